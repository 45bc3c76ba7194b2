"""A gabled roof found by one plane grows by the other, found across its ridge (radcons.stages.objects.joins.mirror)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from radcons.stages.objects.census_check import CensusCheck
from radcons.stages.objects.disparity import census_descriptors
from radcons.stages.objects.joins.mirror import (
    MIN_RISE_PX,
    complete_gables,
    mirrored,
    ridge_side,
)
from radcons.stages.objects.run import ObjectsParams, _with_gables_completed

PARAMS = ObjectsParams(method="height")
SHAPE = (150, 200)
GROUND = 10.0  # ground disparity, px
EAVES, RIDGE = 16.0, 20.0  # disparity of the gable's eaves and ridge, px
NORTH = (slice(40, 70), slice(40, 170))  # the plane north of the ridge (row 70)
SOUTH = (slice(70, 100), slice(40, 170))  # the plane south of it
RADIUS = 3


def _gable(eaves: float = EAVES, ridge: float = RIDGE) -> np.ndarray:
    """Disparity of a gabled roof over both planes, rising linearly from the eaves to the ridge."""
    rows = np.arange(SHAPE[0], dtype=np.float64)[:, None]
    roof = ridge - (ridge - eaves) * np.abs(rows + 0.5 - 70.0) / 30.0
    return np.broadcast_to(roof, SHAPE).copy()


def _pair(disparity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A textured reference and the target it makes through ``disparity`` (``target(x - d) = reference(x)``)."""
    noise = np.random.default_rng(3).normal(0.0, 1.0, SHAPE).astype(np.float32)
    reference = 120.0 + 40.0 * cv2.GaussianBlur(noise, (0, 0), 1.0)
    rows, cols = np.indices(SHAPE, dtype=np.float32)
    # target(x', y) = reference(x' + d, y), with d read at the target's column (a close inverse for smooth d)
    target = cv2.remap(
        reference, cols + disparity.astype(np.float32), rows, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT
    )
    return reference, target


def _check(reference: np.ndarray, target: np.ndarray) -> CensusCheck:
    census = (census_descriptors(reference), census_descriptors(target))
    ground = np.full(SHAPE, GROUND, np.float32)
    return CensusCheck(census, np.arange(0, 30), ground, lowest=3.0, params=PARAMS)


def _scene(south: str | float, gable: np.ndarray | None = None) -> tuple[np.ndarray, CensusCheck]:
    """Ground, the gable's north plane, and over the south plane's box: ``"gable"`` its south plane, ``"steeper"``
    a plane from the ridge to eaves twice as far down, or the disparity ``south``."""
    disparity = np.full(SHAPE, GROUND)
    gable = _gable() if gable is None else gable
    disparity[NORTH] = gable[NORTH]
    if south == "steeper":
        gable = _gable(2.0 * EAVES - RIDGE, RIDGE)
    disparity[SOUTH] = gable[SOUTH] if isinstance(south, str) else south
    return disparity, _check(*_pair(disparity))


def _labels(*boxes: tuple[slice, slice]) -> np.ndarray:
    labels = np.zeros(SHAPE, np.int32)
    for ident, box in enumerate(boxes, start=1):
        labels[box] = ident
    return labels


def test_the_ridge_side_is_where_the_disparity_rises_by_the_truths_rise():
    disparity, check = _scene("gable")
    rows, cols = np.nonzero(_labels(NORTH) == 1)
    ridge = ridge_side(rows, cols, check.census, 18.0, RADIUS)
    assert ridge is not None
    assert ridge.direction[1] == pytest.approx(1.0, abs=1e-3)  # southwards, towards row 70
    along = ridge.along(rows, cols)
    near, far = along > ridge.offset / 3.0, along < -ridge.offset / 3.0
    truth = np.median(disparity[rows[near], cols[near]]) - np.median(disparity[rows[far], cols[far]])
    assert ridge.rise == pytest.approx(truth, abs=0.5)
    assert ridge.rise > MIN_RISE_PX


def test_a_flat_roof_has_no_ridge_to_speak_of():
    disparity = np.full(SHAPE, GROUND)
    disparity[NORTH] = 18.0
    check = _check(*_pair(disparity))
    rows, cols = np.nonzero(_labels(NORTH) == 1)
    ridge = ridge_side(rows, cols, check.census, 18.0, RADIUS)
    assert ridge is not None and abs(ridge.rise) < MIN_RISE_PX


def test_the_mirror_of_a_shape_is_its_reflection_across_its_last_row_on_the_ridge_side():
    mask = np.zeros(SHAPE, bool)
    mask[40:70, 40:170] = True
    mask[55:70, 40:60] = False  # a notch at the ridge's west end
    rows, cols = np.nonzero(mask)
    disparity, check = _scene("gable")
    ridge = ridge_side(rows, cols, check.census, 18.0, RADIUS)
    expected = np.zeros(SHAPE, bool)
    expected[70:99] = mask[40:69][::-1]  # across the centres of row 69: a row narrower than the shape
    mirror = mirrored(mask, ridge) & ~mask
    assert (mirror & expected).sum() / (mirror | expected).sum() > 0.99  # to the pixel


