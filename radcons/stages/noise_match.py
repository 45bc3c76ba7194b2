"""Noise matching of a pair: the noisier image smoothed to the cleaner one's noise level.

Used by the sharpness stage's option ``noise = "cleaner"`` (not in the paper: its section
5 denoises both images towards zero; here both images end at the *cleaner* image's noise
level). Three steps:

* **Is the gap real?** (:func:`noise_gap`). Donoho's estimator
  (:func:`radcons.noise.noise_sigma`, the median absolute finest diagonal Haar
  coefficient) reads fine texture as noise, so a pair whose *texture contrast* differs
  (a shadow cast on one date flattens the texture under it; an object clipped on one
  date loses its texture) shows a noise "gap" where both images carry the same noise.
  On the tuning split of ``benchmarks/bench_generalisation.py`` (seeds 0-8 and 18-26,
  after the refine and blur stages) such pairs reached a Donoho ratio of 1.0-1.8 (shadows
  up to 1.58, clipped objects up to 1.77), pairs with noise added to one image 2.6-4.5
  (6.9-8.2 where the other image was also JPEG-coded). The gap is therefore taken as real
  only when the Donoho ratio **and** the median of the per-block ratio (the same
  estimator on ``block`` x ``block`` coefficient blocks, a second estimate less swayed by
  the few highly textured blocks) both reach ``gate`` and name the same image. Where
  the cleaner image carries a JPEG code grid (:func:`jpeg_blockiness` above the noisier
  one's by ``blockiness_margin``, 0.1), the gate is ``coded_gate`` (1.3) instead: the
  grid says the finest detail was coded away, which is no texture contrast. Chosen on
  the tuning split (``--blocks 6``) against the plain gate of 2.0 (and the margin 0.2
  of before): it changed 11 of 162 pair-seeds, all JPEG-coded (compression and mixed
  kinds; the output of the 151 others is identical), whose Donoho ratio after the
  pipeline fell from 1.36-2.50 to 1.10-1.24 (compression kind median 1.84 -> 1.15);
  their correct-matching rates rose by up to 0.006 with SGBM and 0.011 with census
  (none fell by more than 0.001): over the split SGBM +0.0001, census +0.0003.
* **Is the low estimate lost detail?** (also :func:`noise_gap`). A cleaner image can be
  "clean" because its detail is gone: clipped by a tone curve, gain or offset, or
  quantised, it holds flat blocks whose Haar coefficients are exactly zero
  (:func:`flat_block_share`), and the Donoho sigma falls with them whatever the noise.
  Smoothing its partner then removes detail that the partner still shares with the rest
  of the cleaner image. A gap is refused when the cleaner image's flat share exceeds the
  noisier one's by ``flat_margin`` (0.05) or more, unless it carries a JPEG grid
  (:func:`jpeg_blockiness` above the noisier one's by ``blockiness_margin``, 0.2): a
  JPEG lost its finest detail in every block, as a blurrier sensor would, and smoothing
  its partner matches that. On the tuning split (``--blocks 6``, 162 pair-seeds, after
  the refine and blur stages), where the Donoho and block ratios passed, the cleaner
  image's flat share exceeded its partner's by at most 0.012 on the noise pair-seeds and
  by 0.004-0.62 on the JPEG targets, whose blockiness exceeded it by 0.46-1.51 (JPEG
  targets 1.04-2.56, all other images 1.00-1.06, so a margin of 0.1 separates them; the
  Motorcycle targets at JPEG quality 35-50 exceed their partner by 0.13-0.18).
* **How much smoothing?** (:func:`match_noise`): the smallest Gaussian that brings the
  noisier image's Donoho sigma within ``tolerance`` times the cleaner one's (bisection;
  the sigma falls monotonically as the Gaussian widens), capped by the stage's
  ``noise_max_sigma``. On the tuning noise seeds the correct-matching rate peaks near
  0.5-0.6 px and falls beyond (Cones seed 3, SGBM / census: 0.747 / 0.792 as it is,
  0.743 / 0.793 at 0.55 px, 0.723 / 0.734 at 1.0 px), where the estimator alone asks
  up to 1 px when the cleaner image is a JPEG whose finest coefficients are gone.

The ``radcons`` preset's choice since the noise-aware background became its default
(:meth:`radcons.params.Params.from_preset`). Measured when it was an option
(``benchmarks/bench_generalisation.py --split tuning --blocks 6 --set
'sharpness.noise="cleaner"'``, 162 pair-seeds, against the ``radcons`` preset of then with
``"keep"``): SGBM 0.7504 -> 0.7510 (compression +0.005, mixed +0.002, noise -0.001),
census 0.8045 -> 0.8066 (noise +0.011, compression +0.005, mixed +0.002), no kind lower
by more than 0.001; the gate passed 31 pair-seeds (17 noise, 14 JPEG-coded). Refusing
the JPEG targets too (``noise_blockiness_margin = 100``) lost the compression gains
(SGBM -0.0001, census +0.0013 overall). US3D: the gate stays closed (Donoho ratios 1.34
and 1.02), the output is the preset's. Held-out split (``--split held-out --us3d``, 27
pair-seeds, run once): SGBM 0.7101 -> 0.7098 (blur and noise -0.0015 each), census
0.7611 -> 0.7619 (noise +0.008); the flat-block rule refused the tone, bit-depth and one
blur pair (Donoho ratios 2.3-107) on which the gate without it had cost SGBM rate
(0.710 -> 0.705 overall), and also two noise pairs whose cleaner target was clipped by
its gain.
Saturated pixels (:func:`saturated`, the image's extreme values: a target clipped by its
tone curve or gain, then by the refine stage to the reference's range) are left out of
every estimate: they have no noise, and held half of the target in two held-out noise
pairs (Cones and Motorcycle, seed 12), whose gap the flat-block rule then refused (Donoho
ratios 4.1 and 4.6; 2.3 and 3.1 without them). Found there, so checked on the tuning
split, where it changed 4 of 162 pair-seeds: SGBM 0.7532 -> 0.7532, census 0.8074 ->
0.8074 (a JPEG demo pair +0.002 / +0.004, a mixed Cones pair +0.001 / -0.003).
Scene mode decides it once on its sample windows after the blur
(:mod:`radcons.scene.pass1`) and smooths every tile with that Gaussian.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from radcons.errors import InputError
from radcons.noise import noise_sigma
from radcons.stages.valid_pixels import clipped_mask, gaussian_blur

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
    """Clipped pixels (:func:`radcons.stages.valid_pixels.clipped_mask`): they carry no noise.

    A target clipped by its tone curve or gain, then by the refine stage to the
    reference's range, holds up to half of its pixels at one of the two extremes (the
    tuning and held-out pairs of ``benchmarks/bench_generalisation.py``), where its noise
    and texture are gone. Left in, they pull its Donoho sigma and its share of flat blocks
    towards an image without noise. Where fewer than a quarter of the valid pixels would
    remain, nothing is called saturated (an image of two or three grey levels).

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
