"""Noise matching: the gate that tells a real noise gap from a texture contrast difference."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.ndimage

from radcons.errors import InputError, ParamsError
from radcons.noise import noise_sigma
from radcons.stages.sharpness.noise_match import (
    block_noise_sigmas,
    flat_block_share,
    jpeg_blockiness,
    match_noise,
    noise_gap,
    saturated,
)
from radcons.stages.sharpness.run import SharpnessParams, sharpness_consistency


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
    from radcons.numerics.valid_pixels import gaussian_blur

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
    from radcons.numerics.valid_pixels import gaussian_blur

    np.testing.assert_allclose(out.reference, gaussian_blur(loud, 0.4))


def test_a_given_denoise_replaces_the_measurement():
    scene = _scene()
    loud, clean = _noisy(scene, 8.0, 11), _noisy(scene, 0.5, 12)
    from radcons.numerics.valid_pixels import gaussian_blur

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


def _jpeg(image, quality):
    """8-bit JPEG round trip of an image in 0..255 (OpenCV's coder)."""
    import cv2

    ok, code = cv2.imencode(".jpg", np.clip(np.rint(image), 0, 255).astype(np.uint8), [cv2.IMWRITE_JPEG_QUALITY, quality])
    assert ok
    return cv2.imdecode(code, cv2.IMREAD_GRAYSCALE).astype(np.float32)


def test_blockiness_sees_a_jpeg_grid_at_any_crop_and_none_without_one():
    scene = _noisy(_scene(), 1.0, 13)
    coded = _jpeg(scene, 25)
    assert jpeg_blockiness(scene) < 1.1
    assert jpeg_blockiness(coded) > 1.3
    assert jpeg_blockiness(coded[3:, 5:]) > 1.3  # the grid at another phase
    with_nodata = coded.copy()
    with_nodata[:40, :40] = np.nan
    assert jpeg_blockiness(with_nodata) > 1.3
    assert jpeg_blockiness(np.full((32, 32), 7.0)) == 1.0
    with pytest.raises(InputError):
        jpeg_blockiness(np.zeros((4, 4, 3)))


def test_flat_block_share_counts_the_blocks_flat_to_the_last_digit():
    image = _noisy(_scene(), 0.5, 14)
    assert flat_block_share(image) == 0.0  # faint noise leaves no flat block
    clipped = image.copy()
    clipped[:, :64] = 255.0  # a saturated quarter: 4 of the 16 block columns
    assert flat_block_share(clipped) == pytest.approx(0.25)
    quantised = np.rint(_scene() / 40.0)  # about 4 grey levels: most blocks are one level
    assert flat_block_share(quantised) > 0.5


def test_a_gap_whose_cleaner_image_has_flat_blocks_is_refused_unless_it_is_a_jpeg():
    scene = _scene()
    clipped = _noisy(scene, 1.0, 17)
    clipped[:, :128] = clipped.max()  # half the target saturated: flat blocks, a low Donoho sigma ...
    noisy = _noisy(scene, 1.6, 18)  # ... where the reference has nearly the same noise
    assert noise_sigma(noisy) / noise_sigma(clipped) >= 2.0
    saturation = noise_gap(noisy, clipped, gate=2.0)  # the saturated pixels are left out
    assert saturation.noisier is None and saturation.ratio < 2.0
    quantised = np.rint(_noisy(scene, 1.0, 17) / 20.0) * 20.0  # 15 grey levels: flat blocks between the extremes
    open_gate = noise_gap(noisy, quantised, gate=2.0)
    assert open_gate.noisier == 0 and not open_gate.lost_detail  # the plain gate takes the flat blocks for a gap
    flat = noise_gap(noisy, quantised, gate=2.0, flat_margin=0.05, blockiness_margin=0.2)
    assert flat.ratio >= 2.0 and flat.noisier is None and flat.lost_detail
    assert flat.flat_shares[1] > 0.05
    coded = _jpeg(_noisy(scene, 1.0, 16), 15)  # noise and fine detail gone in every block
    loud = _noisy(scene, 3.0, 15)
    jpeg = noise_gap(loud, coded, gate=2.0, flat_margin=0.05, blockiness_margin=0.2)
    assert jpeg.flat_shares[1] - jpeg.flat_shares[0] >= 0.05  # flat blocks, yet ...
    assert jpeg.blockiness[1] - jpeg.blockiness[0] >= 0.2  # ... a JPEG grid: the gap stands
    assert jpeg.noisier == 0 and not jpeg.lost_detail
    no_exemption = noise_gap(loud, coded, gate=2.0, flat_margin=0.05, blockiness_margin=100.0)
    assert no_exemption.noisier is None and no_exemption.lost_detail


def test_a_jpeg_cleaner_image_opens_the_gap_at_the_coded_gate_only():
    scene = _scene()
    coded = _jpeg(_noisy(scene, 1.0, 22), 50)
    loud = _noisy(scene, 1.0, 23)  # the same noise as the target had before its coding
    plain = noise_gap(loud, coded, gate=2.0, flat_margin=0.05, blockiness_margin=0.2)
    assert 1.3 <= plain.ratio < 2.0 and plain.block_ratio >= 1.3  # a gap the plain gate leaves
    assert plain.noisier is None
    assert plain.blockiness[1] - plain.blockiness[0] >= 0.2
    at_coded = noise_gap(loud, coded, gate=2.0, flat_margin=0.05, blockiness_margin=0.2, coded_gate=1.3)
    assert at_coded.noisier == 0 and at_coded.ratio == plain.ratio
    # without a code grid the same ratio stays below the gate, whatever the coded gate
    clean = _noisy(scene, 1.0 / plain.ratio, 24)
    uncoded = noise_gap(loud, clean, gate=2.0, flat_margin=0.05, blockiness_margin=0.2, coded_gate=1.0)
    assert uncoded.ratio < 2.0 and uncoded.noisier is None
    # the stage reads it from its parameters
    params = SharpnessParams(sigma=0.0, noise="cleaner", noise_coded_gate=1.3)
    out = sharpness_consistency(loud, coded, params)
    assert out.info["denoised"] == "reference" and out.info["denoise_sigma"] > 0.0
    assert sharpness_consistency(loud, coded, SharpnessParams(sigma=0.0, noise="cleaner", noise_coded_gate=2.0)).info[
        "denoised"
    ] == "none"
    with pytest.raises(ParamsError, match="noise_coded_gate"):
        SharpnessParams(noise_coded_gate=0.9)


def test_a_real_gap_without_flat_blocks_passes_the_stage_defaults():
    scene = _scene()
    loud, clean = _noisy(scene, 5.0, 19), _noisy(scene, 1.0, 20)
    out = sharpness_consistency(loud, clean, SharpnessParams(sigma=0.0, noise="cleaner"))
    assert out.info["denoised"] == "reference" and not out.info["lost_detail"]
    clean[:96, :] = clean.min()  # the cleaner image clipped dark over 3 / 8 of its rows: the same gap
    clipped = sharpness_consistency(loud, clean, SharpnessParams(sigma=0.0, noise="cleaner"))
    assert clipped.info["denoised"] == "reference" and not clipped.info["lost_detail"]
    assert clipped.info["denoise_sigma"] == pytest.approx(out.info["denoise_sigma"], abs=0.05)


def test_saturated_pixels_are_the_extremes_unless_they_are_most_of_the_image():
    image = _noisy(_scene(), 1.0, 21)
    assert not saturated(image).any()  # no extreme piles up
    image[:, :100] = image.max()
    image[:10, 100:] = np.nan
    mask = saturated(image)
    assert mask[:, :100].all() and not mask[np.isnan(image)].any()
    assert mask[:, 100:].sum() <= 1  # the brightest pixel, if it lay there
    two_levels = np.zeros((32, 32), np.float32)
    two_levels[:, 16:] = 1.0
    assert not saturated(two_levels).any()  # nothing would remain
    rest = _noisy(_scene(), 1.0, 21)
    rest[:, :100] = np.nan
    rest[:10, 100:] = np.nan
    # the smoothing is measured off the saturated part: as if it were not there
    assert match_noise(image, 0.5, 1.15, 2.0)[1] == pytest.approx(match_noise(rest, 0.5, 1.15, 2.0)[1], abs=0.05)


@pytest.mark.parametrize("name", ["noise_flat_margin", "noise_blockiness_margin"])
def test_negative_lost_detail_margins_are_refused(name):
    with pytest.raises(ParamsError, match=name):
        SharpnessParams(**{name: -0.1})
    assert getattr(SharpnessParams(**{name: 0.0}), name) == 0.0
