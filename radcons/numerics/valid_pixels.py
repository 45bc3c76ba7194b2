"""Image operations that leave invalid pixels out: a Gaussian blur, the sensor's clipped
pixels, a share of the pair's overlap.

Several stages need them (the background mapping, the refined fits, the sharpness and
noise matching); they live here, below all of them.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["gaussian_blur", "clipped_mask", "clipping_pile", "overlap_share", "CLIP_SHARE", "CLIP_PIXELS"]

#: An image's smallest or largest grey value is a clipping level when at least this share
#: of its valid pixels, and this many, hold it. Unclipped images hold their extremes at a
#: pixel or two (the Pleiades and Middlebury images of the test data); a sensor's clipping
#: piles pixels up there (a bright roof at 255: thousands), and so does a fill value not
#: declared as nodata (the Sentinel-2 crops' zeros), which no fit should use either.
CLIP_SHARE = 1e-4
CLIP_PIXELS = 16


def overlap_share(mask: np.ndarray, reference: np.ndarray, target: np.ndarray) -> float:
    """Share of the pair's overlap (pixels valid in both images) where ``mask`` holds.

    A reference pixel facing the target's nodata (an epipolar frame's corners, a target
    cut by the scene's edge) cannot be matched, so it counts neither for nor against a
    disparity (0.0 when the images do not overlap).
    """
    overlap = np.isfinite(reference) & np.isfinite(target)
    count = int(overlap.sum())
    return float((mask & overlap).sum() / count) if count else 0.0


def gaussian_blur(image: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur of standard deviation ``sigma`` px over the valid pixels only.

    Normalised convolution: invalid (NaN) pixels take no part in their neighbours'
    averages and stay NaN. Borders are reflected.
    """
    image = np.asarray(image, np.float32)
    if sigma <= 0:
        return image.copy()
    valid = np.isfinite(image)
    blurred = cv2.GaussianBlur(np.where(valid, image, np.float32(0)), (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
    if valid.all():
        return blurred
    weight = cv2.GaussianBlur(valid.astype(np.float32), (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
    out = np.full(image.shape, np.nan, np.float32)
    np.divide(blurred, weight, out=out, where=valid & (weight > 0))
    return out


def clipping_pile(count: int) -> float:
    """Fewest pixels at an image's extreme value that make it a clipping level, of ``count`` valid ones."""
    return max(CLIP_PIXELS, CLIP_SHARE * count)


def clipped_mask(image: np.ndarray) -> np.ndarray:
    """Pixels clipped by the sensor: the image's extreme grey values, where they pile up.

    A grey value is a clipping level when it is the smallest or the largest valid value
    of the image and at least ``max(16, 1e-4 N)`` of its ``N`` valid pixels hold it. Such
    pixels only bound the scene's grey value (a roof brighter than the sensor's range
    reads 255 in an 8-bit image however bright it is).

    Parameters
    ----------
    image : ndarray
        2-D image, NaN where invalid.

    Returns
    -------
    ndarray of bool
        True on the clipped pixels (all False when no extreme piles up).
    """
    image = np.asarray(image)
    valid = np.isfinite(image)
    clipped = np.zeros(image.shape, bool)
    count = int(valid.sum())
    if count == 0:
        return clipped
    values = image[valid]
    pile = clipping_pile(count)
    for level in {values.min(), values.max()}:
        at_level = image == level
        if at_level.sum() >= pile:
            clipped |= at_level
    return clipped
