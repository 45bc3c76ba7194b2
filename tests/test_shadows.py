"""Shadows raised by the matcher's smoothing are no objects (``[objects] shadow_texture``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from rule_effects import rule_effect

from demo_data_gen import generate
from radcons.errors import ParamsError
from radcons.numerics.modal import modal_disparity
from radcons.stages.objects.features import ImageScales, object_features
from radcons.stages.objects.ground import HeightMap
from radcons.stages.objects.rules import is_dark_and_low, is_shadow
from radcons.stages.objects.run import ObjectsParams, height_objects


def _flat_heights(shape: tuple[int, int]) -> HeightMap:
    """Every pixel 8 m above a ground at disparity 0 (the features' height entries unused here)."""
    zero = np.zeros(shape, np.float32)
    return HeightMap(zero + 8.0, zero, zero + 8.0, "m", 1.0, 1, (0.0, 16.0), 1.0)


def _features(reference: np.ndarray, labels: np.ndarray) -> dict[int, dict[str, float]]:
    return object_features(reference, labels, _flat_heights(reference.shape))


def test_a_dark_smooth_object_is_a_shadow_and_a_bright_smooth_roof_is_not():
    rng = np.random.default_rng(3)
    reference = (300.0 + 60.0 * rng.standard_normal((160, 160))).astype(np.float32)  # textured ground
    labels = np.zeros(reference.shape, np.int32)
    labels[20:60, 20:80] = 1  # a shadow: dark, smooth
    labels[90:140, 30:100] = 2  # a roof: bright, smooth
    labels[100:140, 110:150] = 3  # a dark roof with texture
    reference[labels == 1] = 80.0 + rng.standard_normal(int((labels == 1).sum()))
    reference[labels == 2] = 900.0 + rng.standard_normal(int((labels == 2).sum()))
    reference[labels == 3] = 120.0 + 60.0 * rng.standard_normal(int((labels == 3).sum()))
    features = _features(reference, labels)
    median = float(np.median(reference))
    for ident in (1, 2, 3):
        assert features[ident]["brightness"] == pytest.approx(float(np.median(reference[labels == ident])) / median)
    rules = ObjectsParams(method="height")
    assert is_shadow(features[1], rules)
    assert not is_shadow(features[2], rules)  # smooth, but bright
    assert not is_shadow(features[3], rules)  # dark, but textured
    assert not is_shadow(features[1], replace(rules, shadow_texture=0.0))  # off
    heights = _flat_heights(reference.shape)
    assert object_features(reference, labels, heights, 1.0, ImageScales.of(reference, 1.0)) == features
    assert object_features(reference, labels, heights, 1.0, ImageScales.of(reference, 3.0)) == features  # other sigma: ignored


@pytest.fixture(scope="module")
def shaded_pair():
    """A demo pair (mixed, seed 1, 512 px) whose census disparity raises building shadows."""
    pair = generate(size=512, seed=1, scenario="mixed")
    meta = pair.metadata
    geometry = {"gsd_m": meta["gsd_m"], "base_to_height": meta["base_to_height"]}
    reference, target = pair.reference.as_float32(), pair.target.as_float32()
    found = {
        value: height_objects(reference, target, ObjectsParams(method="height", shadow_texture=value), **geometry)
        for value in (0.0, ObjectsParams().shadow_texture)
    }
    return pair, found


def test_shadows_raised_to_a_roofs_disparity_are_left_out(shaded_pair):
    pair, found = shaded_pair
    reference = pair.reference.as_float32()
    without = found[0.0]
    features = _features(reference, without.reference)
    shadows = []
    for ident, feature in features.items():
        mask = without.reference == ident
        no_building = not (pair.reference_objects[mask] > 0).any()
        if no_building and feature["brightness"] < 1.0 and feature["texture"] < 0.3:
            shadows.append(ident)
    assert shadows, "the pair was chosen for its raised shadows"
    raised = []
    for ident in shadows:
        truth = pair.disparity[without.reference == ident]
        truth = truth[np.isfinite(truth)]
        if ident in without.modal_disparity and without.modal_disparity[ident] - modal_disparity(truth) > 5.0:
            raised.append(ident)
    assert raised  # at least one stands 5 px (10 m) above the ground it lies on
    kept = found[ObjectsParams().shadow_texture].reference
    for ident in shadows:
        assert np.mean(kept[without.reference == ident] > 0) < 0.2
    assert found[ObjectsParams().shadow_texture].mismatched >= without.mismatched + len(shadows)


@pytest.mark.parametrize("value", [-0.1, 2.5, float("nan")])
def test_a_shadow_texture_out_of_range_is_refused(value):
    with pytest.raises(ParamsError, match="shadow_texture"):
        ObjectsParams(method="height", shadow_texture=value)


def test_a_dark_object_is_crowns_or_a_shadow_only_when_it_stands_low():
    rng = np.random.default_rng(4)
    reference = (300.0 + 20.0 * rng.standard_normal((160, 160))).astype(np.float32)
    labels = np.zeros(reference.shape, np.int32)
    labels[20:60, 20:80] = 1  # dark, 4 m
    labels[90:140, 30:80] = 2  # dark, 10 m: a dark roof
    labels[90:140, 100:150] = 3  # bright, 4 m: a low roof
    reference[labels == 1] = 120.0 + 30.0 * rng.standard_normal(int((labels == 1).sum()))
    reference[labels == 2] = 120.0 + 30.0 * rng.standard_normal(int((labels == 2).sum()))
    reference[labels == 3] = 600.0 + 30.0 * rng.standard_normal(int((labels == 3).sum()))
    height = np.where(labels == 2, 10.0, 4.0).astype(np.float32)
    zero = np.zeros(reference.shape, np.float32)
    features = object_features(reference, labels, HeightMap(height, zero, height, "m", 1.0, 1, (0.0, 16.0), 1.0))
    assert [features[i]["height"] for i in (1, 2, 3)] == [4.0, 10.0, 4.0]
    rules = ObjectsParams(method="height")
    threshold = 2.0  # 3 x 2 m: lower than 6 m is low
    assert is_dark_and_low(features[1], rules, threshold)
    assert not is_dark_and_low(features[2], rules, threshold)  # dark, but as high as a roof
    assert not is_dark_and_low(features[3], rules, threshold)  # low, but bright
    assert not is_dark_and_low(features[1], replace(rules, dark_height=0.0), threshold)  # off


def test_dark_low_objects_left_out_on_a_demo_pair_are_no_buildings():
    pair = generate(size=512, seed=2, scenario="multi-temporal")
    alone = ObjectsParams(method="height", crown_alignment=0.0)  # the low-crown rule takes one of the groves too
    effect = rule_effect(pair, replace(alone, dark_height=0.0), alone)
    assert len(effect.removed) >= 2, "the pair was chosen for its groves raised by the matcher"
    wrong = 0
    for ident, iou in effect.removed.items():
        assert iou < 0.5, f"object {ident} left out as dark and low is a building (IoU {iou:.2f})"
        disparity = pair.disparity[effect.without.reference == ident]
        disparity = disparity[np.isfinite(disparity)]
        shift = effect.without.modal_disparity.get(ident)
        wrong += int(shift is not None and abs(shift - modal_disparity(disparity)) > 1.0)
    assert wrong >= 1  # their D̄m is the roof's, not the ground's they lie on
    assert effect.with_rule.trees >= effect.without.trees + len(effect.removed)


@pytest.mark.parametrize(("name", "value"), [("dark_brightness", -0.1), ("dark_brightness", 2.5), ("dark_height", -1.0)])
def test_dark_and_low_out_of_range_is_refused(name, value):
    with pytest.raises(ParamsError, match=name):
        ObjectsParams(method="height", **{name: value})
