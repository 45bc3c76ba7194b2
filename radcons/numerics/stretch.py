"""Linear stretches of a float image to 8 bits between robust grey levels.

SIFT, Felzenszwalb segmentation, edge detection and OpenCV's matchers work on 8-bit
images; satellite images come as 11/12-bit integers or floats. Every stretch here maps the
image's 0.5th-99.5th percentile range (:data:`STRETCH_PERCENTILES`, :func:`robust_range`)
linearly to 0-255, so that a few saturated or dead pixels do not take the contrast of the
rest.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["STRETCH_PERCENTILES", "robust_range", "stretch8", "stretch_for_detection", "stretch_to_uint8"]

#: Percentiles of the valid pixels mapped to 0 and 255.
STRETCH_PERCENTILES = (0.5, 99.5)


def robust_range(values: np.ndarray) -> tuple[float, float]:
    """The :data:`STRETCH_PERCENTILES` of ``values`` (finite values, at least one).

    Parameters
    ----------
    values : ndarray
        The valid grey values (any shape).

    Returns
    -------
    low, high : numpy float64
        The grey values a stretch maps to 0 and 255.
    """
    low, high = np.percentile(values, STRETCH_PERCENTILES)
    return low, high


def stretch8(image: np.ndarray) -> np.ndarray:
    """The image's robust range mapped to 0..255 (uint8), NaN as 0."""
    valid = np.isfinite(image)
    low, high = robust_range(image[valid]) if valid.any() else (0.0, 1.0)
    scale = 255.0 / (high - low) if high > low else 1.0
    return np.clip((np.where(valid, image, low) - low) * scale, 0, 255).astype(np.uint8)


def stretch_for_detection(image: np.ndarray, border: int) -> tuple[np.ndarray, np.ndarray]:
    """The image's robust range mapped to 8 bits, and its keypoint detection mask.

    See :func:`stretch_to_uint8`; an image without a valid pixel gives zeros and an empty mask.
    """
    valid = np.isfinite(image)
    if not valid.any():
        return np.zeros(image.shape, np.uint8), valid.view(np.uint8)
    return stretch_to_uint8(image, robust_range(image[valid]), border, valid)


def stretch_to_uint8(
    image: np.ndarray, levels: tuple[float, float], border: int, valid: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """``image`` mapped linearly from ``levels`` (low, high) to 0-255, clipped, and the detection
    mask: its valid (finite) pixels, eroded by ``border`` px where some are not.

    Parameters
    ----------
    image : ndarray
        Float image (NaN where unknown).
    levels : (float, float)
        Grey values mapped to 0 and 255 (an image of zeros when high <= low).
    border : int
        Keypoints no nearer than this to an unknown pixel.
    valid : ndarray of bool, optional
        ``np.isfinite(image)`` when the caller has it.

    Returns
    -------
    image8 : ndarray of uint8
        The stretched image.
    mask : ndarray of uint8
        1 where keypoints may be detected.
    """
    valid = np.isfinite(image) if valid is None else valid
    low, high = levels
    out = np.zeros(image.shape, np.uint8)
    if high > low:
        scaled = (np.where(valid, image, low) - np.float32(low)) * np.float32(255.0 / (high - low))
        out = np.clip(scaled, 0, 255).astype(np.uint8)
    mask = valid.view(np.uint8)
    if border > 0 and not valid.all():
        mask = cv2.erode(mask, np.ones((2 * border + 1, 2 * border + 1), np.uint8))
    return out, mask
