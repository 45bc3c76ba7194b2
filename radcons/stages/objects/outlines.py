"""The final objects' outlines: cast shadows cut off, the rim snapped to the roof's edge.

The height method's regions (:func:`radcons.stages.objects.regions.segment_elevated`) come
from a census disparity on a reduced grid, snapped to the reference's edges by a
watershed of image segments. Two errors are left on the outline of the objects found:

**Spill onto the shadow** (:func:`trim_shadows`). The disparity's semi-global smoothing
carries a roof's disparity onto the ground beside it, and a cast shadow there has too
little texture to pull it back: the region spills from the roof onto its shadow.
Matching cannot take the spill off again: near the outline, the spilled pixels match the
ground's disparity no better than the roof's own rim pixels do. Their grey level can:
far more of them than of the roof's pixels are darker than half the object's median grey
level. So each object loses its pixels darker than ``ratio`` times its own median (the
reference smoothed over 0.5 m) and keeps the largest 4-connected part of the rest with
the holes that part encloses (dark roof furniture stays). A roof whose dark part would
be half of it or more (:data:`MIN_KEPT`: one slope of a gable in the shade, a dark roof
with a bright wing) is left whole. A shadow cast onto a roof by a taller part of it,
where it reaches the outline, is cut off too.

**An outline a pixel or two off the edge** (:func:`snap_rims`). The segments are cut on
an image smoothed at the segmentation's scale, and a watershed line falls on either side
of the edge: many of the pixels wrong in an object that covers its building lie within a
pixel or two of the building's outline. Each pixel within ``band`` px of an object's
outline, inside or out, is given to the object when its grey level is nearer the
object's own grey level beside it than the ground's: the means of the object's pixels
:data:`RING` px further in, and of the free pixels that far out, each weighted by a
Gaussian of :data:`LOCAL_SIGMA` px around the pixel (normalised convolution), so that
each side of a building is judged against its own neighbours (grass on one side, its
shadow on another). A pixel is judged only where the two means differ by more than
:data:`MIN_CONTRAST` of the object's median grey level; an object never takes another's
pixels or invalid ones, keeps its largest 4-connected part, and is left as it was when
that part would be less than :data:`MIN_SNAPPED` of it. Holes are not filled: a
courtyard is no roof. The band is in pixels, not metres: the outline's error is the
segmentation's, a pixel or two at any resolution.

:func:`candidate_outlines` gives a candidate roof of the searches the same treatment
before its shape is judged.

References
----------
Knutsson, H., Westin, C.-F. (1993). Normalized and differential convolution. CVPR 1993,
515-523.
"""

from __future__ import annotations

import cv2
import numpy as np
import scipy.ndimage

__all__ = [
    "trim_shadows", "snap_rims", "open_parts", "candidate_outlines", "MIN_KEPT", "MIN_SNAPPED", "RING", "LOCAL_SIGMA",
    "MIN_CONTRAST", "SPUR_M",
]

#: An object keeps at least this share of its pixels when its shadow is cut, or is left whole.
MIN_KEPT = 0.5
#: An object keeps at least this share of its pixels when its rim is snapped, or is left as it was.
MIN_SNAPPED = 0.7
#: Width (px) of the rings beyond the band whose grey levels stand for the object and the ground.
RING = 3.0
#: Sigma (px) of the Gaussian that makes those grey levels local.
LOCAL_SIGMA = 4.0
#: Least difference between the two, as a share of the object's median grey level.
MIN_CONTRAST = 0.1
#: Radius (m) of the disc that opens a candidate roof before its shape is judged
#: (:func:`candidate_outlines`): strips and spurs narrower than the disc are cut off.
SPUR_M = 0.75
#: Below this Gaussian-weighted share of ring pixels around a pixel, its local mean is unknown.
_MIN_WEIGHT = 0.02


def _check_shapes(labels: np.ndarray, image: np.ndarray) -> None:
    """Refuse labels and an image of different shapes (ValueError)."""
    if labels.shape != image.shape:
        raise ValueError(f"labels {labels.shape} and image {image.shape} differ in shape")


def _largest_part(mask: np.ndarray) -> np.ndarray | None:
    """The largest 4-connected part of ``mask`` (None when it is empty)."""
    parts, count = scipy.ndimage.label(mask)
    if count == 0:
        return None
    sizes = np.bincount(parts.ravel())
    sizes[0] = 0
    return parts == sizes.argmax()


def trim_shadows(labels: np.ndarray, smooth: np.ndarray, ratio: float) -> np.ndarray:
    """Each object without its dark pixels: the largest part of the rest, holes filled.

    Parameters
    ----------
    labels : ndarray of int
        Objects 1..K of the reference (0 = background).
    smooth : ndarray
        The reference smoothed (NaN-free, e.g.
        :attr:`radcons.stages.objects.features.ImageScales.smooth`), same shape.
    ratio : float
        Pixels darker than ``ratio`` times the object's median grey level are cut
        (0: nothing is).

    Returns
    -------
    ndarray of int32
        The objects, ids unchanged; an object whose kept part would be less than
        :data:`MIN_KEPT` of it is left whole.
    """
    _check_shapes(labels, smooth)
    out = labels.astype(np.int32, copy=True)
    if ratio <= 0:
        return out
    for index, box in enumerate(scipy.ndimage.find_objects(out), start=1):
        if box is None:
            continue
        mask = labels[box] == index
        grey = smooth[box]
        dark = mask & (grey < ratio * float(np.median(grey[mask])))
        if not dark.any():
            continue
        part = _largest_part(mask & ~dark)
        if part is None:
            continue
        kept = scipy.ndimage.binary_fill_holes(part) & mask
        if kept.sum() < MIN_KEPT * mask.sum():
            continue
        out[box][mask & ~kept] = 0
    return out


