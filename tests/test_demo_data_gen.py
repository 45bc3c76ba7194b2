"""Tests of the synthetic stereo pair generator against its own ground truth.

The geometry is checked independently of the generator's code: the target is warped with
scipy (not the generator's OpenCV remap) by the ground-truth disparity, labels are carried
the same way, and OpenCV's semi-global matcher measures the disparity from the images.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
import tomli_w
from scipy import ndimage
from skimage.restoration import estimate_sigma

from demo_data_gen import SCENARIOS, generate
from radcons.errors import InputError
from radcons.io import load_pair, save_pair

SIZE = 256
SEED = 3


@pytest.fixture(scope="module")
def pairs():
    """One pair per scenario, same seed and size."""
    return {scenario: generate(SIZE, SEED, scenario) for scenario in SCENARIOS}


def full_scale(pair, which: str) -> int:
    return 2 ** pair.metadata[f"{which}_bit_depth"] - 1


def warp_target(pair, shift: float = 0.0, order: int = 3) -> np.ndarray:
    """The target sampled at ``x - d + shift`` on the reference grid (scipy, not the generator)."""
    rows, cols = np.mgrid[0 : pair.shape[0], 0 : pair.shape[1]].astype(np.float64)
    d = np.nan_to_num(pair.disparity.astype(np.float64))
    return ndimage.map_coordinates(pair.target.data.astype(np.float64), [rows, cols - d + shift], order=order, mode="nearest")


def smooth_surfaces(pair, margin: int = 2) -> np.ndarray:
    """Reference pixels with a known disparity, ``margin`` px away from occlusions and
    disparity steps (where the two views legitimately see different things) and changes."""
    d = pair.disparity
    known = np.isfinite(d)
    filled = np.where(known, d, -1000.0)
    step = np.zeros(d.shape, bool)
    step[:, 1:] |= np.abs(np.diff(filled, axis=1)) > 0.2
    step[:, :-1] |= np.abs(np.diff(filled, axis=1)) > 0.2
    step[1:, :] |= np.abs(np.diff(filled, axis=0)) > 0.2
    step[:-1, :] |= np.abs(np.diff(filled, axis=0)) > 0.2
    near = ndimage.binary_dilation(step | ~known, np.ones((2 * margin + 1, 2 * margin + 1)))
    return known & ~near & ~pair.change_mask


# ----------------------------------------------------------------------------- contract


def test_pair_contents(pairs):
    for scenario, pair in pairs.items():
        ref, tgt = pair.reference.data, pair.target.data
        assert ref.shape == tgt.shape == (SIZE, SIZE)
        assert ref.dtype == tgt.dtype == np.uint16
        assert pair.disparity.dtype == np.float32 and pair.disparity.shape == (SIZE, SIZE)
        assert pair.reference_objects.dtype == pair.target_objects.dtype == np.int32
        assert pair.change_mask.dtype == bool and pair.change_mask.shape == (SIZE, SIZE)
        assert pair.rectified is True
        assert pair.metadata["scenario"] == scenario and pair.metadata["seed"] == SEED
        assert ref.max() <= full_scale(pair, "reference") and tgt.max() <= full_scale(pair, "target")
        tomli_w.dumps(pair.metadata)  # TOML-writable as it is
        assert scenario in pair.name


def test_scene_has_separable_buildings_and_useful_disparity(pairs):
    pair = pairs["none"]
    ids, counts = np.unique(pair.reference_objects[pair.reference_objects > 0], return_counts=True)
    assert 6 <= len(ids) <= 40
    assert np.median(np.sqrt(counts)) * 512 / SIZE >= 15  # about 15-80 px across at 512 px
    ground = pair.metadata["ground_disparity_px"]
    assert np.nanmin(pair.disparity) >= ground - 1.5  # gentle terrain only
    assert np.nanmax(pair.disparity) - ground >= 10 * SIZE / 512  # 20 m and more of height
    assert 0.01 < np.isnan(pair.disparity).mean() < 0.3  # occlusions exist, but are a minority


# ----------------------------------------------------------------------------- geometry


def test_warped_target_reproduces_reference_within_noise(pairs):
    pair = pairs["none"]
    valid = smooth_surfaces(pair)
    assert valid.mean() > 0.3
    ref = pair.reference.data.astype(np.float64)
    residual = lambda shift: float(np.sqrt(np.mean((ref - warp_target(pair, shift))[valid] ** 2)))
    noise = math.hypot(pair.metadata["reference_noise_sigma_dn"], pair.metadata["target_noise_sigma_dn"])
    exact = residual(0.0)
    assert exact < 1.3 * noise
    # a quarter and a half pixel off are clearly worse: the disparity is sub-pixel exact
    assert residual(0.25) > 1.3 * exact
    assert residual(-0.5) > 1.8 * exact
    assert residual(0.5) > 1.8 * exact


def test_building_labels_line_up_under_disparity(pairs):
    for scenario in ("none", "mixed"):
        pair = pairs[scenario]
        rows, cols = np.mgrid[0:SIZE, 0:SIZE]
        known = np.isfinite(pair.disparity)
        d = np.nan_to_num(pair.disparity)
        seen = ndimage.map_coordinates(pair.target_objects, [rows, cols - d], order=0, mode="nearest")
        labels = pair.reference_objects
        interior = ndimage.grey_erosion(labels, size=3) == ndimage.grey_dilation(labels, size=3)
        check = known & interior & ~pair.change_mask
        inside = check & (labels > 0)
        assert inside.sum() > 2000
        assert np.mean(seen[inside] == labels[inside]) > 0.99
        outside = check & (labels == 0)
        assert np.mean(seen[outside] == 0) > 0.99


def test_semi_global_matching_finds_the_ground_truth(pairs):
    pair = pairs["none"]
    scale = 255.0 / full_scale(pair, "reference")
    left = np.clip(pair.reference.data * scale, 0, 255).astype(np.uint8)
    right = np.clip(pair.target.data * scale, 0, 255).astype(np.uint8)
    sgbm = cv2.StereoSGBM_create(minDisparity=0, numDisparities=32, blockSize=5, P1=8 * 25, P2=32 * 25, uniquenessRatio=5)
    measured = sgbm.compute(left, right).astype(np.float32) / 16.0
    valid = smooth_surfaces(pair) & (measured > 0)
    valid[:, :40] = False  # SGBM leaves the left border undefined
    error = np.abs(measured - pair.disparity)[valid]
    assert valid.sum() > 0.3 * SIZE * SIZE
    assert np.mean(error < 1.0) > 0.85


# ----------------------------------------------------------------------------- scenarios


def test_reference_is_the_same_in_every_scenario(pairs):
    base = pairs["none"]
    for pair in pairs.values():
        np.testing.assert_array_equal(pair.reference.data, base.reference.data)
        np.testing.assert_array_equal(pair.reference_objects, base.reference_objects)


def test_multi_sensor_keeps_geometry_and_scene(pairs):
    none, sensor = pairs["none"], pairs["multi-sensor"]
    np.testing.assert_array_equal(sensor.disparity, none.disparity)
    np.testing.assert_array_equal(sensor.target_objects, none.target_objects)
    assert not sensor.change_mask.any() and not none.change_mask.any()
    assert sensor.metadata["target_sun_azimuth_deg"] == none.metadata["target_sun_azimuth_deg"]


def test_multi_sensor_changes_only_noise_blur_and_bit_depth(pairs):
    none, sensor = pairs["none"], pairs["multi-sensor"]
    fs_none, fs_sensor = full_scale(none, "target"), full_scale(sensor, "target")
    assert fs_sensor < fs_none  # another bit depth
    sigma_none = estimate_sigma(none.target.data.astype(np.float64)) / fs_none * 255
    sigma_sensor = estimate_sigma(sensor.target.data.astype(np.float64)) / fs_sensor * 255
    assert sigma_sensor > 3.0 * sigma_none
    # Blurring the "none" target by the extra point spread and rescaling gives the
    # multi-sensor target up to its noise: same sun, shadows, scene and geometry.
    extra = math.sqrt(sensor.metadata["target_blur_sigma_px"] ** 2 - none.metadata["target_blur_sigma_px"] ** 2)
    expected = cv2.GaussianBlur(none.target.data.astype(np.float32), (0, 0), extra)
    difference = sensor.target.data.astype(np.float32) * (fs_none / fs_sensor) - expected
    local = cv2.blur(difference, (9, 9))[10:-10, 10:-10]  # averages the noise down ~9x
    noise = sensor.metadata["target_noise_sigma_dn"] * fs_none / fs_sensor
    assert np.abs(difference.mean()) < 0.1 * noise
    assert np.percentile(np.abs(local), 99.9) < 0.6 * noise
    # the same comparison with the multi-temporal target fails: it would see other shadows
    other = cv2.GaussianBlur(pairs["multi-temporal"].target.data.astype(np.float32), (0, 0), extra)
    moved = cv2.blur(sensor.target.data.astype(np.float32) * (fs_none / fs_sensor) - other, (9, 9))[10:-10, 10:-10]
    assert np.percentile(np.abs(moved), 99.9) > 3 * noise


def test_multi_temporal_changes_illumination_and_scene_not_noise(pairs):
    none, temporal = pairs["none"], pairs["multi-temporal"]
    meta = temporal.metadata
    assert meta["target_sun_elevation_deg"] != meta["reference_sun_elevation_deg"]
    assert meta["target_sun_azimuth_deg"] != meta["reference_sun_azimuth_deg"]
    assert meta["target_bit_depth"] == meta["reference_bit_depth"]
    sigma_none = estimate_sigma(none.target.data.astype(np.float64))
    sigma_temporal = estimate_sigma(temporal.target.data.astype(np.float64))
    assert 0.75 < sigma_temporal / sigma_none < 1.33
    # local changes are marked and touch a minority of the image
    assert 0.005 < temporal.change_mask.mean() < 0.4
    # the over-exposed object is clipped at full scale in the target, not in the reference
    ident = meta["overexposed_object"]
    assert ident > 0
    fs = full_scale(temporal, "target")
    roof = ndimage.binary_erosion(temporal.reference_objects == ident, iterations=2) & np.isfinite(temporal.disparity)
    assert roof.sum() > 100
    assert np.mean(warp_target(temporal, order=0)[roof] == fs) > 0.7
    assert np.mean(temporal.reference.data[roof] == full_scale(temporal, "reference")) < 0.01
    # a building added or removed: its id exists in one image only, inside the change mask
    added, removed = meta["added_building"], meta["removed_building"]
    assert (added > 0) != (removed > 0)
    if added:
        assert not (temporal.reference_objects == added).any()
        assert (temporal.target_objects == added).sum() > 50
    else:
        footprint = temporal.reference_objects == removed
        assert footprint.sum() > 50 and not (temporal.target_objects == removed).any()
        assert temporal.change_mask[footprint].all()
    # outside the changes the geometry is that of the clean pair
    keep = ~temporal.change_mask
    np.testing.assert_array_equal(temporal.disparity[keep], none.disparity[keep])


def test_multi_temporal_moves_shadows(pairs):
    none, temporal = pairs["none"], pairs["multi-temporal"]
    valid = smooth_surfaces(temporal) & smooth_surfaces(none)
    ref = none.reference.data.astype(np.float64)
    # a global tone curve fitted to the clean pair cannot explain the multi-temporal target
    warped = warp_target(temporal)
    order = np.argsort(warped[valid])
    fitted = np.interp(warped[valid], warped[valid][order], ndimage.uniform_filter1d(ref[valid][order], 201))
    explained = 1.0 - np.var(ref[valid] - fitted) / np.var(ref[valid])
    warped_none = warp_target(none)
    order = np.argsort(warped_none[valid])
    fitted_none = np.interp(warped_none[valid], warped_none[valid][order], ndimage.uniform_filter1d(ref[valid][order], 201))
    explained_none = 1.0 - np.var(ref[valid] - fitted_none) / np.var(ref[valid])
    assert explained_none > 0.95
    assert explained < explained_none - 0.1


def test_mixed_is_both(pairs):
    mixed, temporal, sensor = pairs["mixed"], pairs["multi-temporal"], pairs["multi-sensor"]
    np.testing.assert_array_equal(mixed.disparity, temporal.disparity)
    np.testing.assert_array_equal(mixed.change_mask, temporal.change_mask)
    np.testing.assert_array_equal(mixed.target_objects, temporal.target_objects)
    for key in ("target_sun_elevation_deg", "target_gain", "target_gamma", "overexposed_object"):
        assert mixed.metadata[key] == temporal.metadata[key]
    for key in ("target_bit_depth", "target_noise_sigma_dn", "target_blur_sigma_px"):
        assert mixed.metadata[key] == sensor.metadata[key]


# ----------------------------------------------------------------------------- seeds, inputs, files


def test_same_seed_same_arrays_other_seed_other_city():
    a, b = generate(128, 11, "mixed"), generate(128, 11, "mixed")
    for key in ("disparity", "reference_objects", "target_objects", "change_mask"):
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key))
    np.testing.assert_array_equal(a.reference.data, b.reference.data)
    np.testing.assert_array_equal(a.target.data, b.target.data)
    assert a.metadata == b.metadata
    c = generate(128, 12, "mixed")
    assert not np.array_equal(a.reference_objects, c.reference_objects)
    assert np.mean(a.reference.data != c.reference.data) > 0.5


@pytest.mark.parametrize(
    "kwargs",
    [
        {"size": 63}, {"size": 4097}, {"size": 100.0}, {"size": "256"}, {"size": True},
        {"scenario": "winter"}, {"scenario": "Mixed"}, {"seed": -1}, {"seed": 1.5},
    ],
)
def test_bad_arguments_raise_input_error(kwargs):
    with pytest.raises(InputError):
        generate(**{"size": 64, "seed": 0, "scenario": "none", **kwargs})


def test_smallest_size_works():
    pair = generate(64, 0, "mixed")
    assert pair.reference.data.shape == (64, 64)


def test_save_and_load_round_trip(tmp_path, pairs):
    pair = pairs["mixed"]
    save_pair(pair, tmp_path / "demo")
    back = load_pair(tmp_path / "demo")
    np.testing.assert_array_equal(back.reference.data, pair.reference.data)
    np.testing.assert_array_equal(back.target.data, pair.target.data)
    np.testing.assert_array_equal(back.disparity, pair.disparity)
    np.testing.assert_array_equal(back.reference_objects, pair.reference_objects)
    np.testing.assert_array_equal(back.target_objects, pair.target_objects)
    np.testing.assert_array_equal(back.change_mask, pair.change_mask)
    assert back.metadata == pair.metadata
    assert back.name == pair.name and back.rectified
