"""Buildings the census grid misses: image segments verified by their own census disparity."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import scipy.ndimage

import radcons.stages.objects.searches.missed
from radcons.errors import ParamsError
from radcons.stages.objects.disparity import census_descriptors, object_census_costs
from radcons.stages.objects.ground import HeightMap
from radcons.stages.objects.run import ObjectsParams, height_objects
from radcons.stages.objects.searches.missed import (
    TEXTURED_ROOF_ALIGNMENT,
    is_roof_shaped,
    missed_objects,
    reference_segments,
    segment_cover,
    segment_width,
)

GROUND = 2  # ground disparity of the scene, px
ROOF = (slice(60, 90), slice(80, 112))  # a 30 x 32 px roof: 240 m² at 0.5 m
PARAMS = ObjectsParams(method="height")


def _smooth(shape: tuple[int, int], seed: int, sigma: float, spread: float) -> np.ndarray:
    noise = np.random.default_rng(seed).normal(0.0, 1.0, shape).astype(np.float32)
    return cv2.GaussianBlur(noise, (0, 0), sigma) * np.float32(spread)


def _scene(elevation: int, roof_box: tuple[slice, slice] = ROOF) -> tuple[np.ndarray, np.ndarray]:
    """Textured ground at disparity GROUND, a bright roof ``elevation`` px of disparity above it.

    The target is rendered by its own geometry: ``target(x) = surface(x + d)``, the roof
    drawn over the ground (it stands in front).
    """
    shape = (160, 220)
    ground = 100.0 + _smooth(shape, 0, 1.5, 40.0)
    roof = 170.0 + _smooth((roof_box[0].stop - roof_box[0].start, roof_box[1].stop - roof_box[1].start), 1, 1.0, 4.0)
    reference = ground.copy()
    reference[roof_box] = roof
    target = np.empty_like(ground)
    target[:, : shape[1] - GROUND] = ground[:, GROUND:]
    target[:, shape[1] - GROUND :] = ground[:, -GROUND:]
    shift = GROUND + elevation
    target[roof_box[0], roof_box[1].start - shift : roof_box[1].stop - shift] = roof
    # another date: a tone curve and a little noise
    target = 60.0 * np.sqrt(target) + np.random.default_rng(2).normal(0.0, 0.5, shape).astype(np.float32)
    return reference.astype(np.float32), target.astype(np.float32)


def _missed_height(shape: tuple[int, int]) -> HeightMap:
    """A census height map that saw nothing: the ground's disparity everywhere."""
    flat = np.full(shape, float(GROUND), np.float32)
    return HeightMap(flat, flat.copy(), np.zeros(shape, np.float32), "px", 1.0, 1, (-2.0, 20.0), 1.0)


def _find(reference: np.ndarray, target: np.ndarray, labels: np.ndarray | None = None):
    labels = np.zeros(reference.shape, np.int32) if labels is None else labels
    census = census_descriptors(reference), census_descriptors(target)
    return missed_objects(reference, labels, _missed_height(reference.shape), census, PARAMS, 0.5, PARAMS.min_height_px)


def test_a_small_roof_the_height_map_missed_is_found_with_its_disparity():
    reference, target = _scene(elevation=6)
    found, modal = _find(reference, target)
    assert len(modal) == 1
    truth = np.zeros(reference.shape, bool)
    truth[ROOF] = True
    mask = found == 1
    assert (mask & truth).sum() / (mask | truth).sum() > 0.7  # segmented at 1 m: its edges are 2 px blocks
    assert modal[1] == pytest.approx(GROUND + 6, abs=0.5)


def test_a_roof_level_with_the_ground_and_a_covered_roof_are_not_found():
    reference, target = _scene(elevation=0)
    assert _find(reference, target)[1] == {}
    reference, target = _scene(elevation=6)
    covered = np.zeros(reference.shape, np.int32)
    covered[ROOF] = 1  # an object already holds it
    assert _find(reference, target, covered)[1] == {}


