"""Grey-level mappings of the target's background onto the reference (refine stage options).

* :func:`histogram_mapping`: one monotone mapping for the whole image (histogram matching);
* :func:`noise_aware_histogram_mapping`: the same, fitted as if the target were as noisy as
  the reference (a noisy reference's histogram is widened by its noise);
* :func:`smoothed_quantile_mapping`: a quantile mapping fitted on smoothed images.

After one of them the target may get a gain and an offset per tile for light that varies
across the scene (:mod:`radcons.stages.refine.light`).

All are monotone in the target's grey value at every pixel (a blend of monotone maps with
non-negative weights is monotone), so they never invert a contrast.
"""

from __future__ import annotations

import numpy as np
import scipy.ndimage
from skimage.exposure import match_histograms

from radcons.errors import InputError, ParamsError
from radcons.noise import noise_sigma
from radcons.numerics.valid_pixels import gaussian_blur

__all__ = [
    "histogram_mapping", "added_noise_sigma", "noise_to_add", "noise_aware_histogram_mapping", "noise_aware_lut",
    "smoothed_quantile_mapping",
]

#: Quantile levels of :func:`smoothed_quantile_mapping`.
_SMOOTHED_LEVELS = 257

#: Grey-value bins of the target's distribution in :func:`noise_aware_histogram_mapping`.
_NOISE_AWARE_BINS = 4096


def histogram_mapping(reference: np.ndarray, target: np.ndarray, smoothing: float = 0.0) -> np.ndarray:
    """The target with the reference's grey-level distribution (histogram matching).

    ``skimage.exposure.match_histograms`` over the valid pixels of each image: a monotone
    mapping of the target's grey levels fitted on the whole pair.

    With ``smoothing > 0`` the mapping is fitted on both images smoothed by a Gaussian of
    that many px (:func:`smoothed_quantile_mapping`) and applied to the target as it is:
    the histogram of a noisier image is wider by its noise, and matching it as it is
    flattens the target's signal contrast by as much.

    Parameters
    ----------
    reference, target : ndarray
        2-D images, NaN where invalid (they may differ in shape).
    smoothing : float
        Gaussian, px, applied to both images before the mapping is fitted (0: none).

    Returns
    -------
    ndarray, float32
        The mapped target, NaN kept (all NaN if either image has no valid pixel).
    """
    valid_ref, valid_tgt = np.isfinite(reference), np.isfinite(target)
    if smoothing > 0 and valid_ref.any() and valid_tgt.any():
        return smoothed_quantile_mapping(reference, target, smoothing)
    out = np.full(target.shape, np.nan, np.float32)
    if valid_ref.any() and valid_tgt.any():
        out[valid_tgt] = match_histograms(
            target[valid_tgt].astype(np.float64), reference[valid_ref].astype(np.float64)
        )
    return out


def added_noise_sigma(reference: np.ndarray, target: np.ndarray) -> float:
    """Noise, in the target's grey values, that brings the target to the reference's level.

    The images' noise sigmas (:func:`radcons.noise.noise_sigma`) and variances
    of their valid pixels, through :func:`noise_to_add`.

    Parameters
    ----------
    reference, target : ndarray
        2-D images, NaN where invalid.

    Returns
    -------
    float
        The added sigma (0 when either image has no signal spread beyond its noise, or no
        2 x 2 block of valid pixels).
    """
    valid_ref, valid_tgt = np.isfinite(reference), np.isfinite(target)
    if not (valid_ref.sum() >= 4 and valid_tgt.sum() >= 4):
        return 0.0
    try:
        s_r, s_t = noise_sigma(reference), noise_sigma(target)
    except InputError:
        return 0.0
    variance_r = float(np.var(reference[valid_ref], dtype=np.float64))
    variance_t = float(np.var(target[valid_tgt], dtype=np.float64))
    return noise_to_add(s_r, s_t, variance_r, variance_t)


