"""Low objects with edges every way and no rectangular outline are crowns (``[objects] crown_*``)."""

from __future__ import annotations

from dataclasses import replace

import cv2
import numpy as np
import pytest
from rule_effects import rule_effect

from demo_data_gen import generate
from radcons.errors import ParamsError
from radcons.stages.objects.features import object_features
from radcons.stages.objects.ground import HeightMap
from radcons.stages.objects.rules import is_dark_and_low, is_low_crown, is_tree
from radcons.stages.objects.run import ObjectsParams

THRESHOLD = 2.0  # m, the height threshold of ObjectsParams().min_height_m


def _heights(shape: tuple[int, int], metres: float) -> HeightMap:
    """Every pixel ``metres`` above a ground at disparity 0."""
    zero = np.zeros(shape, np.float32)
    return HeightMap(zero + metres, zero, zero + metres, "m", 1.0, 1, (0.0, 40.0), 1.0)


def _scene() -> tuple[np.ndarray, np.ndarray]:
    """Crowns along a road (1: five touching discs cut straight by the kerb) and a square roof (2), bright on a darker ground.

    The kerb's straight edge keeps the crowns' edges from turning every way, as the
    edges of shadows and kerbs beside them do on real pairs (alignment about 0.33,
    above ``tree_alignment``).
    """
    labels = np.zeros((220, 220), np.uint8)
    for row, col in ((60, 50), (60, 82), (60, 114), (40, 66), (40, 98)):
        cv2.circle(labels, (col, row), 16, 1, -1)
    labels[60:] = 0
    labels[130:190, 120:180] = 2
    rng = np.random.default_rng(0)
    reference = np.where(labels > 0, 140.0, 90.0) + rng.normal(0.0, 2.0, labels.shape)
    return reference.astype(np.float32), labels.astype(np.int32)


@pytest.fixture(scope="module")
def features() -> dict[float, dict[int, dict[str, float]]]:
    reference, labels = _scene()
    return {metres: object_features(reference, labels, _heights(labels.shape, metres)) for metres in (4.0, 9.0)}


def test_a_low_grove_is_crowns_and_the_shape_rules_alone_keep_it(features):
    grove = features[4.0][1]
    rules = ObjectsParams(method="height")
    assert grove["alignment"] < rules.crown_alignment and grove["rectangularity"] < rules.crown_rectangularity
    assert not is_tree(grove, rules)  # neither textured, ragged nor edged every way enough for the tree rule
    assert not is_dark_and_low(grove, rules, THRESHOLD)  # not dark
    assert is_low_crown(grove, rules, THRESHOLD)


def test_the_same_grove_standing_as_high_as_a_roof_is_kept(features):
    grove = features[9.0][1]
    assert grove["height"] == pytest.approx(9.0)
    assert not is_low_crown(grove, ObjectsParams(method="height"), THRESHOLD)


def test_a_low_square_roof_is_no_crown(features):
    roof = features[4.0][2]
    assert roof["alignment"] > 0.9
    assert not is_low_crown(roof, ObjectsParams(method="height"), THRESHOLD)


def test_the_rule_is_off_at_zero_alignment(features):
    assert not is_low_crown(features[4.0][1], ObjectsParams(method="height", crown_alignment=0.0), THRESHOLD)


def test_an_object_without_any_gradient_is_not_judged_by_its_edges():
    labels = np.zeros((80, 80), np.int32)
    cv2.circle(labels, (40, 40), 20, 1, -1)
    feature = object_features(np.full(labels.shape, 100.0, np.float32), labels, _heights(labels.shape, 3.0))[1]
    assert np.isnan(feature["alignment"])
    assert not is_low_crown(feature, ObjectsParams(method="height"), THRESHOLD)


@pytest.mark.parametrize(("name", "value"), [("crown_alignment", -0.1), ("crown_rectangularity", 2.5), ("crown_height", -1.0)])
def test_out_of_range_values_are_refused(name, value):
    with pytest.raises(ParamsError, match=name):
        replace(ObjectsParams(method="height"), **{name: value})


def test_on_a_demo_pair_the_rule_removes_an_object_that_is_no_building():
    rules = ObjectsParams(method="height")
    effect = rule_effect(generate(size=512, seed=2, scenario="multi-temporal"), replace(rules, crown_alignment=0.0), rules)
    assert effect.removed, "the rule removed nothing on a pair with a low grove"
    for ident, iou in effect.removed.items():
        assert iou < 0.5, f"object {ident} was a building (IoU {iou:.2f})"
        assert np.mean(effect.with_rule.left_out[effect.without.reference == ident] == 8) > 0.5  # shown as crowns
    assert effect.with_rule.trees == effect.without.trees + len(effect.removed)
    assert int(effect.with_rule.reference.max()) == int(effect.without.reference.max()) - len(effect.removed)
