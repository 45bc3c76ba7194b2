"""Sharpness consistency: one point spread for both images of a pair (not in the paper).

Su et al. (2018), section 5, bring the two images of a mixed pair to one smoothness level
by denoising both with one union threshold. Sensors differ in their point spread (MTF) as
much as in their noise, and denoising does not change a point spread: a target from a
blurrier sensor stays blurrier, and the matching cost (SGBM's, on the x-derivative)
compares a sharp reference edge with a soft target one. This stage estimates the relative
blur of the pair from the two images and blurs the sharper one by it, so that both have
the same MTF; the blurrier image is left as it is (sharpening would amplify its noise).

Estimation (:func:`relative_blur`):

* Welch power spectra: each image is cut into ``tile`` x ``tile`` tiles overlapping by
  half; a tile holding an invalid (NaN) pixel is skipped; each tile, minus its mean and
  times a 2-D Hann window, gives ``|FFT|^2 / sum(window^2)``, so that white noise of
  standard deviation sigma has the power sigma^2 at every frequency. The tiles' spectra
  are averaged and then averaged over rings one frequency step (``1 / tile`` cycles/px)
  wide.
* Each image's noise power, ``noise_sigma(image) ** 2`` (Donoho's robust estimator,
  :func:`radcons.noise.noise_sigma`), is subtracted from its rings.
* A Gaussian point spread of standard deviation s multiplies the power spectrum by
  ``exp(-4 pi^2 s^2 f^2)``, so with ``s^2 = s_target^2 - s_reference^2`` the log ratio of
  the noise-free spectra is ``log(g^2) - 4 pi^2 s^2 f^2`` (``g`` a remaining contrast
  ratio). It is fitted by least squares over the rings between ``f_low`` and ``f_high``
  (cycles/px) where both noise-free powers exceed ``snr`` times their noise power; the
  signed ``s = sign(s^2) sqrt(|s^2|)`` is positive when the target is the blurrier image.
* Fewer than 3 usable rings (too small, too flat or too noisy an image), or ``|s|`` below
  ``min_sigma``, count as equal MTFs: no blur.

On pairs whose target was blurred the estimate comes close to the blur applied; on pairs
from one sensor it stays within a few tenths of a pixel of zero, hence ``min_sigma``
(0.5 px) below which no blur is applied: blurring one image of a pair from one sensor
lowers its matching rate. The measurements are in ``docs/tuning.md``.

Option ``noise = "cleaner"`` (:mod:`radcons.stages.sharpness.noise_match`): after the
point spreads, where the pair's noise gap is large and reliable (two estimates agree and
reach ``noise_gate``, and the cleaner image's low estimate is not the flat blocks of
clipping or quantisation, ``noise_flat_margin``), the noisier image is smoothed by the
smallest Gaussian (at most ``noise_max_sigma``) that brings its noise sigma (Donoho's
estimator) within ``noise_tolerance`` times the cleaner image's: both images end at the
*cleaner* image's noise level, where the paper's section 5 denoises both towards zero.

The relative blur is a pair-wide quantity computed once; the blur itself is a local
filter, so tiles of a large scene can be processed independently with the scene's value
(pass it as ``SharpnessParams.sigma``); so is the noise matching's Gaussian (pass the
scene's as ``SharpnessParams.denoise``, signed: positive smooths the target).
"""

from __future__ import annotations

import math

import numpy as np

from radcons.noise import noise_sigma
from radcons.numerics.valid_pixels import gaussian_blur
from radcons.results import StageImages
from radcons.stages.sharpness.noise_match import noise_smoothing
from radcons.stages.sharpness.params import SharpnessParams
from radcons.validate import single_band_image

__all__ = [
    "SharpnessParams", "power_spectrum", "relative_blur", "sharpness_consistency",
]

#: Fewest usable frequency rings for a relative blur estimate.
_MIN_RINGS = 3


def _image(image: np.ndarray, name: str) -> np.ndarray:
    return single_band_image(image, name, 16, "is too small for a power spectrum (16 px)")


