"""Objects (buildings) from one image: the morphological building index (section 3).

The paper segments buildings with Shu et al.'s non-negative low-rank sparse correlation
mapping, which has no public implementation. radcons uses a morphological building index
(MBI, Huang and Zhang 2012) instead: it is made for building roofs on high-resolution
urban imagery, needs no training, and costs a few OpenCV morphological operations:

1. invalid pixels are filled with the nearest valid value and the image is smoothed with
   a small Gaussian (``smooth_sigma``) so single noisy pixels do not form structures;
2. for each of four directions (0, 45, 90, 135 degrees) the white top-hat with a linear
   structuring element of length ``max_size`` minus the one of length ``min_size`` keeps
   the bright structures shorter than ``max_size`` and wider than ``min_size`` along that
   direction; the MBI is the mean over the directions (roofs are short in every
   direction and score in all four, roads in three at most). With plain openings the
   top-hat grows monotonically with the length, so Huang and Zhang's sum of differential
   profiles over all lengths reduces to these two lengths; plain openings replace their
   openings by reconstruction, which are much slower;
3. the MBI is thresholded at the larger of Otsu's threshold and ``min_contrast`` times the
   image's noise level (Donoho's robust estimator), so an image with nothing standing out
   of its noise yields no objects;
4. the mask is cleaned (opening with a 3 x 3 square, holes filled), split into
   8-connected components, and components smaller than ``min_area`` pixels are dropped.

``polarity = "dark"`` runs the same on the inverted image (dark roofs); ``"both"`` joins
the two masks. The MBI misses roofs no brighter than their surroundings. A graph
segmentation finds those too, but it cuts the ground into hundreds of objects and splits
uniform roofs into pieces.

The ``paper`` preset uses this path, and the height method
(:mod:`radcons.stages.objects.run`) falls back to it when the pair's census disparity fails.

References
----------
Huang, X., Zhang, L. (2012). Morphological building/shadow index for building extraction
from high-resolution imagery over urban areas. IEEE JSTARS 5(1), 161-172.
Otsu, N. (1979). A threshold selection method from gray-level histograms. IEEE SMC 9(1).
"""

from __future__ import annotations

import cv2
import numpy as np
import scipy.ndimage
from skimage.filters import threshold_otsu

from radcons.noise import noise_sigma
from radcons.numerics.labels import relabel
from radcons.stages.objects.params import ObjectsParams
from radcons.validate import single_band_image

__all__ = ["building_index", "extract_objects"]


def _line(length: int, angle: int) -> np.ndarray:
    """Linear structuring element of ``length`` pixels at 0, 45, 90 or 135 degrees."""
    if angle == 0:
        return np.ones((1, length), np.uint8)
    if angle == 90:
        return np.ones((length, 1), np.uint8)
    diagonal = np.eye(length, dtype=np.uint8)
    return diagonal[::-1] if angle == 45 else diagonal


def building_index(image: np.ndarray, params: ObjectsParams = ObjectsParams()) -> np.ndarray:
    """Morphological building index of a finite image (bright structures).

    The openings run on the image quantised to 16 bits over its own range (OpenCV's
    morphology is faster on uint16 than on float32); the index is returned in
    the image's grey levels.

    Parameters
    ----------
    image : ndarray, shape (M, N), float32
        Finite image (invalid pixels already filled).
    params : ObjectsParams

    Returns
    -------
    ndarray, shape (M, N), float32
        ``mean_d [tophat(d, max_size) - tophat(d, min_size)]``, >= 0, in grey levels.
    """
    low, high = float(image.min()), float(image.max())
    if high <= low:
        return np.zeros(image.shape, np.float32)
    step = (high - low) / 65535.0
    quantised = np.rint((image - np.float32(low)) * np.float32(1.0 / step)).astype(np.uint16)
    total = np.zeros(image.shape, np.int32)
    for angle in (0, 45, 90, 135):
        total += cv2.morphologyEx(quantised, cv2.MORPH_OPEN, _line(params.min_size, angle))
        total -= cv2.morphologyEx(quantised, cv2.MORPH_OPEN, _line(params.max_size, angle))
    return total.astype(np.float32) * np.float32(step / 4.0)


def _mask(index: np.ndarray, valid: np.ndarray, floor: float) -> np.ndarray:
    """``index > max(Otsu threshold, floor)`` on valid pixels (Otsu on a 1024-bin histogram)."""
    values = index[valid]
    top = float(values.max(initial=0.0))
    if top <= floor:
        return np.zeros(index.shape, bool)
    bins = np.minimum((values * np.float32(1023.0 / top)).astype(np.int32), 1023)
    counts = np.bincount(bins, minlength=1024)
    centres = (np.arange(1024) + 0.5) * (top / 1023.0)
    threshold = max(float(threshold_otsu(hist=(counts, centres))), floor)
    return (index > threshold) & valid


def _fill_holes(mask: np.ndarray) -> np.ndarray:
    """Fill the background areas not connected (4-neighbours) to the image border."""
    outside = np.pad(~mask, 1, constant_values=True).astype(np.uint8)
    cv2.floodFill(outside, None, (0, 0), 2)
    return outside[1:-1, 1:-1] != 2


def _mbi_objects(image: np.ndarray, valid: np.ndarray, floor: float, params: ObjectsParams) -> np.ndarray:
    """Steps 1-4 of the module notes on a filled image: the objects of its valid pixels, 1..K."""
    if params.smooth_sigma > 0:
        image = cv2.GaussianBlur(image, (0, 0), params.smooth_sigma, borderType=cv2.BORDER_REFLECT)
    mask = np.zeros(image.shape, bool)
    if params.polarity in ("bright", "both"):
        mask |= _mask(building_index(image, params), valid, floor)
    if params.polarity in ("dark", "both"):
        mask |= _mask(building_index(-image, params), valid, floor)
    mask = cv2.morphologyEx(mask.view(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)).astype(bool)
    mask = _fill_holes(mask) & valid
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.view(np.uint8), connectivity=8, ltype=cv2.CV_32S)
    return relabel(labels, stats[:, cv2.CC_STAT_AREA] >= params.min_area)


def extract_objects(image: np.ndarray, params: ObjectsParams = ObjectsParams()) -> np.ndarray:
    """Segment the buildings of an image into labelled objects.

    Parameters
    ----------
    image : ndarray, shape (M, N)
        Single-band image, NaN where invalid (any real dtype; computed in float32).
    params : ObjectsParams

    Returns
    -------
    ndarray, shape (M, N), int32
        0 = background (and invalid pixels), 1..K the objects.

    Raises
    ------
    InputError
        Not 2-D, empty, not real numbers, or no valid pixel.
    """
    image = single_band_image(image, "image", 1, "is empty")
    valid = np.isfinite(image)
    floor = params.min_contrast * noise_sigma(image)
    if not valid.all():
        nearest = scipy.ndimage.distance_transform_edt(~valid, return_distances=False, return_indices=True)
        image = image[tuple(nearest)]
    return _mbi_objects(image, valid, floor, params)
