"""Linear relative normalisation helpers shared by the regression baselines.

Relative radiometric normalisation fits ``reference ~ gain * target + offset`` on pixels
at the same position in both images and applies the map to the target. The methods assume
co-registered images; the two images of a stereo pair are co-registered only up to the
parallax, which is tens of pixels on close-range or urban scenes. :func:`aligned_views`
therefore first shifts the target along the rows by the pair's dominant disparity (the
peak of the phase correlation), so that most pixel pairs show the same ground; what
parallax remains acts like the misregistration these methods are built to tolerate.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from radcons.errors import InputError

__all__ = [
    "LinearFit", "check_pair", "dominant_disparity", "aligned_views", "paired_pixels",
    "weighted_least_squares", "orthogonal_regression", "apply_linear",
]


@dataclass(frozen=True)
class LinearFit:
    """``reference ~ gain * target + offset``, fitted on ``n_used`` pixels."""

    gain: float
    offset: float
    n_used: int


def check_pair(reference: np.ndarray, target: np.ndarray) -> None:
    """Raise :class:`InputError` unless both images are 2-D, of one shape, with valid pixels."""
    if reference.ndim != 2 or reference.shape != target.shape:
        raise InputError(
            f"normalisation needs two 2-D images of the same shape, got {reference.shape} and {target.shape}"
        )
    for name, image in (("reference", reference), ("target", target)):
        if not np.isfinite(image).any():
            raise InputError(f"the {name} image has no valid pixel")


def dominant_disparity(reference: np.ndarray, target: np.ndarray) -> int:
    """Integer disparity d of the phase-correlation peak: ``reference(x) ~ target(x - d)``.

    NaN pixels are filled with their image's mean and a Hann window tapers the borders.
    """
    check_pair(reference, target)
    filled = [np.where(np.isfinite(im), im, np.nanmean(im)).astype(np.float64) for im in (reference, target)]
    window = cv2.createHanningWindow(reference.shape[::-1], cv2.CV_64F)
    (shift_x, _), _ = cv2.phaseCorrelate(filled[0], filled[1], window)
    return int(round(-shift_x))


def aligned_views(
    reference: np.ndarray, target: np.ndarray, align: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """Views of both images in which equal positions are paired.

    With ``align`` the target is shifted along the rows by :func:`dominant_disparity` (the
    columns with no partner are cut); without it the images are returned as they are.
    """
    check_pair(reference, target)
    if not align:
        return reference, target
    d = dominant_disparity(reference, target)
    width = reference.shape[1]
    if abs(d) >= width - 1:
        return reference, target
    if d >= 0:
        return reference[:, d:], target[:, : width - d]
    return reference[:, : width + d], target[:, -d:]


def paired_pixels(reference: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return ``(x, y, mask)``: target values, reference values, where both are valid.

    Raises
    ------
    InputError
        Fewer than 2 pixels valid in both images.
    """
    check_pair(reference, target)
    mask = np.isfinite(reference) & np.isfinite(target)
    if np.count_nonzero(mask) < 2:
        raise InputError("the reference and the target share fewer than 2 valid pixels")
    return target[mask].astype(np.float64), reference[mask].astype(np.float64), mask


def _weighted_moments(
    x: np.ndarray, y: np.ndarray, w: np.ndarray
) -> tuple[float, float, float, float, float]:
    """Weighted means of x and y, variances of x and y, covariance."""
    total = w.sum()
    if not total > 0:
        raise InputError("no pixel has a positive weight: cannot fit a linear map")
    mx, my = float(np.sum(w * x) / total), float(np.sum(w * y) / total)
    dx, dy = x - mx, y - my
    sxx, syy, sxy = (float(np.sum(w * a * b) / total) for a, b in ((dx, dx), (dy, dy), (dx, dy)))
    return mx, my, sxx, syy, sxy


def weighted_least_squares(x: np.ndarray, y: np.ndarray, w: np.ndarray | None = None) -> LinearFit:
    """Weighted least-squares line ``y ~ gain * x + offset``."""
    w = np.ones_like(x) if w is None else w
    mx, my, sxx, _, sxy = _weighted_moments(x, y, w)
    if not sxx > 0:
        raise InputError("the weighted target values are constant: cannot fit a gain")
    gain = sxy / sxx
    return LinearFit(gain, my - gain * mx, int(np.count_nonzero(w > 0)))


def orthogonal_regression(x: np.ndarray, y: np.ndarray, w: np.ndarray | None = None) -> LinearFit:
    """Orthogonal (total least squares) line ``y ~ gain * x + offset``.

    Both variables carry noise, so the line minimises perpendicular distances (Canty and
    Nielsen 2008 use it for the same reason).
    """
    w = np.ones_like(x) if w is None else w
    mx, my, sxx, syy, sxy = _weighted_moments(x, y, w)
    if sxy == 0:
        raise InputError("the reference and the target are uncorrelated: cannot fit a line")
    gain = (syy - sxx + np.sqrt((syy - sxx) ** 2 + 4.0 * sxy**2)) / (2.0 * sxy)
    return LinearFit(float(gain), float(my - gain * mx), int(np.count_nonzero(w > 0)))


def apply_linear(target: np.ndarray, fit: LinearFit) -> np.ndarray:
    """``gain * target + offset`` as float32, NaN kept."""
    return (fit.gain * target.astype(np.float64) + fit.offset).astype(np.float32)