def power_spectrum(image: np.ndarray, tile: int = 128) -> tuple[np.ndarray, np.ndarray]:
    """Radially averaged Welch power spectrum of an image.

    Parameters
    ----------
    image : ndarray, shape (M, N)
        NaN where invalid; tiles holding an invalid pixel are skipped.
    tile : int
        Tile side, px (even); reduced to the image's largest even square if larger.

    Returns
    -------
    frequency : ndarray, shape (tile // 2,)
        Ring centres, cycles/px: ``k / tile`` for ``k = 1 .. tile / 2``.
    power : ndarray, shape (tile // 2,)
        Mean power of each ring, normalised so that white noise of standard deviation
        sigma gives sigma^2; NaN when no tile is entirely valid.
    """
    image = _image(image, "image")
    tile = min(tile, 2 * (min(image.shape) // 2))
    step = tile // 2
    window = np.outer(np.hanning(tile), np.hanning(tile))
    norm = float((window**2).sum())
    total = np.zeros((tile, tile), np.float64)
    count = 0
    for y in range(0, image.shape[0] - tile + 1, step):
        for x in range(0, image.shape[1] - tile + 1, step):
            block = image[y : y + tile, x : x + tile].astype(np.float64)
            if not np.isfinite(block).all():
                continue
            spectrum = np.fft.fft2((block - block.mean()) * window)
            total += spectrum.real**2 + spectrum.imag**2
            count += 1
    frequency = np.arange(1, tile // 2 + 1) / tile
    if count == 0:
        return frequency, np.full(frequency.shape, np.nan)
    fy = np.fft.fftfreq(tile)[:, None]
    fx = np.fft.fftfreq(tile)[None, :]
    ring = np.rint(np.hypot(fy, fx) * tile).astype(np.int64).ravel()
    inside = (ring >= 1) & (ring <= tile // 2)
    sums = np.bincount(ring[inside] - 1, (total / (count * norm)).ravel()[inside], tile // 2)
    counts = np.bincount(ring[inside] - 1, None, tile // 2)
    return frequency, sums / counts


def relative_blur(reference: np.ndarray, target: np.ndarray, params: SharpnessParams = SharpnessParams()) -> float:
    """Signed relative Gaussian blur of the pair, px: ``sign * sqrt(|s_tgt^2 - s_ref^2|)``.

    See the module docstring for the model and the fit.

    Parameters
    ----------
    reference, target : ndarray
        2-D images on one grey-level scale (after the illumination stages), NaN where
        invalid; they may differ in shape.
    params : SharpnessParams

    Returns
    -------
    float
        Positive when the target is the blurrier image, negative when the reference is;
        0.0 when fewer than 3 frequency rings are usable.

    Raises
    ------
    InputError
        Not 2-D, smaller than 16 px, or no valid pixel.
    """
    reference = _image(reference, "reference")
    target = _image(target, "target")
    frequency, power_ref = power_spectrum(reference, params.tile)
    frequency_tgt, power_tgt = power_spectrum(target, params.tile)
    if frequency_tgt.size != frequency.size:  # images of different sizes: compare on one grid
        size = min(frequency.size, frequency_tgt.size) * 2
        frequency, power_ref = power_spectrum(reference, size)
        _, power_tgt = power_spectrum(target, size)
    noise_ref, noise_tgt = noise_sigma(reference) ** 2, noise_sigma(target) ** 2
    signal_ref, signal_tgt = power_ref - noise_ref, power_tgt - noise_tgt
    with np.errstate(invalid="ignore"):
        usable = (
            (frequency >= params.f_low)
            & (frequency <= params.f_high)
            & (signal_ref > params.snr * noise_ref)
            & (signal_tgt > params.snr * noise_tgt)
            & (signal_ref > 0)
            & (signal_tgt > 0)
        )
    if usable.sum() < _MIN_RINGS:
        return 0.0
    log_ratio = np.log(signal_tgt[usable] / signal_ref[usable])
    design = np.column_stack([np.ones(int(usable.sum())), -4.0 * math.pi**2 * frequency[usable] ** 2])
    (_, s2), *_ = np.linalg.lstsq(design, log_ratio, rcond=None)
    return float(math.copysign(math.sqrt(abs(s2)), s2))


def sharpness_consistency(
    reference: np.ndarray, target: np.ndarray, params: SharpnessParams = SharpnessParams()
) -> StageImages:
    """Blur the sharper image of the pair to the other's point spread.

    Parameters
    ----------
    reference, target : ndarray, shape (M, N)
        The pair after the illumination stages, NaN where invalid.
    params : SharpnessParams

    Returns
    -------
    StageImages
        ``reference`` and ``target`` (float32, NaN kept; the blurrier one unchanged) and
        ``info`` with ``relative_blur`` (the signed estimate, or ``params.sigma``, px),
        ``blurred`` (``"reference"``, ``"target"`` or ``"none"``) and ``sigma`` (the
        Gaussian applied, px); with ``noise = "cleaner"`` also ``denoised`` (the image
        smoothed to the other's noise level, or ``"none"``), ``denoise_sigma`` (px) and
        ``noise_ratio`` / ``block_noise_ratio`` (the two estimates of the gate, before) and
        ``lost_detail`` (the gap refused for the cleaner image's lost detail).

    Raises
    ------
    InputError
        Not 2-D, smaller than 16 px, or no valid pixel.
    """
    reference = _image(reference, "reference")
    target = _image(target, "target")
    estimate = relative_blur(reference, target, params) if params.sigma is None else float(params.sigma)
    sigma = min(params.strength * abs(estimate), params.max_sigma)
    info = {"relative_blur": estimate, "blurred": "none", "sigma": 0.0}
    images = [reference.copy(), target.copy()]
    if abs(estimate) >= params.min_sigma and sigma > 0.0:
        blurred = 0 if estimate > 0 else 1
        info.update(sigma=sigma, blurred=("reference", "target")[blurred])
        images[blurred] = gaussian_blur(images[blurred], sigma)
    if params.noise == "cleaner":
        denoise = params.denoise
        if denoise is None:
            denoise, gap = noise_smoothing(images[0], images[1], params)
            info.update(noise_ratio=gap.ratio, block_noise_ratio=gap.block_ratio, lost_detail=gap.lost_detail)
        info.update(denoised="none", denoise_sigma=0.0)
        if denoise != 0:
            smoothed = int(denoise > 0)
            images[smoothed] = gaussian_blur(images[smoothed], abs(denoise))
            info.update(denoised=("reference", "target")[smoothed], denoise_sigma=abs(denoise))
    return StageImages(images[0], images[1], info)