def test_the_missing_plane_is_found_and_the_roof_gets_one_dm():
    disparity, check = _scene("gable")
    labels = _labels(NORTH)
    labels[120:140, 10:30] = 2  # a flat object elsewhere, left alone
    grown, modal, which = complete_gables(labels, {1: 18.0, 2: 10.0}, check, RADIUS)
    assert which == [1]
    roof = np.zeros(SHAPE, bool)
    roof[40:100, 40:170] = True
    assert ((grown == 1) & roof).sum() / ((grown == 1) | roof).sum() > 0.95
    assert np.array_equal(grown == 2, labels == 2)
    assert modal[1] == pytest.approx(np.median(disparity[roof]), abs=0.75)  # the roof's disparity, both planes


@pytest.mark.parametrize(
    "south, gable, modal, why",
    [
        (GROUND, (EAVES, RIDGE), 18.0, "ground beside a sloping plane: it matches better at the ground's disparity"),
        (18.0, (EAVES, RIDGE), 18.0, "a flat roof at the plane's height: nothing falls away from the ridge"),
        ("gable", (GROUND + 0.5, GROUND + 3.0), GROUND + 2.0, "a gable 0.5-3 px up: lower than a building (3 px)"),
        ("steeper", (EAVES, RIDGE), 18.0, "a plane falling twice as steeply: its eaves 4 px below the object's"),
    ],
)
def test_no_plane_is_added_where_the_mirror_is_no_roofs_plane(south, gable, modal, why):
    _, check = _scene(south, _gable(*gable))
    labels = _labels(NORTH)
    grown, kept, which = complete_gables(labels, {1: modal}, check, RADIUS)
    assert which == [], why
    assert np.array_equal(grown, labels)
    assert kept == {1: modal}


def test_an_object_that_is_no_rectangle_does_not_grow():
    _, check = _scene("gable")
    labels = _labels(NORTH)
    rows, cols = np.indices(SHAPE)
    labels[(labels == 1) & (cols - 40 > 130 * (rows - 40) / 30)] = 0  # a triangle: half its rectangle
    grown, _, which = complete_gables(labels, {1: 18.0}, check, RADIUS)
    assert which == [] and np.array_equal(grown, labels)


def test_a_plane_cut_from_its_twin_along_a_ragged_line_grows():
    # the snapping can follow a roof's texture instead of its ridge where both planes are
    # alike: the plane then fills about 0.75 of its rectangle (demo 'mixed' seed 1 at
    # 1024 px, building 10: 0.63), and the mirror across its last row still finds its twin
    disparity, check = _scene("gable")
    labels = _labels(NORTH)
    rows, cols = np.indices(SHAPE)
    labels[(labels == 1) & (rows >= 55 + 15 * ((cols - 40) % 20) / 19)] = 0  # teeth 20 px wide towards the ridge
    (_, size, _) = cv2.minAreaRect(np.column_stack(np.nonzero(labels)[::-1]).astype(np.float32))
    assert 0.6 < (labels == 1).sum() / (size[0] * size[1]) < 0.8
    grown, modal, which = complete_gables(labels, {1: 18.0}, check, RADIUS)
    assert which == [1]
    south = np.zeros(SHAPE, bool)
    south[SOUTH] = True
    assert ((grown == 1) & south).sum() > 0.5 * south.sum()
    assert ((grown == 1) & (disparity == GROUND)).sum() < 0.02 * (grown == 1).sum()  # none of the ground beyond


def test_a_plane_that_is_an_object_already_is_taken_in():
    disparity, check = _scene("gable")
    labels = _labels(NORTH, SOUTH)
    grown, modal, which = complete_gables(labels, {1: 18.0, 2: 18.2}, check, RADIUS)
    assert len(which) == 1 and list(modal) == which
    assert np.array_equal(grown > 0, labels > 0)
    assert len(np.unique(grown[grown > 0])) == 1


def test_a_plane_at_another_height_is_not_taken_in():
    _, check = _scene("gable")
    labels = _labels(NORTH, SOUTH)
    grown, modal, which = complete_gables(labels, {1: 18.0, 2: 23.0}, check, RADIUS)
    assert which == [] and np.array_equal(grown, labels) and modal == {1: 18.0, 2: 23.0}


def test_objects_without_a_dm_neither_grow_nor_are_taken_in():
    _, check = _scene("gable")
    labels = _labels(NORTH, SOUTH)
    grown, modal, which = complete_gables(labels, {2: 18.0}, check, RADIUS)
    assert np.array_equal(grown, labels) and which == [] and modal == {2: 18.0}


def test_the_height_method_completes_gables_by_default():
    assert ObjectsParams().complete_gables is True


def test_the_height_method_numbers_the_objects_again_when_the_last_one_is_taken_in():
    _, check = _scene("gable")
    reference, target = _pair(_scene("gable")[0])
    labels = _labels(NORTH, SOUTH)  # the south plane, the last object, is taken in by the north one
    (joined, modal, scores), gables = _with_gables_completed(
        (labels, {1: 18.0, 2: 18.2}, {1: 0.5, 2: 0.6}), (reference, target), check, RADIUS, 1.0
    )
    assert int(joined.max()) == 1 and np.array_equal(joined > 0, labels > 0)
    assert np.array_equal(gables, labels > 0)  # where the grown roof lies, for the shadow rule to spare
    assert list(modal) == [1] and list(scores) == [1]
    assert scores[1] > 0.6  # scored again over the whole roof, at its D̄m