def noise_to_add(
    sigma_reference: float, sigma_target: float, variance_reference: float, variance_target: float
) -> float:
    """Noise to add to the target, in its grey values, to bring it to the reference's level.

    With ``s_r, s_t`` the noise sigmas and ``v_r, v_t`` the variances, the reference's
    grey values are ``g`` times the target's, ``g = sqrt((v_r - s_r^2) / (v_t - s_t^2))``
    (the ratio of the signals' spreads), and the noise to add is
    ``sqrt(max((s_r / g)^2 - s_t^2, 0))``: 0 when the target is the noisier image.

    Returns
    -------
    float
        The added sigma; 0 when either image has no signal spread beyond its noise.
    """
    signal_r = variance_reference - sigma_reference * sigma_reference
    signal_t = variance_target - sigma_target * sigma_target
    if not (signal_r > 0 and signal_t > 0):
        return 0.0
    gain = np.sqrt(signal_r / signal_t)
    return float(np.sqrt(max((sigma_reference / gain) ** 2 - sigma_target * sigma_target, 0.0)))


def noise_aware_histogram_mapping(reference: np.ndarray, target: np.ndarray, added_sigma: float) -> np.ndarray:
    """Histogram matching fitted as if the target carried Gaussian noise of ``added_sigma``.

    The histogram of a noisy reference is its signal's widened by its noise. Matched onto
    it as it is, a cleaner target takes that noise as contrast, and where the target's
    histogram has a peak (a flat roof, a road, a clipped region) the mapping is steepest:
    the target's faint texture and grey-level steps there are magnified, the rest
    compressed. The mapping (:func:`noise_aware_lut`) is fitted on both images' grey-value
    counts and applied to every valid target pixel. With ``added_sigma = 0`` this is plain
    histogram matching (up to the binning of the target's distribution).

    Parameters
    ----------
    reference, target : ndarray
        2-D images, NaN where invalid (they may differ in shape).
    added_sigma : float
        Standard deviation, in grey values, of the noise the target is taken to carry
        (>= 0); :func:`radcons.stages.refine.run.refine_target` passes
        :func:`added_noise_sigma`, the noise that brings the target to the reference's
        level.

    Returns
    -------
    ndarray, float32
        The mapped target, NaN kept (all NaN if either image has no valid pixel).

    Raises
    ------
    ParamsError
        ``added_sigma`` negative or not finite.
    """
    if not (np.isfinite(added_sigma) and added_sigma >= 0):
        raise ParamsError(f"noise-aware histogram mapping needs added_sigma >= 0, got {added_sigma}")
    valid_ref, valid_tgt = np.isfinite(reference), np.isfinite(target)
    out = np.full(target.shape, np.nan, np.float32)
    if not (valid_ref.any() and valid_tgt.any()):
        return out
    values = target[valid_tgt]
    lut = noise_aware_lut(
        *np.unique(values, return_counts=True), *np.unique(reference[valid_ref], return_counts=True), added_sigma
    )
    out[valid_tgt] = np.interp(values, *lut)
    return out


