"""Simulated date / sensor differences, noise estimation, and the real pairs with ground truth."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from radcons.errors import InputError, ParamsError
from radcons.evaluate import differences as diff
from radcons.noise import noise_ratio, noise_sigma
from radcons.evaluate.simulate import (
    KINDS,
    RANGES,
    Degradation,
    Difference,
    degrade,
    sample_difference,
    simulate_pair,
    split_of,
    split_seeds,
)
from radcons.evaluate.truth_pairs import (
    labels_to_target,
    load_cones,
    load_motorcycle,
    objects_from_disparity,
)
from radcons.io import Pair, Raster


def ramp(rows: int = 64, cols: int = 256) -> np.ndarray:
    """Horizontal ramp over 0..255 (every column one value)."""
    return np.tile(np.linspace(0.0, 255.0, cols), (rows, 1)).astype(np.float32)


def smooth_image(seed: int = 0, n: int = 128) -> np.ndarray:
    """Very smooth image (almost no fine-scale signal), values about 50..200."""
    rng = np.random.default_rng(seed)
    field = ndimage.gaussian_filter(rng.normal(size=(n, n)), 12.0)
    return (125.0 + 75.0 * field / np.abs(field).max()).astype(np.float32)


# ----------------------------------------------------------------------------- degrade


def test_gamma_is_the_known_mapping():
    image = ramp()
    out = degrade(image, Degradation(gamma=0.5))
    np.testing.assert_allclose(out, 255.0 * (image / 255.0) ** 0.5, rtol=1e-6, atol=1e-4)


def test_gain_offset_and_clipping():
    image = ramp()
    out = degrade(image, Degradation(gain=0.5, offset=10.0))
    np.testing.assert_allclose(out, 0.5 * image + 10.0, atol=1e-4)
    # pushed above the range: clipped at the input's maximum, as a sensor saturates
    out = degrade(image, Degradation(gain=2.0))
    np.testing.assert_allclose(out, np.minimum(2.0 * image, 255.0), atol=1e-4)


def test_saturated_box_and_object():
    image = ramp()
    out = degrade(image, Degradation(saturate_box=(100, 10, 200, 30), saturate_factor=2.0))
    expected = image.copy()
    expected[10:30, 100:200] = np.minimum(2.0 * image[10:30, 100:200], 255.0)
    np.testing.assert_allclose(out, expected, atol=1e-4)
    assert (out[10:30, 128:200] == 255.0).all()  # everything above half range saturates
    labels = np.zeros(image.shape, np.int32)
    labels[40:50, 150:160] = 3
    out = degrade(image, Degradation(saturate_label=3, saturate_factor=3.0), labels)
    assert (out[40:50, 150:160] == 255.0).all()
    np.testing.assert_allclose(out[labels != 3], image[labels != 3], atol=1e-4)
    with pytest.raises(InputError):
        degrade(image, Degradation(saturate_label=3))
    with pytest.raises(InputError):
        degrade(image, Degradation(saturate_label=4), labels)


def test_blur_matches_gaussian_and_keeps_nan():
    image = smooth_image() + np.random.default_rng(1).normal(0, 20, (128, 128)).astype(np.float32)
    image = np.clip(image, 0, 255)
    low, high = image.min(), image.max()
    out = degrade(image, Degradation(blur_sigma=1.5))
    expected = np.clip(ndimage.gaussian_filter(image.astype(np.float64), 1.5, mode="nearest"), low, high)
    np.testing.assert_allclose(out, expected, rtol=1e-5, atol=1e-3)
    holed = image.copy()
    holed[60:64, 60:64] = np.nan
    out = degrade(holed, Degradation(blur_sigma=1.5))
    assert np.isnan(out[60:64, 60:64]).all() and np.isfinite(out[~np.isnan(holed)]).all()


def test_noise_has_the_asked_sigma_and_seed():
    image = smooth_image()
    out = degrade(image, Degradation(noise_sigma=5.0, seed=3))
    assert noise_sigma(out) == pytest.approx(5.0, rel=0.05)
    np.testing.assert_array_equal(out, degrade(image, Degradation(noise_sigma=5.0, seed=3)))
    assert not np.array_equal(out, degrade(image, Degradation(noise_sigma=5.0, seed=4)))


def test_degradation_validation():
    for bad in ({"gamma": 0.0}, {"gain": -1.0}, {"blur_sigma": -1.0}, {"saturate_box": (5, 5, 5, 9)}):
        with pytest.raises(ParamsError):
            Degradation(**bad)
    with pytest.raises(InputError):
        degrade(np.ones((4, 4), np.float32), Degradation())


# ----------------------------------------------------------------------------- noise


def test_noise_sigma_of_white_noise_with_holes():
    rng = np.random.default_rng(2)
    image = (100.0 + rng.normal(0.0, 3.0, (200, 200))).astype(np.float32)
    image[:50, :50] = np.nan
    assert noise_sigma(image) == pytest.approx(3.0, rel=0.05)
    # a linear ramp adds nothing to the diagonal detail coefficients
    ramped = image + np.linspace(0, 500, 200)[None, :] + np.linspace(0, 300, 200)[:, None]
    assert noise_sigma(ramped) == pytest.approx(noise_sigma(image), rel=1e-4)
    with pytest.raises(InputError):
        noise_sigma(np.full((4, 4), np.nan))


def test_noise_ratio():
    image = smooth_image(5)
    quiet = degrade(image, Degradation(noise_sigma=2.0, seed=1))
    loud = degrade(image, Degradation(noise_sigma=6.0, seed=2))
    assert noise_ratio(quiet, loud) == pytest.approx(3.0, rel=0.08)
    assert noise_ratio(loud, quiet) == noise_ratio(quiet, loud)


# ----------------------------------------------------------------------------- objects and real pairs


def test_objects_from_disparity_and_labels_to_target():
    disparity = np.full((40, 60), 3.0, np.float32)
    disparity[5:25, 20:45] = 12.0  # a near block
    disparity[30:33, 5:8] = 30.0  # too small to be an object
    disparity[35:, :] = np.nan
    labels = objects_from_disparity(disparity, layer_width=4.0, min_area=20)
    assert labels.max() == 2
    assert (labels[5:25, 20:45] == 2).all()  # smaller than the background layer
    assert (labels[30:33, 5:8] == 0).all() and (labels[35:] == 0).all()
    target = labels_to_target(labels, disparity)
    # the near block lands 12 px to the left and hides the background there
    assert (target[5:25, 8:33] == 2).all()
    assert (target[5:25, 33:42] == 0).all()  # disoccluded: hidden by the block in the reference
    assert (target[5:25, 42:57] == 1).all()
    assert (target[:5, :57] == 1).all() and (target[:5, 57:] == 0).all()


def _warp_error(pair, sign: float) -> float:
    reference = pair.reference.data.astype(np.float64)
    target = pair.target.data.astype(np.float64)
    rows, cols = np.nonzero(np.isfinite(pair.disparity))
    matched = np.rint(cols - sign * pair.disparity[rows, cols]).astype(int)
    inside = (matched >= 0) & (matched < reference.shape[1])
    return float(np.abs(reference[rows[inside], cols[inside]] - target[rows[inside], matched[inside]]).mean())


@pytest.mark.realdata
def test_load_cones(shared_data):
    pair = load_cones(shared_data / "middlebury_cones")
    assert pair.shape == (375, 450) and pair.disparity.dtype == np.float32
    assert np.isnan(pair.disparity).any() and np.nanmin(pair.disparity) > 0
    # our sign convention: reference(x, y) <-> target(x - d, y)
    assert _warp_error(pair, +1.0) < 0.4 * _warp_error(pair, -1.0)
    ids = set(np.unique(pair.reference_objects)) - {0}
    assert len(ids) >= 5 and ids == set(np.unique(pair.target_objects)) - {0}


def test_load_motorcycle():
    pair = load_motorcycle()
    assert pair.shape == (250, 370)
    assert pair.reference.data.dtype == np.float32 and pair.reference.data.max() <= 255.0
    assert 0 < np.nanmin(pair.disparity) and np.nanmax(pair.disparity) < 31  # full size / 2
    assert _warp_error(pair, +1.0) < 0.4 * _warp_error(pair, -1.0)
    assert len(set(np.unique(pair.reference_objects)) - {0}) >= 5


# ----------------------------------------------------------------------------- randomised differences


def flat(value: float = 0.5, n: int = 256) -> np.ndarray:
    return np.full((n, n), value)


def test_tone_curve_definition():
    u = np.linspace(0.0, 1.0, 1001)
    np.testing.assert_allclose(diff.tone_curve(u, 1.0, 0.0, 0.8, 0.05), 0.8 * u + 0.05, atol=1e-12)
    np.testing.assert_allclose(diff.tone_curve(u, 2.0, 0.0, 1.0, 0.0), u**2, atol=1e-12)
    curve = diff.tone_curve(u, 1.0, 0.4, 1.0, 0.0)
    np.testing.assert_allclose(curve[[0, 500, 1000]], [0.0, 0.5, 1.0], atol=1e-12)  # S fixes 0, 1/2, 1
    assert (curve[501] - curve[499]) / (u[501] - u[499]) == pytest.approx(1.4, rel=1e-4)  # slope 1 + s
    assert (np.diff(diff.tone_curve(u, 0.6, -0.9, 1.2, -0.1)) > 0).all()  # monotone
    with pytest.raises(ParamsError):
        diff.tone_curve(u, 1.0, 1.0, 1.0, 0.0)


def test_quantise_levels_and_range():
    u = np.linspace(0.0, 1.0, 100000).reshape(100, 1000)
    eight = diff.quantise(u, 8, 0.5)
    assert np.unique(eight).size == 129 and eight.max() == 128.0  # round(0.5 * 255) + 1 levels
    twelve = diff.quantise(u, 12, 1.0)
    assert twelve.max() == 4095.0 and np.array_equal(twelve, np.rint(twelve))
    assert np.abs(twelve / 4095.0 - u).max() <= 0.5 / 4095.0 + 1e-12
    with pytest.raises(ParamsError):
        diff.quantise(u, 10, 1.0)


def test_blur_sigma_measured_from_the_impulse_response():
    impulse = np.zeros((81, 81))
    impulse[40, 40] = 1.0
    for sigma in (0.7, 1.5, 2.0):
        response = diff.gaussian_blur(impulse, sigma)
        x = np.arange(81) - 40.0
        variance = float((response.sum(axis=0) * x**2).sum() / response.sum())
        assert np.sqrt(variance) == pytest.approx(sigma, rel=0.03)
    holed = flat()
    holed[10:20, 10:20] = np.nan
    out = diff.gaussian_blur(holed, 1.5)
    assert np.isnan(out[10:20, 10:20]).all()
    np.testing.assert_allclose(out[np.isfinite(holed)], 0.5)  # only valid pixels averaged


def test_noise_std_measured_gaussian_and_signal_dependent():
    rng = np.random.default_rng(0)
    assert np.std(diff.add_noise(flat(0.3), 0.02, 0.0, rng) - 0.3) == pytest.approx(0.02, rel=0.02)
    for level in (0.2, 0.8):
        measured = np.std(diff.add_noise(flat(level), 0.01, 0.002, rng) - level)
        assert measured == pytest.approx(np.sqrt(0.01**2 + 0.002 * level), rel=0.02)
    assert noise_sigma(diff.add_noise(smooth_image() / 255.0, 0.02, 0.0, rng)) == pytest.approx(0.02, rel=0.06)


def test_light_field_gradient_vignetting_haze():
    u = flat(0.5, 101)
    half_diagonal = np.hypot(101, 101) / 2.0
    x = np.arange(101) - 50.0
    gradient = diff.light_field(u, 0.3, 0.0, 0.0, 0.0, 0.8)
    np.testing.assert_allclose(gradient[50], 0.5 * (1 + 0.3 * x / half_diagonal))
    vignetted = diff.light_field(u, 0.0, 0.0, 0.2, 0.0, 0.8)
    np.testing.assert_allclose(vignetted[50], 0.5 * (1 - 0.2 * x**2 / half_diagonal**2))
    hazy = diff.light_field(u, 0.0, 0.0, 0.0, 0.4, 0.9)
    assert hazy[50, 50] == pytest.approx(0.5 * 0.8 + 0.9 * 0.2)  # t = 1 - 0.4 / 2 at the centre


def test_shadows_darken_their_mask_only():
    rng = np.random.default_rng(3)
    mask = diff.shadow_mask((400, 400), 4, 0.1, rng)
    assert 0.05 < mask.mean() < 0.12  # ellipses may overlap
    u = flat(0.6, 400)
    out = diff.cast_shadows(u, mask, 0.5, softness=0.0)
    np.testing.assert_allclose(out[mask], 0.3)
    np.testing.assert_allclose(out[~mask], 0.6)


def test_clip_objects_and_jpeg():
    u = np.tile(np.linspace(0.0, 1.0, 64), (64, 1))
    region = np.zeros(u.shape, bool)
    region[:, 32:] = True
    out = diff.clip_objects(u, region, 1.5)
    np.testing.assert_allclose(out[region], np.minimum(1.5 * u[region], 1.0))
    np.testing.assert_array_equal(out[~region], u[~region])
    image = smooth_image() / 255.0 + np.random.default_rng(2).normal(0, 0.05, (128, 128))
    image = np.clip(image, 0, 1)
    errors = [np.abs(diff.jpeg_roundtrip(image, q) - image).mean() for q in (95, 50, 10)]
    assert errors[0] < errors[1] < errors[2] and errors[0] < 0.01


def test_sampled_differences_cycle_kinds_within_ranges_and_split():
    assert split_seeds("tuning") == list(range(9)) and split_seeds("held-out") == list(range(9, 18))
    assert set(split_seeds("tuning", 3)).isdisjoint(split_seeds("held-out", 3))
    assert [split_of(s) for s in (0, 8, 9, 17, 18)] == ["tuning", "tuning", "held-out", "held-out", "tuning"]
    for seed in range(36):
        d = sample_difference(seed)
        assert d == sample_difference(seed) and d.kind == KINDS[seed % len(KINDS)] and d.split == split_of(seed)
        for name in ("gain", "offset", "s_curve", "gamma"):
            low, high = RANGES[name]
            assert low <= getattr(d, name) <= high
        if d.kind == "blur":
            assert RANGES["blur_sigma"][0] <= d.blur_sigma <= RANGES["blur_sigma"][1]
        if d.kind == "bit_depth":
            assert d.bits in (8, 11, 12)
        if d.kind == "tone":
            assert d == Difference("tone", seed, d.gamma, d.s_curve, d.gain, d.offset)  # nothing else
    with pytest.raises(ParamsError):
        split_of(-1)


def test_simulate_pair_applies_the_tone_curve_exactly():
    image = ramp()
    pair = Pair(Raster(image.copy()), Raster(image.copy()), disparity=np.zeros(image.shape, np.float32))
    out = simulate_pair(pair, Difference("tone", 0, gain=0.8, offset=0.05))
    np.testing.assert_allclose(out.target.data, 255.0 * (0.8 * image / 255.0 + 0.05), atol=1e-3)
    np.testing.assert_array_equal(out.reference.data, image)
    assert out.disparity is pair.disparity
    recorded = simulate_pair(pair, Difference("bit_depth", 0, bits=11, fill=1.0))
    np.testing.assert_allclose(recorded.target.data, np.rint(image / 255.0 * 2047.0))
    noisy_reference = simulate_pair(pair, Difference("noise", 0, noise_sigma=0.02, noise_on="reference"))
    np.testing.assert_array_equal(noisy_reference.target.data, pair.target.data)
    assert not np.array_equal(noisy_reference.reference.data, image)


def test_simulate_pair_stores_whole_levels_of_the_source_dtype():
    image = np.rint(ramp()).astype(np.uint8)
    pair = Pair(Raster(image.copy()), Raster(image.copy()), disparity=np.zeros(image.shape, np.float32))
    toned = simulate_pair(pair, Difference("tone", 0, gain=0.8, offset=0.05))
    assert toned.target.data.dtype == np.uint8
    expected = np.clip(np.rint(255.0 * (0.8 * image / 255.0 + 0.05)), 0, 255)
    np.testing.assert_array_equal(toned.target.data, expected)
    noisy = simulate_pair(pair, Difference("noise", 0, noise_sigma=0.05, noise_on="reference"))
    assert noisy.reference.data.dtype == np.uint8 and not np.array_equal(noisy.reference.data, image)
    assert simulate_pair(pair, Difference("bit_depth", 0, bits=12, fill=1.0)).target.data.dtype == np.uint16
    assert simulate_pair(pair, Difference("bit_depth", 0, bits=8, fill=0.5)).target.data.max() == 128
    floats = Pair(Raster(ramp()), Raster(ramp()), disparity=np.zeros(image.shape, np.float32))
    assert simulate_pair(floats, Difference("tone", 0, gain=0.8)).target.data.dtype == np.float32
