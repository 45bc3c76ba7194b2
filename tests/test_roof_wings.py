"""Flat roofs cut into rectangular parts are joined again (radcons.stages.objects.joins.wings)."""

import cv2
import numpy as np
import pytest

from demo_data_gen import generate
from radcons.stages.objects.joins.wings import join_wings
from radcons.stages.objects.run import ObjectsParams, height_objects


def _two(first, second, shape=(140, 180)):
    """Label raster with objects 1 and 2 on the given (row0, row1, col0, col1) boxes."""
    labels = np.zeros(shape, np.int32)
    for ident, (r0, r1, c0, c1) in ((1, first), (2, second)):
        labels[r0:r1, c0:c1] = ident
    return labels


@pytest.mark.parametrize(
    "first, second, why",
    [
        ((20, 60, 20, 140), (61, 110, 20, 60), "a wing across the block's long side (an L)"),
        ((20, 60, 20, 100), (20, 60, 101, 150), "the two ends of a long roof"),
    ],
)
def test_two_parts_of_one_flat_roof_become_one_object_with_the_line_between_them(first, second, why):
    labels = _two(first, second)
    labels[120:135, 150:170] = 3  # another object, left alone
    joined, modal, scores = join_wings(labels, {1: 10.0, 2: 10.3, 3: 4.0}, {1: 0.8, 2: 0.9, 3: 0.5})
    assert int(joined.max()) == 2, why
    roof = joined == joined[first[0] + 1, first[2] + 1]
    expected = (labels == 1) | (labels == 2)
    cross = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
    line = (cv2.dilate((labels == 1).astype(np.uint8), cross) > 0) & (
        cv2.dilate((labels == 2).astype(np.uint8), cross) > 0
    ) & (labels == 0)  # 4-adjacent to both
    assert np.array_equal(roof, expected | line), why  # both parts and the one-pixel line between them
    assert np.array_equal(joined[120:135, 150:170] > 0, np.ones((15, 20), bool))
    larger = 1 if (labels == 1).sum() >= (labels == 2).sum() else 2
    assert modal[int(joined[first[0] + 1, first[2] + 1])] == {1: 10.0, 2: 10.3}[larger]
    assert scores[int(joined[first[0] + 1, first[2] + 1])] == {1: 0.8, 2: 0.9}[larger]


def _triangle_beside_a_block() -> np.ndarray:
    labels = _two((20, 60, 20, 140), (0, 0, 0, 0))
    cv2.fillPoly(labels, [np.array([[40, 60], [100, 60], [70, 110]], np.int32)], 2)  # its base along the block
    return labels


def _turned_beside_a_block() -> np.ndarray:
    labels = np.zeros((140, 180), np.int32)
    corners = cv2.boxPoints(((80.0, 82.0), (30.0, 46.0), 30.0)).astype(np.int32)
    cv2.fillPoly(labels, [corners], 2)
    labels[20:60, 20:140] = 1  # the block over the part's top corner: they touch
    return labels


@pytest.mark.parametrize(
    "labels, modal, why",
    [
        (_two((20, 60, 20, 140), (61, 110, 20, 60)), {1: 10.0, 2: 11.0}, "two heights"),
        (_two((20, 60, 20, 140), (61, 110, 20, 60)), {1: 10.0}, "no D̄m for one"),
        (_two((20, 60, 20, 140), (61, 110, 130, 170)), {1: 10.0, 2: 10.0}, "touching over a quarter of its width"),
        (_triangle_beside_a_block(), {1: 10.0, 2: 10.0}, "a part that is no rectangle"),
        (_turned_beside_a_block(), {1: 10.0, 2: 10.0}, "a part turned by 30 degrees"),
    ],
)
def test_other_neighbours_stay_apart(labels, modal, why):
    joined, kept, _ = join_wings(labels, modal, {})
    assert int(joined.max()) == 2, why
    assert np.array_equal(joined, labels), why
    assert kept == modal


def test_each_object_joins_one_other_at_most():
    labels = np.zeros((80, 200), np.int32)
    labels[20:60, 10:60], labels[20:60, 61:110], labels[20:60, 111:160] = 1, 2, 3  # three blocks end to end
    joined, modal, _ = join_wings(labels, {1: 10.0, 2: 10.0, 3: 10.0}, {})
    assert int(joined.max()) == 2 and len(modal) == 2


def _majority(labels: np.ndarray, mask: np.ndarray) -> int:
    under = labels[mask]
    return int(np.bincount(under).argmax()) if under.size else 0


def test_on_a_demo_pair_the_parts_joined_are_parts_of_one_building():
    pair = generate(size=512, seed=1, scenario="mixed")
    reference, target = pair.reference.as_float32(), pair.target.as_float32()
    geometry = {"gsd_m": pair.metadata["gsd_m"], "base_to_height": pair.metadata["base_to_height"]}
    without = height_objects(reference, target, ObjectsParams(method="height", join_wings=False), **geometry)
    found = height_objects(reference, target, ObjectsParams(method="height"), **geometry)
    truth = pair.reference_objects
    joined = 0
    for ident in range(1, int(found.reference.max()) + 1):
        mask = found.reference == ident
        parts = [p for p in np.unique(without.reference[mask]) if p and np.mean(mask[without.reference == p]) > 0.9]
        if len(parts) < 2:
            continue
        joined += 1
        buildings = {_majority(truth, without.reference == p) for p in parts}
        assert len(buildings) == 1 and 0 not in buildings, f"object {ident} joins parts of buildings {buildings}"
        building = truth == buildings.pop()
        iou = (mask & building).sum() / (mask | building).sum()
        best_part = max(
            ((without.reference == p) & building).sum() / ((without.reference == p) | building).sum() for p in parts
        )
        assert iou > 0.9 and iou > best_part
    assert joined >= 1, "the pair was chosen for a roof cut in two"