def noise_aware_lut(
    target_values: np.ndarray,
    target_counts: np.ndarray,
    reference_values: np.ndarray,
    reference_counts: np.ndarray,
    added_sigma: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The noise-aware histogram mapping as a table, from both images' grey-value counts.

    The target's distribution is taken convolved with a Gaussian of ``added_sigma`` (its
    counts binned in :data:`_NOISE_AWARE_BINS` bins over its range widened by
    ``4 added_sigma`` and smoothed: the distribution of ``target + N(0, added_sigma^2)``).
    Each target value ``t`` takes the level ``F(t)`` of that distribution at the centre of
    ``t``'s bin, halfway up the bin's mass (so that a value held by a pile of pixels sits
    in the middle of it), and maps to the reference's quantile at ``F(t)``: the sorted
    reference values at positions ``(i + 1/2) / n``, linear between them.

    The in-memory stage (:func:`noise_aware_histogram_mapping`) and scene mode
    (:mod:`radcons.scene.pass1`, from the scene's grey-value counts) both call this, so
    they give one mapping.

    Parameters
    ----------
    target_values, reference_values : ndarray
        Distinct grey values, increasing.
    target_counts, reference_counts : ndarray
        Pixels holding each value (zeros allowed).
    added_sigma : float
        Noise the target is taken to carry, in the units of ``target_values`` (>= 0).

    Returns
    -------
    values, mapped : ndarray, float64
        The target values and the value each maps to; apply with
        ``np.interp(target, values, mapped)``.
    """
    keep_t, keep_r = np.asarray(target_counts) > 0, np.asarray(reference_counts) > 0
    values = np.asarray(target_values, np.float64)[keep_t]
    weights = np.asarray(target_counts, np.float64)[keep_t]
    goal = np.asarray(reference_values, np.float64)[keep_r]
    piles = np.asarray(reference_counts, np.float64)[keep_r]
    low, high = values[0] - 4.0 * added_sigma, values[-1] + 4.0 * added_sigma
    if not high > low:
        low, high = low - 0.5, high + 0.5
    edges = np.linspace(low, high, _NOISE_AWARE_BINS + 1)
    counts, _ = np.histogram(values, edges, weights=weights)
    width = edges[1] - edges[0]
    if added_sigma > 0:
        counts = scipy.ndimage.gaussian_filter1d(counts, added_sigma / width, mode="constant")
    cdf = np.concatenate([[0.0], np.cumsum(counts)])
    cdf /= cdf[-1]
    levels = np.interp(values, edges[:-1] + 0.5 * width, 0.5 * (cdf[:-1] + cdf[1:]))
    # the sorted reference at positions (i + 1/2) / n: each pile of equal values spans
    # from its first to its last position, linear between piles
    total = piles.sum()
    first = np.cumsum(piles) - piles
    positions = np.column_stack([(first + 0.5) / total, (first + piles - 0.5) / total]).ravel()
    return values, np.interp(levels, positions, np.repeat(goal, 2))


def smoothed_quantile_mapping(reference: np.ndarray, target: np.ndarray, smoothing: float) -> np.ndarray:
    """Quantile mapping fitted on both images smoothed by a Gaussian, applied to the target.

    The target's values are mapped linearly between the :data:`_SMOOTHED_LEVELS` quantiles
    of the smoothed target and the same quantiles of the smoothed reference, and beyond the
    end quantiles along the end segments (the raw target, noise included, spans more than
    its smoothed copy).

    Raises
    ------
    ParamsError
        ``smoothing`` not positive.
    """
    if not smoothing > 0:
        raise ParamsError(f"histogram smoothing must be positive, got {smoothing}")
    valid_ref, valid_tgt = np.isfinite(reference), np.isfinite(target)
    levels = np.linspace(0.0, 1.0, _SMOOTHED_LEVELS)
    source, goal = _quantile_map(
        gaussian_blur(reference, smoothing)[valid_ref], gaussian_blur(target, smoothing)[valid_tgt], levels
    )
    values = target.astype(np.float64)
    out = np.interp(values, source, goal)
    low_slope = (goal[1] - goal[0]) / (source[1] - source[0])
    high_slope = (goal[-1] - goal[-2]) / (source[-1] - source[-2])
    out = np.where(values < source[0], goal[0] + (values - source[0]) * low_slope, out)
    out = np.where(values > source[-1], goal[-1] + (values - source[-1]) * high_slope, out)
    out[~valid_tgt] = np.nan
    return out.astype(np.float32)


def _quantile_map(reference: np.ndarray, target: np.ndarray, levels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Target and reference quantiles at ``levels``; the target's made strictly increasing."""
    source = np.quantile(target, levels)
    source = source + np.arange(levels.size) * (1e-6 * max(float(np.ptp(source)), 1.0))
    return source, np.quantile(reference, levels)
