"""Simulated date and sensor differences for the target of a real stereo pair.

No public stereo pair with ground truth was taken at two dates by two sensors, so the
evaluation degrades the target of a real pair with ground truth (Middlebury Cones,
Motorcycle) the way a second date and a second sensor would: a different illumination
(gamma, gain, offset), a local overexposure that saturates (the paper's Object 1), a
different sensor point spread (blur) and a different noise level.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from radcons.errors import InputError, ParamsError

__all__ = ["Degradation", "degrade"]


@dataclass(frozen=True)
class Degradation:
    """What :func:`degrade` does to an image, applied in the order of the attributes.

    With ``[low, high]`` the image's value range (finite minimum and maximum) and
    ``u = (v - low) / (high - low)``:

    Attributes
    ----------
    gamma : float
        Illumination nonlinearity: ``v <- low + (high - low) * u ** gamma``.
    gain, offset : float
        Linear radiometric change: ``v <- gain * v + offset``.
    saturate_box : (int, int, int, int) or None
        Rectangle ``(x0, y0, x1, y1)`` (end exclusive) pushed above the range: its values
        are multiplied by ``saturate_factor`` and then clipped at ``high`` with the rest.
    saturate_label : int or None
        Same, for the pixels of this object id of the ``labels`` given to :func:`degrade`.
    saturate_factor : float
        Brightening factor of the saturated region (> 1).
    blur_sigma : float
        Gaussian point spread of the other sensor, in pixels (0 = none). NaN pixels are
        left out of the average (normalised convolution).
    noise_sigma : float
        Standard deviation of additive white Gaussian noise, in the image's units.
    seed : int
        Seed of the noise generator.

    Finally every value is clipped to ``[low, high]``, as a sensor saturates.
    """

    gamma: float = 1.0
    gain: float = 1.0
    offset: float = 0.0
    saturate_box: tuple[int, int, int, int] | None = None
    saturate_label: int | None = None
    saturate_factor: float = 1.5
    blur_sigma: float = 0.0
    noise_sigma: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        if not self.gamma > 0:
            raise ParamsError(f"gamma must be positive, got {self.gamma}")
        if not self.gain > 0:
            raise ParamsError(f"gain must be positive, got {self.gain}")
        if not self.saturate_factor > 0:
            raise ParamsError(f"saturate_factor must be positive, got {self.saturate_factor}")
        if self.blur_sigma < 0 or self.noise_sigma < 0:
            raise ParamsError("blur_sigma and noise_sigma must be >= 0")
        if self.saturate_box is not None:
            x0, y0, x1, y1 = self.saturate_box
            if not (0 <= x0 < x1 and 0 <= y0 < y1):
                raise ParamsError(
                    f"saturate_box must be (x0, y0, x1, y1) with x0 < x1, y0 < y1, got {self.saturate_box}"
                )


def degrade(
    image: np.ndarray, degradation: Degradation, labels: np.ndarray | None = None
) -> np.ndarray:
    """Apply a simulated date / sensor difference to an image.

    Parameters
    ----------
    image : ndarray
        2-D image, NaN where invalid.
    degradation : Degradation
        What to apply (see its attributes for the formulas and their order).
    labels : ndarray of int, optional
        Object labels of ``image``, needed with ``degradation.saturate_label``.

    Returns
    -------
    ndarray of float32
        The degraded image on the input's value range, NaN kept.

    Raises
    ------
    InputError
        Not 2-D, constant, labels missing or of another shape, or the saturated region
        empty.
    """
    image = np.asarray(image, dtype=np.float64)
    if image.ndim != 2:
        raise InputError(f"degrade needs a 2-D image, got shape {image.shape}")
    valid = np.isfinite(image)
    if not valid.any():
        raise InputError("the image has no valid pixel")
    low, high = float(image[valid].min()), float(image[valid].max())
    if not high > low:
        raise InputError("the image is constant")
    span = high - low
    out = low + span * np.clip((image - low) / span, 0.0, 1.0) ** degradation.gamma
    out = degradation.gain * out + degradation.offset
    region = _saturated_region(image.shape, degradation, labels)
    if region is not None:
        out[region] *= degradation.saturate_factor
    if degradation.blur_sigma > 0:
        out = _blur_valid(out, valid, degradation.blur_sigma)
    if degradation.noise_sigma > 0:
        rng = np.random.default_rng(degradation.seed)
        out = out + rng.normal(0.0, degradation.noise_sigma, size=out.shape)
    out = np.clip(out, low, high)
    out[~valid] = np.nan
    return out.astype(np.float32)


def _saturated_region(
    shape: tuple[int, int], degradation: Degradation, labels: np.ndarray | None
) -> np.ndarray | None:
    """Boolean mask of the region pushed above the range, or None."""
    if degradation.saturate_box is None and degradation.saturate_label is None:
        return None
    region = np.zeros(shape, bool)
    if degradation.saturate_box is not None:
        x0, y0, x1, y1 = degradation.saturate_box
        region[y0:y1, x0:x1] = True
    if degradation.saturate_label is not None:
        if labels is None or labels.shape != shape:
            raise InputError("saturate_label needs the image's object labels (same shape)")
        region |= labels == degradation.saturate_label
    if not region.any():
        raise InputError("the saturated region lies outside the image or names no object")
    return region


def _blur_valid(image: np.ndarray, valid: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur that averages valid pixels only (normalised convolution)."""
    weight = ndimage.gaussian_filter(valid.astype(np.float64), sigma, mode="nearest")
    blurred = ndimage.gaussian_filter(np.where(valid, image, 0.0), sigma, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(weight > 0, blurred / weight, np.nan)
