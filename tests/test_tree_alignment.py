"""Objects whose edges turn every way are no buildings (``[objects] tree_alignment``)."""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np
import pytest
from rule_effects import rule_effect

from demo_data_gen import generate
from radcons.errors import ParamsError
from radcons.stages.objects.features import object_features
from radcons.stages.objects.ground import HeightMap
from radcons.stages.objects.rules import is_tree
from radcons.stages.objects.run import ObjectsParams


def _flat_heights(shape: tuple[int, int]) -> HeightMap:
    """Every pixel 8 m above a ground at disparity 0 (the features' height entries unused here)."""
    zero = np.zeros(shape, np.float32)
    return HeightMap(zero + 8.0, zero, zero + 8.0, "m", 1.0, 1, (0.0, 16.0), 1.0)


def _scene() -> tuple[np.ndarray, np.ndarray]:
    """A square roof, the same roof turned by 30 degrees, and a round crown, bright on a smooth ground."""
    labels = np.zeros((200, 200), np.uint8)
    labels[20:70, 20:70] = 1
    corners = cv2.boxPoints(((150.0, 50.0), (50.0, 50.0), 30.0)).astype(np.int32)
    cv2.fillPoly(labels, [corners], 2)
    cv2.circle(labels, (100, 145), 28, 3, -1)
    reference = np.where(labels > 0, 180.0, 60.0).astype(np.float32)
    return reference, labels.astype(np.int32)


def _alignment_by_definition(reference: np.ndarray, mask: np.ndarray, sigma: float) -> float:
    """|sum |g|^2 exp(4 i theta)| / sum |g|^2 over the mask grown by 2 sigma px, one pixel at a time."""
    smooth = cv2.GaussianBlur(reference, (0, 0), sigma)
    gx, gy = cv2.Sobel(smooth, cv2.CV_64F, 1, 0), cv2.Sobel(smooth, cv2.CV_64F, 0, 1)
    grow = 2 * round(sigma)
    band = cv2.dilate(mask.astype(np.uint8), np.ones((2 * grow + 1, 2 * grow + 1), np.uint8)) > 0
    real = imag = total = 0.0
    for row, col in zip(*np.nonzero(band)):
        power = gx[row, col] ** 2 + gy[row, col] ** 2
        angle = math.atan2(gy[row, col], gx[row, col])
        real += power * math.cos(4 * angle)
        imag += power * math.sin(4 * angle)
        total += power
    return math.hypot(real, imag) / total


def test_alignment_follows_its_definition():
    reference, labels = _scene()
    features = object_features(reference, labels, _flat_heights(reference.shape), sigma=1.0)
    for ident in (1, 2, 3):
        expected = _alignment_by_definition(reference, labels == ident, 1.0)
        assert features[ident]["alignment"] == pytest.approx(expected, rel=1e-3)


def test_a_round_smooth_crown_is_a_tree_and_square_roofs_turned_any_way_are_not():
    reference, labels = _scene()
    features = object_features(reference, labels, _flat_heights(reference.shape), sigma=1.0)
    square, turned, crown = features[1], features[2], features[3]
    assert square["alignment"] > 0.9 and turned["alignment"] > 0.6
    assert crown["alignment"] < 0.05
    without = ObjectsParams(tree_alignment=0.0)
    # neither textured nor ragged: only the edges tell the crown from a roof
    assert not any(is_tree(feature, without) for feature in (square, turned, crown))
    rules = ObjectsParams()
    assert not is_tree(square, rules) and not is_tree(turned, rules)
    assert is_tree(crown, rules)


def test_an_object_without_any_gradient_is_not_judged_by_its_edges():
    reference = np.full((80, 80), 100.0, np.float32)
    labels = np.zeros(reference.shape, np.int32)
    labels[20:60, 20:60] = 1
    feature = object_features(reference, labels, _flat_heights(reference.shape))[1]
    assert np.isnan(feature["alignment"])
    assert not is_tree(feature, ObjectsParams())


def test_on_a_demo_pair_the_rule_removes_objects_that_are_no_buildings():
    alone = ObjectsParams(method="height", dark_height=0.0)  # the dark-and-low rule would take some of them too
    effect = rule_effect(generate(size=512, seed=2, scenario="mixed"), replace(alone, tree_alignment=0.0), alone)
    assert effect.removed, "the rule removed nothing on a pair with groves"
    for ident, iou in effect.removed.items():
        assert iou < 0.5, f"object {ident} removed as unaligned is a building (IoU {iou:.2f})"
        # shown as left out by the tree rule (the edges' part of it), not by another
        mask = effect.without.reference == ident
        assert np.mean(effect.with_rule.left_out[mask] == 1) > 0.5 and np.mean(effect.without.left_out[mask] == 1) < 0.2
    assert effect.with_rule.trees > effect.without.trees


@pytest.mark.parametrize("value", [-0.1, 1.5])
def test_a_tree_alignment_out_of_range_is_refused(value):
    with pytest.raises(ParamsError, match="tree_alignment"):
        ObjectsParams(method="height", tree_alignment=value)