def test_a_strip_narrower_than_a_roof_is_not_found(monkeypatch):
    """A bright strip 1.5 m wide and 60 m long that stands and matches like a roof is a façade or a kerb (rule 5)."""
    reference, target = _scene(elevation=6, roof_box=(slice(20, 140), slice(100, 103)))
    assert _find(reference, target)[1] == {}
    monkeypatch.setattr(radcons.stages.objects.searches.missed, "MIN_WIDTH_M", 0.0)
    assert len(_find(reference, target)[1]) == 1  # the rule, not another one, leaves it out


@pytest.mark.parametrize(("draw", "low", "high"), [("strip", 5, 5), ("square", 9, 9), ("disc", 19, 20), ("L", 7, 8)])
def test_segment_width_is_the_largest_inscribed_disc(draw, low, high):
    """Against scipy's exact Euclidean distance transform, and the drawn sizes (a disc of
    radius 10 px holds 21 pixels across, but its rim pixels sit inside the circle; the L's
    corner holds a slightly wider disc than its 7 px arms)."""
    mask = np.zeros((60, 70), np.uint8)
    if draw == "strip":
        mask[10:50, 20:25] = 1
    elif draw == "square":
        mask[10:19, 20:29] = 1
    elif draw == "disc":
        cv2.circle(mask, (35, 30), 10, 1, -1)
    else:
        mask[5:55, 10:17] = 1
        mask[48:55, 10:60] = 1
    rows, cols = np.nonzero(mask)
    exact = 2 * scipy.ndimage.distance_transform_edt(np.pad(mask, 1)).max() - 1
    assert segment_width(rows, cols) == pytest.approx(exact, abs=0.05)
    assert low - 0.05 <= segment_width(rows, cols) <= high


def test_vectorised_census_costs_equal_a_direct_loop():
    reference = 120.0 + _smooth((60, 90), 3, 1.2, 30.0)
    target = np.roll(reference, -5, axis=1) + _smooth((60, 90), 4, 0.7, 3.0)
    ref_census, tgt_census = census_descriptors(reference), census_descriptors(target)
    rows, cols = np.mgrid[10:40, 0:30]
    rows, cols = rows.ravel(), cols.ravel()
    disparities = np.arange(-3, 25)
    expected = []
    for d in disparities:  # every object pixel that lands in the target, one disparity at a time
        pairs = [(r, c) for r, c in zip(rows, cols) if 0 <= c - d < reference.shape[1]]
        bits = [bin(int(ref_census[r, c]) ^ int(tgt_census[r, c - d])).count("1") for r, c in pairs]
        expected.append(np.mean(bits) / 24.0 if len(pairs) >= 10 else np.inf)
    costs = object_census_costs(ref_census, tgt_census, rows, cols, disparities)
    np.testing.assert_allclose(costs, expected)
    assert disparities[int(np.argmin(costs))] == 5


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("missed_scale", 0.0, r"\[objects\] missed_scale must be in \[10, 10000\]"),
        ("missed_rectangularity", 1.5, r"\[objects\] missed_rectangularity must be in \[0, 1\]"),
        ("missed_margin", -0.1, r"\[objects\] missed_margin must be in \[0, 1\]"),
        ("textured_roof_rectangularity", 2.5, r"\[objects\] textured_roof_rectangularity must be in \[0, 2\]"),
    ],
)
def test_missed_object_parameters_out_of_range_are_refused(field, value, message):
    with pytest.raises(ParamsError, match=message):
        ObjectsParams(method="height", **{field: value})


def test_segments_of_a_reduced_reference_cover_it_at_full_size():
    # 0.25 m pixels are segmented at 0.75 m (a factor 3), 101 x 76 px is no multiple of 3
    reference = np.full((101, 76), 50.0, np.float32)
    reference[30:60, 20:50] = 200.0  # one bright block
    reference[0, 0] = np.nan
    segments = reference_segments(reference, 0.25, 150.0)
    assert segments.shape == reference.shape
    assert segments[0, 0] == -1 and (segments[1:, :] >= 0).all()
    assert len(np.unique(segments[36:54, 26:44])) == 1  # the block's inside is one segment
    assert segments[45, 35] != segments[80, 70]  # ... apart from the ground
    assert segments[100, 75] == segments[97, 72]  # the last, partial block takes its neighbour's


