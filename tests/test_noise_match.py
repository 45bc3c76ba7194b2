"""Noise matching: the gate that tells a real noise gap from a texture contrast difference."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.ndimage

from radcons.errors import InputError, ParamsError
from radcons.evaluate.noise import noise_sigma
from radcons.stages.noise_match import block_noise_sigmas, match_noise, noise_gap
from radcons.stages.sharpness import SharpnessParams, sharpness_consistency


def _scene(n=256, seed=0):
    """Flat patches (a smooth field) with fine texture on part of the image, 100 +/- 40."""
    rng = np.random.default_rng(seed)
    smooth = scipy.ndimage.gaussian_filter(rng.normal(0.0, 1.0, (n, n)), 8.0)
    texture = scipy.ndimage.gaussian_filter(rng.normal(0.0, 1.0, (n, n)), 0.8)
    image = 100.0 + 40.0 * smooth / smooth.std() + 15.0 * texture / texture.std() * (smooth > 0)
    return image.astype(np.float32)


def _noisy(image, sigma, seed):
    return (image + np.random.default_rng(seed).normal(0.0, sigma, image.shape)).astype(np.float32)


def test_block_sigmas_of_white_noise_are_its_sigma():
    noise = np.random.default_rng(1).normal(0.0, 3.0, (256, 256))
    sigmas = block_noise_sigmas(noise, block=8)
    assert sigmas.shape == (16 * 16,)
    assert abs(np.median(sigmas) - 3.0) < 0.1


def test_block_sigmas_skip_blocks_with_invalid_pixels():
    noise = np.random.default_rng(2).normal(0.0, 2.0, (64, 64))
    noise[:16, :16] = np.nan  # exactly one 16 x 16 px block
    assert block_noise_sigmas(noise, block=8).shape == (15,)
    with pytest.raises(InputError):
        block_noise_sigmas(np.full((64, 64), np.nan))
    with pytest.raises(InputError):
        block_noise_sigmas(np.zeros((4, 4, 3)))


@pytest.mark.parametrize("noisier", [0, 1])
def test_a_real_noise_gap_names_the_noisier_image(noisier):
    scene = _scene()
    images = [_noisy(scene, 1.0, 3), _noisy(scene, 1.0, 4)]
    images[noisier] = _noisy(scene, 5.0, 5)
    gap = noise_gap(*images, gate=2.0)
    assert gap.noisier == noisier
    assert gap.ratio > 2.0 and gap.block_ratio > 2.0  # 5 : 1 in noise, texture in both


def test_a_texture_contrast_difference_is_no_noise_gap():
    scene = _noisy(_scene(), 1.0, 6)
    # a shadow-like change: the target's texture at 55 % contrast, same noise in both
    flattened = (scene.mean() + 0.55 * (scene - scene.mean())).astype(np.float32)
    # Donoho's estimator alone sees a gap beyond the tolerance of 1.15
    assert noise_sigma(scene) / noise_sigma(flattened) > 1.5
    gap = noise_gap(scene, flattened, gate=2.0)
    assert gap.noisier is None
    out = sharpness_consistency(scene, flattened, SharpnessParams(sigma=0.0, noise="cleaner"))
    assert out.info["denoised"] == "none"
    np.testing.assert_array_equal(out.reference, scene)
    # the same pair with a gate of 1 (no gate) is smoothed
    ungated = sharpness_consistency(scene, flattened, SharpnessParams(sigma=0.0, noise="cleaner", noise_gate=1.0))
    assert ungated.info["denoised"] == "reference"


def test_match_noise_reaches_the_goal_with_the_smallest_gaussian():
    from radcons.stages.sharpness import gaussian_blur

    loud = _noisy(_scene(), 6.0, 7)
    goal = noise_sigma(_noisy(_scene(), 1.5, 8))
    smoothed, sigma = match_noise(loud, goal, 1.1, 3.0)
    assert 0 < sigma < 3.0
    assert noise_sigma(smoothed) <= 1.1 * goal
    assert noise_sigma(gaussian_blur(loud, 0.9 * sigma)) > 1.1 * goal
    same, none = match_noise(loud, noise_sigma(loud), 1.1, 3.0)
    assert none == 0.0 and np.array_equal(same, loud)


def test_noise_gate_below_one_and_a_wide_noise_gaussian_are_refused():
    with pytest.raises(ParamsError, match="noise_gate"):
        SharpnessParams(noise_gate=0.5)
    with pytest.raises(ParamsError, match="noise_max_sigma"):
        SharpnessParams(noise_max_sigma=0.0)
    with pytest.raises(ParamsError, match="noise_max_sigma"):
        SharpnessParams(noise_max_sigma=4.0, max_sigma=3.0)


def test_the_noise_gaussian_is_capped():
    scene = _scene()
    loud, clean = _noisy(scene, 8.0, 9), _noisy(scene, 0.5, 10)
    out = sharpness_consistency(loud, clean, SharpnessParams(sigma=0.0, noise="cleaner", noise_max_sigma=0.4))
    assert out.info["denoised"] == "reference" and out.info["denoise_sigma"] == 0.4
    from radcons.stages.sharpness import gaussian_blur

    np.testing.assert_allclose(out.reference, gaussian_blur(loud, 0.4))


def test_a_given_denoise_replaces_the_measurement():
    scene = _scene()
    loud, clean = _noisy(scene, 8.0, 11), _noisy(scene, 0.5, 12)
    from radcons.stages.sharpness import gaussian_blur

    given = sharpness_consistency(loud, clean, SharpnessParams(sigma=0.0, noise="cleaner", denoise=0.3))
    assert given.info["denoised"] == "target" and given.info["denoise_sigma"] == 0.3
    np.testing.assert_allclose(given.target, gaussian_blur(clean, 0.3))  # the value given, not the gap
    np.testing.assert_array_equal(given.reference, loud)
    none = sharpness_consistency(loud, clean, SharpnessParams(sigma=0.0, noise="cleaner", denoise=0.0))
    assert none.info["denoised"] == "none" and np.array_equal(none.reference, loud)
    with pytest.raises(ParamsError, match="denoise"):
        SharpnessParams(denoise=5.0, max_sigma=3.0)
    with pytest.raises(ParamsError):
        SharpnessParams(denoise=float("nan"))
