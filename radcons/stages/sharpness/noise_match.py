"""Noise matching of a pair: the noisier image smoothed to the cleaner one's noise level.

Used by the sharpness stage's option ``noise = "cleaner"`` (not in the paper: its section
5 denoises both images towards zero; here both images end at the *cleaner* image's noise
level). Three steps:

* **Is the gap real?** (:func:`noise_gap`). Donoho's estimator
  (:func:`radcons.noise.noise_sigma`, the median absolute finest diagonal Haar
  coefficient) reads fine texture as noise, so a pair whose *texture contrast* differs
  (a shadow cast on one date flattens the texture under it; an object clipped on one
  date loses its texture) shows a noise "gap" where both images carry the same noise.
  Such gaps stay below those of noise added to one image, so the gap is taken as real
  only when the Donoho ratio **and** the median of the per-block ratio (the same
  estimator on ``block`` x ``block`` coefficient blocks, a second estimate less swayed by
  the few highly textured blocks) both reach ``gate`` and name the same image. Where
  the cleaner image carries a JPEG code grid (:func:`jpeg_blockiness` above the noisier
  one's by ``blockiness_margin``), the gate is ``coded_gate`` instead: the grid says the
  finest detail was coded away, which is no texture contrast, so a smaller gap is real.
* **Is the low estimate lost detail?** (also :func:`noise_gap`). A cleaner image can be
  "clean" because its detail is gone: clipped by a tone curve, gain or offset, or
  quantised, it holds flat blocks whose Haar coefficients are exactly zero
  (:func:`flat_block_share`), and the Donoho sigma falls with them whatever the noise.
  Smoothing its partner then removes detail that the partner still shares with the rest
  of the cleaner image. A gap is refused when the cleaner image's flat share exceeds the
  noisier one's by ``flat_margin`` or more, unless it carries a JPEG grid
  (``blockiness_margin``): a JPEG lost its finest detail in every block, as a blurrier
  sensor would, and smoothing its partner matches that.
* **How much smoothing?** (:func:`match_noise`): the smallest Gaussian that brings the
  noisier image's Donoho sigma within ``tolerance`` times the cleaner one's (bisection;
  the sigma falls monotonically as the Gaussian widens), capped by the stage's
  ``noise_max_sigma``: a wider Gaussian blurs the signal's edges more than it helps the
  matching, and the estimator alone asks for one when the cleaner image is a JPEG whose
  finest coefficients are gone.

Saturated pixels (:func:`saturated`, the image's extreme values: a target clipped by its
tone curve or gain, then by the refine stage to the reference's range) are left out of
every estimate: they have no noise, and where they are a large share of an image they
would pull its Donoho sigma and its share of flat blocks towards those of an image
without noise, so that the flat-block rule refuses a real gap.

The ``radcons`` preset uses this matching (:meth:`radcons.params.Params.from_preset`); the
measurements behind its gates and margins are in ``docs/tuning.md``. Scene mode decides
it once on its sample windows after the blur (:mod:`radcons.scene.pass1`) and smooths
every tile with that Gaussian.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from radcons.errors import InputError
from radcons.noise import noise_sigma
from radcons.numerics.valid_pixels import clipped_mask, gaussian_blur

__all__ = [
    "NoiseGap", "block_noise_sigmas", "flat_block_share", "jpeg_blockiness", "noise_gap", "match_noise", "saturated",
    "noise_smoothing",
]

#: Median of |N(0, 1)|: turns a median absolute coefficient into a standard deviation.
_MAD_TO_SIGMA = 0.6744897501960817
#: Bisection steps of the smoothing that matches the noise levels.
_NOISE_STEPS = 12
#: Block side of a JPEG code grid, px.
_JPEG_BLOCK = 8
#: Saturated pixels are left out of the estimates while at least this share of the valid ones remains.
_MIN_UNSATURATED = 0.25


@dataclass(frozen=True)
class NoiseGap:
    """The noise gap of a pair as :func:`noise_gap` measures it.

    Attributes
    ----------
    noisier : int or None
        0 (reference) or 1 (target) when the gap is taken as real, else None.
    ratio : float
        Larger over smaller Donoho sigma of the two images (inf when one is 0).
    block_ratio : float
        Same, of the medians of the per-block sigmas (inf when one is 0).
    sigmas : tuple of float
        Donoho sigma of the reference and of the target.
    flat_shares : tuple of float
        :func:`flat_block_share` of the reference and of the target.
    blockiness : tuple of float
        :func:`jpeg_blockiness` of the reference and of the target.
    lost_detail : bool
        True when the gap reached the gate but the cleaner image has flat blocks that
        the noisier one has not, without a JPEG grid (the gap is then refused:
        ``noisier`` is None).
    """

    noisier: int | None
    ratio: float
    block_ratio: float
    sigmas: tuple[float, float]
    flat_shares: tuple[float, float] = (0.0, 0.0)
    blockiness: tuple[float, float] = (1.0, 1.0)
    lost_detail: bool = False


def _haar_diagonal(image: np.ndarray) -> np.ndarray:
    """Orthonormal Haar HH coefficients of the 2 x 2 blocks (NaN where a pixel is invalid)."""
    image = np.asarray(image, np.float64)
    rows, cols = (image.shape[0] // 2) * 2, (image.shape[1] // 2) * 2
    a, b = image[0:rows:2, 0:cols:2], image[0:rows:2, 1:cols:2]
    c, d = image[1:rows:2, 0:cols:2], image[1:rows:2, 1:cols:2]
    return (a - b - c + d) / 2.0


def block_noise_sigmas(image: np.ndarray, block: int = 8) -> np.ndarray:
    """Donoho's noise sigma of every ``block`` x ``block`` block of Haar HH coefficients.

    Parameters
    ----------
    image : ndarray
        2-D image, NaN where invalid.
    block : int
        Coefficients a side per block (``2 * block`` px a side).

    Returns
    -------
    ndarray, 1-D
        ``median(|HH|) / 0.6745`` of each block whose coefficients are all valid.

    Raises
    ------
    InputError
        Not 2-D, or no complete block.
    """
    image = np.asarray(image)
    if image.ndim != 2:
        raise InputError(f"noise estimation needs a 2-D image, got shape {image.shape}")
    if block < 2:
        raise InputError(f"noise blocks need at least 2 coefficients a side, got {block}")
    hh = np.abs(_haar_diagonal(image))
    n0, n1 = hh.shape[0] // block, hh.shape[1] // block
    blocks = hh[: n0 * block, : n1 * block].reshape(n0, block, n1, block).transpose(0, 2, 1, 3).reshape(n0 * n1, -1)
    blocks = blocks[np.isfinite(blocks).all(axis=1)]
    if blocks.shape[0] == 0:
        raise InputError(f"no complete block of {2 * block} x {2 * block} valid pixels to estimate the noise from")
    return np.median(blocks, axis=1) / _MAD_TO_SIGMA


def flat_block_share(image: np.ndarray, block: int = 8) -> float:
    """Share of the blocks of :func:`block_noise_sigmas` without fine detail (sigma exactly 0).

    More than half of a block's Haar HH coefficients are exactly zero only where the
    values are flat to the last digit: quantised to few levels, clipped, or with the
    finest frequencies zeroed by lossy coding. Noise, even faint, leaves none such.

    Parameters
    ----------
    image : ndarray
        2-D image, NaN where invalid.
    block : int
        Block side, in coefficients (``2 * block`` px).

    Returns
    -------
    float
        In [0, 1].
    """
    return float(np.mean(block_noise_sigmas(image, block) == 0.0))


def jpeg_blockiness(image: np.ndarray) -> float:
    """Strength of an 8 x 8 px code grid: the largest over the 8 grid phases of the median
    absolute step between neighbours, over the median of the 8 phases (rows and columns).

    A JPEG-coded image steps more across its block borders than inside its blocks, at
    one phase of the 8 (whatever the crop); an image without a code grid gives about 1.
    Medians of the non-zero steps, so that a few strong edges along one grid line (a
    clipped rectangle) or flat regions do not read as a grid.

    Parameters
    ----------
    image : ndarray
        2-D image, NaN where invalid (steps touching them are left out).

    Returns
    -------
    float
        >= 1 (1.0 where the image is too small or flat to tell).

    Raises
    ------
    InputError
        Not 2-D.
    """
    image = np.asarray(image, np.float64)
    if image.ndim != 2:
        raise InputError(f"blockiness needs a 2-D image, got shape {image.shape}")
    phases = np.zeros(_JPEG_BLOCK)
    for steps in (np.abs(np.diff(image, axis=1)), np.abs(np.diff(image, axis=0)).T):
        for phase in range(min(_JPEG_BLOCK, steps.shape[1])):
            values = steps[:, phase::_JPEG_BLOCK]
            values = values[np.isfinite(values) & (values > 0)]
            phases[phase] += float(np.median(values)) if values.size else 0.0
    middle = float(np.median(phases))
    return max(float(phases.max()) / middle, 1.0) if middle > 0.0 else 1.0


def _ratio(first: float, second: float) -> float:
    low, high = sorted((first, second))
    if high == 0.0:
        return 1.0
    return high / low if low > 0.0 else float("inf")


def saturated(image: np.ndarray) -> np.ndarray:
    """Clipped pixels (:func:`radcons.numerics.valid_pixels.clipped_mask`): they carry no noise.

    A target clipped by its tone curve or gain, then by the refine stage to the
    reference's range, can hold a large share of its pixels at one of the two extremes,
    where its noise and texture are gone. Left in, they pull its Donoho sigma and its
    share of flat blocks towards an image without noise. Where fewer than a quarter of the
    valid pixels would remain, nothing is called saturated (an image of two or three grey
    levels).

    Parameters
    ----------
    image : ndarray
        2-D image, NaN where invalid.

    Returns
    -------
    ndarray of bool
    """
    clipped = clipped_mask(image)
    valid = int(np.isfinite(image).sum())
    if valid - int(clipped.sum()) < _MIN_UNSATURATED * valid:
        return np.zeros(clipped.shape, bool)
    return clipped


def _unsaturated(image: np.ndarray) -> np.ndarray:
    """The image as float with its :func:`saturated` pixels NaN."""
    return np.where(saturated(image), np.nan, np.asarray(image, np.float64))


def noise_gap(
    reference: np.ndarray,
    target: np.ndarray,
    gate: float,
    flat_margin: float = float("inf"),
    blockiness_margin: float = float("inf"),
    block: int = 8,
    coded_gate: float | None = None,
) -> NoiseGap:
    """Which image of the pair is the noisier one, if the gap is large and reliable.

    Parameters
    ----------
    reference, target : ndarray
        2-D images on one grey-level scale, NaN where invalid.
    gate : float
        Both the Donoho ratio and the per-block median ratio must reach it (>= 1).
    flat_margin : float
        A gap is refused when the cleaner image's :func:`flat_block_share` exceeds the
        noisier one's by this or more (inf: never) ...
    blockiness_margin : float
        ... unless the cleaner image's :func:`jpeg_blockiness` exceeds the noisier one's
        by this or more (inf: never): a JPEG-coded image lost its fine detail in every
        block, as a blurrier sensor would, and smoothing its partner matches that.
    block : int
        Block side of :func:`block_noise_sigmas`, in coefficients.
    coded_gate : float, optional
        The gate instead of ``gate`` where the cleaner image carries the JPEG grid of
        ``blockiness_margin`` (None: ``gate``).

    Every estimate leaves out each image's :func:`saturated` pixels.

    Returns
    -------
    NoiseGap
        ``noisier`` None when the gap is below the gate, when the two estimates name
        different images, when both images are noise-free, or when the cleaner image
        shows lost detail (``lost_detail``): flat blocks, from clipping or quantisation,
        that lower its estimate where it has no less noise.
    """
    reference, target = _unsaturated(reference), _unsaturated(target)
    sigmas = (noise_sigma(reference), noise_sigma(target))
    blocks = (float(np.median(block_noise_sigmas(reference, block))), float(np.median(block_noise_sigmas(target, block))))
    flat = (flat_block_share(reference, block), flat_block_share(target, block))
    grid = (jpeg_blockiness(reference), jpeg_blockiness(target))
    ratio, block_ratio = _ratio(*sigmas), _ratio(*blocks)
    noisier = int(sigmas[1] > sigmas[0])
    cleaner = 1 - noisier
    coded = grid[cleaner] - grid[noisier] >= blockiness_margin
    agree = noisier == int(blocks[1] > blocks[0]) and sigmas[noisier] > 0.0
    passes = coded_gate if coded and coded_gate is not None else gate
    reliable = agree and ratio >= passes and block_ratio >= passes
    lost = reliable and flat[cleaner] - flat[noisier] >= flat_margin and not coded
    return NoiseGap(noisier if reliable and not lost else None, ratio, block_ratio, sigmas, flat, grid, lost)


def match_noise(image: np.ndarray, goal: float, tolerance: float, max_sigma: float) -> tuple[np.ndarray, float]:
    """Smooth ``image`` by the smallest Gaussian that brings its noise sigma to ``tolerance * goal``.

    Parameters
    ----------
    image : ndarray
        The noisier image, NaN where invalid.
    goal : float
        The cleaner image's noise sigma (:func:`radcons.noise.noise_sigma`),
        measured, as the image's own, without its :func:`saturated` pixels.
    tolerance : float
        Noise ratio accepted (>= 1).
    max_sigma : float
        Largest Gaussian, px.

    Returns
    -------
    (ndarray, float)
        The smoothed image (float32, NaN kept) and the Gaussian's sigma, px (0 when the
        image is already within the tolerance; ``max_sigma`` when even that is not enough).
    """
    image = np.asarray(image, np.float32)
    clipped = saturated(image)

    def sigma(smoothed: np.ndarray) -> float:  # measured where the image is not saturated
        return noise_sigma(np.where(clipped, np.nan, smoothed))

    if sigma(image) <= tolerance * goal:
        return image.copy(), 0.0
    low, high = 0.0, max_sigma
    if sigma(gaussian_blur(image, high)) > tolerance * goal:
        return gaussian_blur(image, high), high
    for _ in range(_NOISE_STEPS):  # noise sigma falls as the Gaussian widens
        middle = 0.5 * (low + high)
        if sigma(gaussian_blur(image, middle)) > tolerance * goal:
            low = middle
        else:
            high = middle
    return gaussian_blur(image, high), high


def noise_smoothing(reference: np.ndarray, target: np.ndarray, params: object) -> tuple[float, NoiseGap]:
    """The Gaussian that brings the pair to its cleaner image's noise level, and the gap it rests on.

    :func:`noise_gap` with the sharpness stage's gate and margins, then, where it names a
    noisier image, :func:`match_noise`'s smoothing of that image. The in-memory stage and
    scene mode's pass 1 (on its sample windows) both decide by it.

    Parameters
    ----------
    reference, target : ndarray
        The pair after the blur of the sharpness stage, NaN where invalid.
    params : SharpnessParams
        ``noise_gate``, ``noise_coded_gate``, ``noise_flat_margin``,
        ``noise_blockiness_margin``, ``noise_tolerance`` and ``noise_max_sigma`` are used.

    Returns
    -------
    (float, NoiseGap)
        The Gaussian's sigma (px) signed as ``SharpnessParams.denoise``: positive smooths
        the target, negative the reference, 0 for none; and the gap.
    """
    gap = noise_gap(
        reference, target, params.noise_gate, params.noise_flat_margin, params.noise_blockiness_margin,
        coded_gate=params.noise_coded_gate,
    )
    if gap.noisier is None:
        return 0.0, gap
    noisier = (reference, target)[gap.noisier]
    _, sigma = match_noise(noisier, gap.sigmas[1 - gap.noisier], params.noise_tolerance, params.noise_max_sigma)
    return (sigma if gap.noisier == 1 else -sigma), gap
