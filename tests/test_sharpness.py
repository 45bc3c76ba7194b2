"""Sharpness consistency: relative blur estimate and blurring the sharper image."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.ndimage

from radcons.errors import InputError, ParamsError
from radcons.stages.sharpness.run import (
    SharpnessParams,
    gaussian_blur,
    power_spectrum,
    relative_blur,
    sharpness_consistency,
)


def _texture(n=256, seed=0):
    """An optical-looking image: white noise through a 0.7 px point spread, 100 +/- 30."""
    rng = np.random.default_rng(seed)
    field = scipy.ndimage.gaussian_filter(rng.normal(0.0, 1.0, (n, n)), 0.7)
    return (100.0 + 30.0 * field / field.std()).astype(np.float32)


def _noisy(image, sigma, seed):
    return (image + np.random.default_rng(seed).normal(0.0, sigma, image.shape)).astype(np.float32)


def test_white_noise_has_a_flat_spectrum_at_its_variance():
    noise = np.random.default_rng(1).normal(0.0, 3.0, (256, 256)).astype(np.float32)
    frequency, power = power_spectrum(noise, 64)
    assert frequency[0] == pytest.approx(1 / 64) and frequency[-1] == pytest.approx(0.5)
    assert power[2:].mean() == pytest.approx(9.0, rel=0.03)
    np.testing.assert_allclose(power[2:], 9.0, rtol=0.15)


@pytest.mark.parametrize("blur", [0.8, 1.2, 1.6])
def test_relative_blur_of_a_gaussian_blurred_target(blur):
    reference = _noisy(_texture(), 1.0, 2)
    target = _noisy(scipy.ndimage.gaussian_filter(_texture(), blur), 2.0, 3)
    assert relative_blur(reference, target) == pytest.approx(blur, abs=0.12)


def test_relative_blur_is_negative_when_the_reference_is_blurrier():
    reference = _noisy(scipy.ndimage.gaussian_filter(_texture(), 1.2), 1.0, 4)
    target = 0.5 * _noisy(_texture(), 2.0, 5) + 40.0  # another contrast: the fit's intercept
    assert relative_blur(reference, target) == pytest.approx(-1.2, abs=0.12)


def test_equal_point_spreads_leave_the_pair_unchanged():
    reference, target = _noisy(_texture(), 1.0, 6), _noisy(_texture(), 3.0, 7)
    assert abs(relative_blur(reference, target)) < 0.3
    result = sharpness_consistency(reference, target)
    assert result.info["blurred"] == "none" and result.info["sigma"] == 0.0
    np.testing.assert_array_equal(result.reference, reference)
    np.testing.assert_array_equal(result.target, target)


def test_the_sharper_reference_is_blurred_to_the_target():
    clean = _texture()
    reference = _noisy(clean, 1.0, 8)
    target = _noisy(scipy.ndimage.gaussian_filter(clean, 1.2), 1.0, 9)
    result = sharpness_consistency(reference, target)
    assert result.info["blurred"] == "reference"
    assert result.info["sigma"] == pytest.approx(1.2, abs=0.12)
    np.testing.assert_array_equal(result.target, target)
    expected = scipy.ndimage.gaussian_filter(reference, result.info["sigma"], mode="reflect")
    np.testing.assert_allclose(result.reference, expected, atol=0.05)
    # the two images now have one point spread
    assert abs(relative_blur(result.reference, result.target)) < 0.3


def test_a_given_sigma_replaces_the_estimate_and_max_sigma_caps_it():
    reference, target = _texture(64), _texture(64, 1)
    result = sharpness_consistency(reference, target, SharpnessParams(sigma=-0.9))
    assert result.info == {"relative_blur": -0.9, "blurred": "target", "sigma": 0.9}
    np.testing.assert_array_equal(result.reference, reference)
    capped = sharpness_consistency(reference, target, SharpnessParams(sigma=5.0, max_sigma=2.0, strength=0.5))
    assert capped.info["sigma"] == 2.0 and capped.info["blurred"] == "reference"


def test_gaussian_blur_averages_valid_pixels_only():
    image = _texture(64)
    image[10:14, 20:30] = np.nan
    out = gaussian_blur(image, 1.5)
    valid = np.isfinite(image)
    assert np.array_equal(np.isfinite(out), valid)
    filled = np.where(valid, image, 0.0).astype(np.float64)
    weight = scipy.ndimage.gaussian_filter(valid.astype(np.float64), 1.5, mode="reflect")
    expected = scipy.ndimage.gaussian_filter(filled, 1.5, mode="reflect") / weight
    np.testing.assert_allclose(out[valid], expected[valid], rtol=2e-3)


def test_tiles_with_invalid_pixels_are_skipped():
    image = _texture(128)
    holed = image.copy()
    holed[:8, :8] = np.nan  # spoils the tiles of the top-left corner only
    _, power = power_spectrum(holed, 64)
    assert np.isfinite(power).all()
    _, none = power_spectrum(np.where(np.arange(128) % 50 == 0, np.nan, image), 64)
    assert np.isnan(none).all()


def test_flat_images_give_no_estimate():
    flat = np.full((64, 64), 80.0, np.float32)
    assert relative_blur(flat, _texture(64)) == 0.0


def test_bad_input_and_params():
    with pytest.raises(InputError, match="2-D"):
        relative_blur(np.zeros((4, 32, 32)), _texture(32))
    with pytest.raises(InputError, match="too small"):
        sharpness_consistency(np.zeros((8, 8)), np.zeros((8, 8)))
    with pytest.raises(InputError, match="NaN"):
        relative_blur(np.full((32, 32), np.nan), _texture(32))
    for bad in (dict(tile=15), dict(f_low=0.3, f_high=0.2), dict(snr=0), dict(min_sigma=4.0),
                dict(strength=0.0), dict(sigma=float("nan"))):
        with pytest.raises(ParamsError):
            SharpnessParams(**bad)


def _smooth(n=256, seed=3):
    """A smooth image (little fine detail), so that its noise estimate is its noise."""
    field = scipy.ndimage.gaussian_filter(np.random.default_rng(seed).normal(0.0, 1.0, (n, n)), 6.0)
    return (120.0 + 60.0 * field / np.abs(field).max()).astype(np.float32)


@pytest.mark.parametrize("noisier", ["reference", "target"])
def test_noise_cleaner_brings_the_noisier_image_to_the_cleaner_level(noisier):
    from radcons.noise import noise_sigma

    clean, loud = _noisy(_smooth(), 1.0, 4), _noisy(_smooth(), 4.0, 5)
    reference, target = (loud, clean) if noisier == "reference" else (clean, loud)
    params = SharpnessParams(sigma=0.0, noise="cleaner", noise_tolerance=1.15)
    out = sharpness_consistency(reference, target, params)
    assert out.info["denoised"] == noisier and out.info["denoise_sigma"] > 0
    kept = out.target if noisier == "reference" else out.reference
    np.testing.assert_array_equal(kept, clean)  # the cleaner image is left as it is
    ratio = noise_sigma(out.reference) / noise_sigma(out.target)
    assert 1 / 1.16 < ratio < 1.16  # within the tolerance (4 : 1 before)
    # the smallest smoothing: a Gaussian 10 % narrower leaves the ratio above the tolerance
    narrower = gaussian_blur(loud, 0.9 * out.info["denoise_sigma"])
    assert noise_sigma(narrower) > 1.15 * noise_sigma(clean)
    # "keep" (the default) changes nothing when the point spreads agree
    same = sharpness_consistency(reference, target, SharpnessParams(sigma=0.0))
    assert "denoised" not in same.info and np.array_equal(same.reference, reference)
    with pytest.raises(ParamsError):
        SharpnessParams(noise="both")
    with pytest.raises(ParamsError):
        SharpnessParams(noise_tolerance=0.9)