def test_the_left_right_check_leaves_objects_that_are_not_buildings_unassociated():
    from dataclasses import replace

    from demo_data_gen import generate
    from radcons.stages.objects.run import height_objects

    pair = generate(size=512, seed=3, scenario="mixed")
    ref, tgt, meta = pair.reference.as_float32(), pair.target.as_float32(), pair.metadata
    # the edge, dark-and-low, low-crown and outline rules leave out some of the objects this
    # check catches: without them, the check alone is judged
    earlier_rules_only = replace(PARAMS, tree_alignment=0.0, dark_height=0.0, crown_alignment=0.0, outline_edge=0.0)
    found = {
        check: height_objects(
            ref, tgt, replace(earlier_rules_only, cross_check_objects=check),
            gsd_m=meta["gsd_m"], base_to_height=meta["base_to_height"],
        )
        for check in (False, True)
    }
    before, after = found[False], found[True]
    np.testing.assert_array_equal(after.reference, before.reference)  # the objects stay
    assert before.unmatched == () and len(after.unmatched) >= 3
    assert set(after.modal_disparity) == set(before.modal_disparity) - set(after.unmatched)
    for ident in after.unmatched:  # no copy in the target
        assert not (after.target == ident).any() and (before.target == ident).any()
    buildings = sum(int(np.mean(pair.reference_objects[after.reference == i] > 0) > 0.5) for i in after.unmatched)
    assert buildings < len(after.unmatched) / 2  # mostly not buildings (the shadows among them go earlier)


def _shape(texture: float, rectangularity: float, hull: float, alignment: float) -> dict[str, float]:
    return {"texture": texture, "rectangularity": rectangularity, "hull_rectangularity": hull, "alignment": alignment}


@pytest.mark.parametrize(
    "shape, roof, why",
    [
        (_shape(0.8, 0.9, 0.9, 0.3), True, "a plain rectangle"),
        (_shape(2.5, 1.02, 0.97, 0.65), True, "a furnished small roof: textured, a full rectangle, square edges"),
        (_shape(2.5, 1.02, 0.97, TEXTURED_ROOF_ALIGNMENT - 0.06), False, "textured, a rectangle, edges every way"),
        (_shape(2.5, 0.92, 0.97, 0.65), False, "textured and not quite a rectangle"),
        (_shape(2.5, 1.02, 0.90, 0.65), False, "textured, its hull not quite a rectangle"),
        (_shape(0.8, 0.80, 0.90, 0.65), False, "plain but no rectangle"),
    ],
)
def test_a_textured_segment_is_a_roof_only_as_a_full_rectangle_with_square_edges(shape, roof, why):
    assert is_roof_shaped(shape, PARAMS) is roof, why
    if shape["texture"] > PARAMS.tree_texture:
        assert not is_roof_shaped(shape, ObjectsParams(method="height", textured_roof_rectangularity=0.0)), why


def test_a_small_furnished_roof_of_a_demo_pair_is_found():
    from demo_data_gen import generate

    pair = generate(size=512, seed=3, scenario="mixed")  # building 19: 88 m², vents and a box on its roof
    reference, target = pair.reference.as_float32(), pair.target.as_float32()
    geometry = {"gsd_m": pair.metadata["gsd_m"], "base_to_height": pair.metadata["base_to_height"]}
    building = pair.reference_objects == 19

    def best_iou(params: ObjectsParams) -> float:
        labels = height_objects(reference, target, params, **geometry).reference
        under = labels[building]
        under = under[under > 0]
        if not under.size:
            return 0.0
        found = labels == np.bincount(under).argmax()
        return float((found & building).sum() / (found | building).sum())

    assert best_iou(ObjectsParams(method="height", textured_roof_rectangularity=0.0)) < 0.5
    assert best_iou(PARAMS) > 0.9


def test_segment_cover_counts_each_segments_pixels_and_those_under_the_mask():
    rng = np.random.default_rng(2)
    segments = rng.integers(-1, 6, (40, 50)).astype(np.int32)  # -1: invalid pixels
    segments[segments == 4] = 3  # segment 4 has no pixel
    mask = rng.random((40, 50)) < 0.3
    area, covered = segment_cover(segments, mask)
    assert area.tolist() == [int((segments == k).sum()) for k in range(6)]
    assert covered.tolist() == [int((mask & (segments == k)).sum()) for k in range(6)]