def _local_mean(image: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Gaussian-weighted mean of ``image`` over the pixels of ``weight`` (NaN where too few)."""
    total = cv2.GaussianBlur(image * weight, (0, 0), LOCAL_SIGMA)
    share = cv2.GaussianBlur(weight, (0, 0), LOCAL_SIGMA)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(share > _MIN_WEIGHT, total / share, np.nan)


def snap_rims(labels: np.ndarray, reference: np.ndarray, band: float) -> np.ndarray:
    """Each object's rim given to the side, object or ground, whose grey level it is nearer.

    Parameters
    ----------
    labels : ndarray of int
        Objects 1..K of the reference (0 = background).
    reference : ndarray
        The reference, NaN where invalid, same shape.
    band : float
        Pixels within this distance (px) of an object's outline, on either side, are
        judged (0: none is).

    Returns
    -------
    ndarray of int32
        The objects, ids unchanged (see the module notes).
    """
    _check_shapes(labels, reference)
    out = labels.astype(np.int32, copy=True)
    if band <= 0 or not out.any():
        return out
    valid = np.isfinite(reference)
    image = np.where(valid, reference, 0.0).astype(np.float32)
    margin = int(np.ceil(band + RING + 3 * LOCAL_SIGMA))
    rows, cols = out.shape
    for index, box in enumerate(scipy.ndimage.find_objects(out), start=1):  # the boxes before any snap
        if box is None:
            continue
        wide = (
            slice(max(box[0].start - margin, 0), min(box[0].stop + margin, rows)),
            slice(max(box[1].start - margin, 0), min(box[1].stop + margin, cols)),
        )
        owned = out[wide]
        mask = owned == index
        seen = valid[wide]
        free = ((owned == 0) | mask) & seen
        grey = image[wide]
        inside = cv2.distanceTransform(mask.astype(np.uint8), cv2.DIST_L2, 3)
        outside = cv2.distanceTransform((~mask).astype(np.uint8), cv2.DIST_L2, 3)
        roof = _local_mean(grey, (mask & seen & (inside > band) & (inside <= band + RING)).astype(np.float32))
        ground = _local_mean(grey, (free & ~mask & (outside > band) & (outside <= band + RING)).astype(np.float32))
        level = abs(float(np.median(grey[mask & seen]))) if (mask & seen).any() else 0.0
        near = (mask & seen & (inside <= band)) | (free & ~mask & (outside <= band))
        rim = near & (np.abs(roof - ground) > MIN_CONTRAST * level)
        snapped = mask.copy()
        snapped[rim] = np.abs(grey[rim] - roof[rim]) < np.abs(grey[rim] - ground[rim])
        part = _largest_part(snapped)
        if part is None or part.sum() < MIN_SNAPPED * mask.sum():
            continue
        owned[mask & ~part] = 0
        owned[part] = index
    return out


def open_parts(labels: np.ndarray, radius: int) -> np.ndarray:
    """Each object opened by a disc of ``radius`` px and cut to its largest 4-connected part.

    Strips and spurs narrower than the disc (a façade strip along the roof, a line of
    pixels where a segment followed a kerb) are cut off; the roof's body stays.

    Parameters
    ----------
    labels : ndarray of int
        Objects 1..K (0 = background).
    radius : int
        Radius of the disc, px (0: the objects are returned as they are).

    Returns
    -------
    ndarray of int32
        The objects, ids unchanged; one opened away entirely is gone.
    """
    out = labels.astype(np.int32, copy=True)
    if radius <= 0:
        return out
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1,) * 2)
    for index, box in enumerate(scipy.ndimage.find_objects(out), start=1):
        if box is None:
            continue
        wide = tuple(slice(max(part.start - radius, 0), part.stop + radius) for part in box)
        mask = out[wide] == index
        opened = cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_OPEN, kernel) > 0
        part = _largest_part(opened)
        out[wide][mask] = 0
        if part is not None:
            out[wide][part] = index
    return out


def candidate_outlines(
    candidates: np.ndarray, taken: np.ndarray, reference: np.ndarray, smooth: np.ndarray, params: object, gsd: float
) -> np.ndarray:
    """Candidate roofs given the final objects' outline treatment before their shape is judged.

    A verified segment or union of segments follows the segmentation's lines: it spills
    onto the shadow and the façade strip beside its roof, and a spur of it runs along a
    kerb. Its shape would then read as no roof's. Here each candidate loses its shadow
    (:func:`trim_shadows`), its rim is snapped (:func:`snap_rims`), it gives up the pixels
    of objects already found, and it is opened by a disc of radius :data:`SPUR_M` m,
    rounded to whole pixels (:func:`open_parts`).

    Parameters
    ----------
    candidates : ndarray of int
        The candidate roofs 1..K (0 elsewhere).
    taken : ndarray of bool
        The pixels of the objects found so far.
    reference : ndarray
        The reference, NaN where invalid.
    smooth : ndarray
        The reference smoothed over 0.5 m, NaN-free.
    params : ObjectsParams
        ``shadow_trim`` and ``outline_band`` are used.
    gsd : float
        Ground sample distance, m.

    Returns
    -------
    ndarray of int32
        The candidates, ids unchanged.
    """
    out = snap_rims(trim_shadows(candidates, smooth, params.shadow_trim), reference, params.outline_band)
    out[taken] = 0
    return open_parts(out, int(round(SPUR_M / gsd)))
