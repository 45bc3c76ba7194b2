"""The refine stage's local light correction: a gain and an offset per tile, blended
(:func:`radcons.stages.refine.light.local_light_correction`)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from radcons.errors import ParamsError
from radcons.params import Params
from radcons.results import Association
from radcons.stages.refine.background import histogram_mapping
from radcons.stages.refine.light import light_spread, local_light_correction
from radcons.stages.refine.params import RefineParams
from radcons.stages.refine.run import background_mapping, refine_target


def textured(shape=(240, 320), seed=0) -> np.ndarray:
    return (50.0 + 100.0 * np.random.default_rng(seed).random(shape)).astype(np.float32)


@pytest.mark.parametrize("tiles", [1, 3, 6])
def test_a_constant_gain_and_offset_is_undone_at_every_tile_count(tiles):
    reference = textured()
    target = 0.6 * reference + 25.0
    corrected = local_light_correction(reference, target, tiles)
    np.testing.assert_allclose(corrected, reference, atol=1e-3)


def test_one_tile_is_the_whole_images_moments_line():
    reference, target = textured(seed=1), textured(seed=2) ** 1.1
    gain = reference.std(dtype=np.float64) / target.std(dtype=np.float64)
    expected = gain * target + (reference.mean(dtype=np.float64) - gain * target.mean(dtype=np.float64))
    np.testing.assert_allclose(local_light_correction(reference, target, 1), expected, rtol=1e-5, atol=1e-3)


def test_a_light_gradient_across_the_scene_is_taken_out():
    reference = textured(seed=3)
    rows, cols = reference.shape
    x = (np.arange(cols) + 0.5) / cols
    light = (1.0 + 0.8 * (x - 0.5))[None, :]  # +-40 % from left to right
    haze = 0.15 * 100.0 * x[None, :]
    target = (reference * light + haze).astype(np.float32)
    before = np.abs(target - reference).mean()
    after = np.abs(local_light_correction(reference, target, 8) - reference).mean()
    assert after < 0.1 * before
    # one whole-image line cannot follow the gradient
    assert np.abs(local_light_correction(reference, target, 1) - reference).mean() > 3 * after


def test_grey_value_order_is_kept_and_invalid_pixels_stay_invalid():
    reference, target = textured(seed=4), textured(seed=5)
    target[10:20, 30:40] = np.nan
    corrected = local_light_correction(reference, target, 4)
    assert np.isnan(corrected[10:20, 30:40]).all()
    assert np.isfinite(corrected[np.isfinite(target)]).all()
    # along a row the gain varies smoothly and stays positive: neighbours keep their order
    row_t, row_c = target[100], corrected[100]
    pairs = np.abs(np.diff(row_t)) > 5.0
    assert (np.sign(np.diff(row_t))[pairs] == np.sign(np.diff(row_c))[pairs]).all()


def test_a_flat_or_empty_tile_keeps_the_target():
    reference, target = textured(seed=6), textured(seed=7)
    target[:] = 80.0
    np.testing.assert_array_equal(local_light_correction(reference, target, 3), target)
    empty = np.full_like(target, np.nan)
    assert np.isnan(local_light_correction(reference, empty, 3)).all()


def test_bad_tiles_and_shapes_are_refused():
    with pytest.raises(ParamsError, match="tiles >= 1"):
        local_light_correction(textured(), textured(), 0)
    with pytest.raises(ParamsError, match="one shape"):
        local_light_correction(textured(), textured((10, 10)), 2)


def test_refine_applies_it_to_the_background_only():
    """``background = "local"``: outside the applied objects the target gets the histogram
    mapping and then the light correction; with no object at all that is the whole target."""
    reference = textured(seed=8)
    x = (np.arange(reference.shape[1]) + 0.5) / reference.shape[1]
    target = (reference * (0.8 + 0.4 * x)[None, :]).astype(np.float32)
    labels = np.zeros(reference.shape, np.int32)
    params = Params.from_preset("radcons").refine
    assert params.background == "local"
    plain, _ = refine_target(reference, target, labels, Association(np.zeros((0, 4)), ()), replace(params, background="histogram"))
    lit, _ = refine_target(reference, target, labels, Association(np.zeros((0, 4)), ()), params)
    assert np.abs(lit - reference).mean() < 0.5 * np.abs(plain - reference).mean()


def test_light_spread_is_the_moved_standard_deviation_over_the_references_range():
    reference = textured(seed=9)  # uniform 50..150: its 1..99 percentile range is 98
    target = textured(seed=10)
    ramp = np.linspace(-6.0, 6.0, reference.shape[1], dtype=np.float64)[None, :]
    low, high = np.percentile(reference, [1, 99])
    expected = np.broadcast_to(ramp, reference.shape).std() / (high - low)
    assert light_spread(reference, target, (target + ramp).astype(np.float32)) == pytest.approx(expected, rel=1e-4)
    assert light_spread(reference, target, target + np.float32(7.0)) == pytest.approx(0.0, abs=1e-7)
    assert light_spread(reference, np.full_like(target, np.nan), target) == 0.0
    assert light_spread(np.full_like(reference, 3.0), target, target + ramp) == 0.0


def test_tiles_that_differ_by_content_alone_are_left_as_they_are():
    """A target whose tiles differ from the reference's by parallax and a scene change,
    not by light: the correction would follow the content, so below ``local_min_light``
    the background is the whole-image mapping; a light gradient of +-20 % is corrected."""
    params = RefineParams(background="local", local_tiles=6)
    assert params.local_min_light == 0.04
    reference = textured(seed=11)
    changed = np.roll(reference, 3, axis=1)
    changed[40:90, 60:120] = 60.0  # a roof that changed between the dates
    mapped, done = background_mapping(reference, changed, params)
    whole = histogram_mapping(reference, changed)
    np.testing.assert_array_equal(mapped, whole)
    assert done["light_spread"] == light_spread(reference, whole, local_light_correction(reference, whole, 6)) < 0.04
    assert done == {"background": "local", "light_spread": done["light_spread"], "light_applied": False}
    x = (np.arange(reference.shape[1]) + 0.5) / reference.shape[1]
    lit = (reference * (0.8 + 0.4 * x)[None, :]).astype(np.float32)
    mapped, done = background_mapping(reference, lit, params)
    np.testing.assert_array_equal(mapped, local_light_correction(reference, histogram_mapping(reference, lit), 6))
    assert done["light_applied"] and done["light_spread"] >= 0.04
    assert np.abs(mapped - reference).mean() < 0.3 * np.abs(lit - reference).mean()
