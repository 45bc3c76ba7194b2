"""The refine stage's noise-aware background mapping (a noisier reference's histogram)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.ndimage
from skimage.exposure import match_histograms

from radcons.errors import ParamsError
from radcons.results import Association, Matches
from radcons.stages.refine.background import (
    added_noise_sigma,
    histogram_mapping,
    noise_aware_histogram_mapping,
)
from radcons.stages.refine.run import RefineParams, refine_target

GAIN, OFFSET, NOISE = 2.0, 10.0, 12.0


def smooth_signal(seed: int = 0, shape: tuple[int, int] = (256, 256)) -> np.ndarray:
    """A noise-free scene: smooth texture (no fine detail for the noise estimator to see)."""
    field = scipy.ndimage.gaussian_filter(np.random.default_rng(seed).normal(size=shape), 6.0)
    return (100.0 + 30.0 * field / field.std()).astype(np.float32)


def noisy_reference(signal: np.ndarray, seed: int = 1) -> np.ndarray:
    """The reference: the signal through a known line, plus white noise of NOISE."""
    noise = np.random.default_rng(seed).normal(0.0, NOISE, signal.shape)
    return (GAIN * signal + OFFSET + noise).astype(np.float32)


def slope(mapped: np.ndarray, signal: np.ndarray) -> float:
    """Least-squares slope of the mapped target against the true signal."""
    return float(np.polyfit(signal.ravel(), mapped.ravel(), 1)[0])


def test_added_sigma_is_the_reference_noise_in_target_grey_values():
    signal = smooth_signal()
    reference = noisy_reference(signal)
    # the reference's noise NOISE is NOISE / GAIN in the target's grey values
    assert added_noise_sigma(reference, signal) == pytest.approx(NOISE / GAIN, rel=0.1)
    # a target already noisier than that needs nothing added
    noisy_target = signal + np.random.default_rng(2).normal(0.0, NOISE, signal.shape).astype(np.float32)
    assert added_noise_sigma(reference, noisy_target) == 0.0


def test_noise_aware_mapping_gives_the_target_the_reference_signal_contrast():
    signal = smooth_signal()
    reference = noisy_reference(signal)
    # plain matching takes the reference's noise as contrast: slope sqrt(GAIN^2 + (NOISE / 30)^2) = 2.04
    plain = slope(histogram_mapping(reference, signal), signal)
    assert plain > GAIN * 1.015
    aware = noise_aware_histogram_mapping(reference, signal, NOISE / GAIN)
    assert slope(aware, signal) == pytest.approx(GAIN, rel=0.005)
    assert np.abs(aware - (GAIN * signal + OFFSET)).mean() < 0.5 * np.abs(histogram_mapping(reference, signal) - (GAIN * signal + OFFSET)).mean()


def test_noise_aware_mapping_without_added_noise_is_histogram_matching():
    rng = np.random.default_rng(3)
    target = rng.gamma(3.0, 20.0, (200, 200)).astype(np.float32)
    reference = np.sqrt(target) * 7.0 + 3.0
    mapped = noise_aware_histogram_mapping(reference, target, 0.0)
    expected = match_histograms(target.astype(np.float64), reference.astype(np.float64))
    central = (target > np.quantile(target, 0.01)) & (target < np.quantile(target, 0.99))
    assert np.abs(mapped - expected)[central].max() < 0.01 * np.ptp(reference)


def test_noise_aware_mapping_is_monotone_and_keeps_nan():
    signal = smooth_signal()
    signal[:5, :5] = np.nan
    reference = noisy_reference(np.nan_to_num(signal, nan=100.0))
    mapped = noise_aware_histogram_mapping(reference, signal, 4.0)
    assert np.isnan(mapped[:5, :5]).all() and np.isfinite(mapped[5:, 5:]).all()
    order = np.argsort(signal[5:, 5:].ravel())
    assert (np.diff(mapped[5:, 5:].ravel()[order]) >= 0).all()
    with pytest.raises(ParamsError, match="added_sigma"):
        noise_aware_histogram_mapping(reference, signal, -1.0)


def test_refine_background_noise_maps_the_background_to_the_reference_signal():
    signal = smooth_signal()
    reference = noisy_reference(signal)
    empty = Association(Matches(np.zeros((0, 2), np.float32), np.zeros((0, 2), np.float32)), ())
    labels = np.zeros(signal.shape, np.int32)
    params = RefineParams(background="histogram", blend_width=0.0, background_noise=True)
    refined, _ = refine_target(reference, signal, labels, empty, params)
    plain, _ = refine_target(reference, signal, labels, empty, RefineParams(background="histogram", blend_width=0.0))
    assert slope(refined, signal) == pytest.approx(GAIN, rel=0.01)
    assert slope(plain, signal) > GAIN * 1.015


def test_background_noise_needs_the_unsmoothed_histogram_background():
    with pytest.raises(ParamsError, match="background_noise"):
        RefineParams(background="global", background_noise=True)
    with pytest.raises(ParamsError, match="background_noise"):
        RefineParams(background="histogram", background_smoothing=1.0, background_noise=True)
