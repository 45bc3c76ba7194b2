"""Low objects with edges every way and no rectangular outline are crowns (``[objects] crown_*``)."""

from __future__ import annotations

from dataclasses import replace

import cv2
import numpy as np
import pytest

from demo_data_gen import generate
from radcons.errors import ParamsError
from radcons.stages.height import HeightMap
from radcons.stages.objects import ObjectsParams, height_objects
from radcons.stages.objects_height import is_dark_and_low, is_low_crown, is_tree, object_features

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
    pair = generate(size=512, seed=2, scenario="multi-temporal")
    reference, target = pair.reference.as_float32(), pair.target.as_float32()
    geometry = {"gsd_m": pair.metadata["gsd_m"], "base_to_height": pair.metadata["base_to_height"]}
    rules = ObjectsParams(method="height")
    without = height_objects(reference, target, replace(rules, crown_alignment=0.0), **geometry)
    with_rule = height_objects(reference, target, rules, **geometry)
    gone = [
        ident for ident in range(1, int(without.reference.max()) + 1)
        if np.mean(with_rule.reference[without.reference == ident] > 0) < 0.2
    ]
    assert gone, "the rule removed nothing on a pair with a low grove"
    truth = pair.reference_objects
    for ident in gone:
        mask = without.reference == ident
        building = np.bincount(truth[mask]).argmax()
        iou = (mask & (truth == building)).sum() / (mask | (truth == building)).sum() if building else 0.0
        assert iou < 0.5, f"object {ident} was a building (IoU {iou:.2f})"
        assert np.mean(with_rule.left_out[mask] == 8) > 0.5  # shown as crowns in the inspector
    assert with_rule.trees == without.trees + len(gone)
    assert int(with_rule.reference.max()) == int(without.reference.max()) - len(gone)
