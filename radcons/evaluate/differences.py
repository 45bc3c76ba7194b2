"""The single date / sensor differences the randomised benchmark composes.

Each function applies one difference to a float image normalised to ``u`` in ``[0, 1]``
(NaN where invalid, kept), by its definition below; :mod:`radcons.evaluate.simulate`
samples their parameters and composes them. The random ones take a ``numpy`` generator,
so that a seed fixes the result.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from scipy import ndimage

from radcons.errors import InputError, ParamsError

__all__ = [
    "tone_curve",
    "quantise",
    "gaussian_blur",
    "add_noise",
    "light_field",
    "cast_shadows",
    "clip_objects",
    "jpeg_roundtrip",
]


def tone_curve(u: np.ndarray, gamma: float, s_curve: float, gain: float, offset: float) -> np.ndarray:
    """Another date's illumination and another sensor's response, monotone.

    ``v = gain * S(u ** gamma) + offset`` with ``S(t) = t - s sin(2 pi t) / (2 pi)``: S fixes
    0, 1/2 and 1 and has slope ``1 + s`` at 1/2 (``s > 0`` raises mid-tone contrast, ``s <
    0`` lowers it); it is monotone for ``|s| < 1``. Values are not clipped here.
    """
    if not gamma > 0 or not gain > 0 or not abs(s_curve) < 1:
        raise ParamsError(f"tone curve needs gamma > 0, gain > 0, |s| < 1; got {gamma}, {gain}, {s_curve}")
    t = np.clip(u, 0.0, 1.0) ** gamma
    return gain * (t - s_curve * np.sin(2.0 * math.pi * t) / (2.0 * math.pi)) + offset


def quantise(u: np.ndarray, bits: int, fill: float) -> np.ndarray:
    """Record ``u`` with a ``bits``-bit sensor whose signal fills ``fill`` of its range.

    Returns the integer counts ``round(clip(u, 0, 1) * fill * (2**bits - 1))`` as float
    (NaN kept): an 8-bit target so recorded keeps ``fill * 255 + 1`` grey levels, an 11- or
    12-bit one is on another value range than an 8-bit reference.
    """
    if bits not in (8, 11, 12) or not 0 < fill <= 1:
        raise ParamsError(f"bit depth must be 8, 11 or 12 and fill in (0, 1]; got {bits}, {fill}")
    return np.rint(np.clip(u, 0.0, 1.0) * (fill * (2**bits - 1)))


def gaussian_blur(u: np.ndarray, sigma: float) -> np.ndarray:
    """Another point spread: Gaussian of ``sigma`` px over the valid pixels (normalised convolution)."""
    if sigma < 0:
        raise ParamsError(f"blur sigma must be >= 0, got {sigma}")
    if sigma == 0:
        return u.copy()
    valid = np.isfinite(u)
    weight = ndimage.gaussian_filter(valid.astype(np.float64), sigma, mode="nearest")
    blurred = ndimage.gaussian_filter(np.where(valid, u, 0.0), sigma, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(valid & (weight > 0), blurred / weight, np.nan)


def add_noise(u: np.ndarray, sigma: float, signal_gain: float, rng: np.random.Generator) -> np.ndarray:
    """Sensor noise: zero-mean Gaussian of variance ``sigma**2 + signal_gain * u``.

    ``signal_gain = 0`` is white Gaussian noise; ``signal_gain > 0`` adds the photon
    (Poisson-like) part that grows with the signal.
    """
    if sigma < 0 or signal_gain < 0:
        raise ParamsError(f"noise sigma and signal gain must be >= 0, got {sigma}, {signal_gain}")
    std = np.sqrt(sigma**2 + signal_gain * np.clip(np.nan_to_num(u), 0.0, None))
    return u + std * rng.standard_normal(u.shape)


def light_field(
    u: np.ndarray, gradient: float, angle: float, vignetting: float, haze: float, haze_level: float
) -> np.ndarray:
    """Spatially varying light: a linear gradient, vignetting and haze.

    With ``(x, y)`` the pixel centre relative to the image centre and ``r`` its distance
    over the half diagonal: ``v = u * (1 + gradient * p) * (1 - vignetting * r**2)``,
    ``p = (x cos(angle) + y sin(angle)) / half diagonal`` in ``[-1, 1]``; then haze (an
    airlight over a transmission growing along the same direction),
    ``v <- v * t + haze_level * (1 - t)``, ``t = 1 - haze * (1 + p) / 2``.
    """
    if not 0 <= gradient < 1 or not 0 <= vignetting < 1 or not 0 <= haze < 1:
        raise ParamsError("gradient, vignetting and haze must lie in [0, 1)")
    rows, cols = u.shape
    y, x = np.mgrid[0:rows, 0:cols].astype(np.float64)
    x -= (cols - 1) / 2.0
    y -= (rows - 1) / 2.0
    half_diagonal = max(math.hypot(rows, cols) / 2.0, 1.0)
    p = (x * math.cos(angle) + y * math.sin(angle)) / half_diagonal
    r2 = (x**2 + y**2) / half_diagonal**2
    v = u * (1.0 + gradient * p) * (1.0 - vignetting * r2)
    t = 1.0 - haze * (1.0 + p) / 2.0
    return v * t + haze_level * (1.0 - t)


def shadow_mask(shape: tuple[int, int], count: int, area: float, rng: np.random.Generator) -> np.ndarray:
    """``count`` random filled ellipses covering about ``area`` of the image (bool)."""
    if count < 1 or not 0 < area < 1:
        raise ParamsError(f"shadow count must be >= 1 and area in (0, 1); got {count}, {area}")
    rows, cols = shape
    mask = np.zeros(shape, np.uint8)
    each = area * rows * cols / count
    for _ in range(count):
        elongation = rng.uniform(1.0, 4.0)
        minor = math.sqrt(each / (math.pi * elongation))
        axes = (max(1, round(minor * elongation)), max(1, round(minor)))
        centre = (int(rng.integers(0, cols)), int(rng.integers(0, rows)))
        cv2.ellipse(mask, centre, axes, float(rng.uniform(0, 180)), 0, 360, 1, thickness=-1)
    return mask.astype(bool)


def cast_shadows(u: np.ndarray, mask: np.ndarray, darkening: float, softness: float = 1.0) -> np.ndarray:
    """Shadows cast on one date only: ``v = u * (1 - darkening * m)``.

    ``m`` is ``mask`` blurred by a Gaussian of ``softness`` px (the penumbra), 1 deep inside.
    """
    if not 0 < darkening < 1:
        raise ParamsError(f"shadow darkening must lie in (0, 1), got {darkening}")
    if mask.shape != u.shape:
        raise InputError(f"shadow mask {mask.shape} and image {u.shape} differ in shape")
    soft = ndimage.gaussian_filter(mask.astype(np.float64), softness) if softness > 0 else mask.astype(np.float64)
    return u * (1.0 - darkening * soft)


def clip_objects(u: np.ndarray, region: np.ndarray, factor: float) -> np.ndarray:
    """Over-exposed objects: ``v = min(u * factor, 1)`` inside ``region``, ``u`` elsewhere."""
    if not factor > 1:
        raise ParamsError(f"clipping factor must be > 1, got {factor}")
    if region.shape != u.shape:
        raise InputError(f"clipped region {region.shape} and image {u.shape} differ in shape")
    return np.where(region, np.minimum(u * factor, 1.0), u)


def jpeg_roundtrip(u: np.ndarray, quality: int) -> np.ndarray:
    """Lossy compression: ``u`` coded as an 8-bit JPEG of ``quality`` and decoded.

    Values are clipped to ``[0, 1]`` and scaled to 0..255 for the coder, and the decoded
    grey levels scaled back; NaN pixels are coded as 0 and stay NaN.
    """
    if not 1 <= quality <= 100:
        raise ParamsError(f"JPEG quality must lie in 1..100, got {quality}")
    valid = np.isfinite(u)
    grey = np.rint(np.clip(np.where(valid, u, 0.0), 0.0, 1.0) * 255.0).astype(np.uint8)
    ok, coded = cv2.imencode(".jpg", grey, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise InputError("JPEG coding failed")
    decoded = cv2.imdecode(coded, cv2.IMREAD_GRAYSCALE).astype(np.float64) / 255.0
    return np.where(valid, decoded, np.nan)
