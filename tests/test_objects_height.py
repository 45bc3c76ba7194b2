"""Objects from height: boxes on sloped ground, flat scenes, transfer, association, outputs."""

from __future__ import annotations

import json
from dataclasses import replace

import cv2
import numpy as np
import pytest

from radcons.errors import ParamsError
from radcons.io import Raster
from radcons.io.geojson import read_geojson, write_geojson
from radcons.numerics.census import CensusParams, census_disparity
from radcons.numerics.coarse_disparity import checked_census, fill_occlusions
from radcons.params import Params
from radcons.results import Matches
from radcons.stages.association.height import associate_by_height
from radcons.stages.association.params import AssociationParams
from radcons.stages.objects.disparity import census_descriptors, object_census_disparity
from radcons.stages.objects.features import object_features
from radcons.stages.objects.ground import HeightMap, ground_disparity
from radcons.stages.objects.regions import _fill_holes, _valid_spread
from radcons.stages.objects.rules import LEFT_OUT_RULES, is_tree
from radcons.stages.objects.run import ObjectsParams, height_objects
from radcons.stages.objects.transfer import object_disparities, transfer_to_target

BOXES = ((40, 50, 44, 60), (150, 40, 50, 40), (60, 160, 56, 48), (170, 170, 40, 52))  # row, col, rows, cols
BOX_RISE = 9  # disparity px a box adds above its ground


def _texture(rng: np.random.Generator, shape: tuple[int, int], sigma: float, amplitude: float) -> np.ndarray:
    noise = rng.normal(0.0, 1.0, shape).astype(np.float32)
    return cv2.GaussianBlur(noise, (0, 0), sigma) * amplitude


def _stereo_scene(
    size: int = 256, boxes=BOXES, seed: int = 0, slope: float = 0.03, plain: tuple[int, ...] = (), courts: dict | None = None
):
    """A reference, its target under a known disparity, the box labels and the disparity.

    Ground disparity ``6 + slope * x + slope * y / 2`` (a tilted plane), each box
    ``BOX_RISE`` px above the ground under its left edge; the boxes of ``plain`` (ids)
    keep the ground's texture, without an edge at their outline, in a lawn (the ground
    there and 12 px around it at a third of its contrast). The target is painted from the
    reference pixel by pixel, ``target(x - round(d), y) = reference(x, y)``, nearer
    (larger d) pixels last; what no reference pixel reaches gets fresh ground texture.
    ``courts`` maps a box id to a courtyard (row, col, rows, cols, within the image) left
    as ground inside it: the ground's disparity and texture, label 0.
    """
    rng = np.random.default_rng(seed)
    rows, cols = np.mgrid[0:size, 0:size].astype(np.float32)
    disparity = 6.0 + slope * cols + 0.5 * slope * rows
    reference = 100.0 + _texture(rng, (size, size), 1.2, 60.0)
    for ident in plain:
        r, c, h, w = boxes[ident - 1]
        lawn = (slice(max(r - 12, 0), r + h + 12), slice(max(c - 12, 0), c + w + 12))
        reference[lawn] = 100.0 + (reference[lawn] - 100.0) / 3.0
    ground = reference.copy()
    truth = np.zeros((size, size), np.int32)
    for ident, (r, c, h, w) in enumerate(boxes, start=1):
        truth[r : r + h, c : c + w] = ident
        disparity[r : r + h, c : c + w] = disparity[r, c] + BOX_RISE
        roof = 170.0 + _texture(rng, (h, w), 1.2, 40.0)  # drawn for every box: the others keep their texture
        if ident not in plain:
            reference[r : r + h, c : c + w] = roof
        if courts and ident in courts:
            cr, cc, ch, cw = courts[ident]
            court = (slice(cr, cr + ch), slice(cc, cc + cw))
            truth[court] = 0
            disparity[court] = 6.0 + slope * cols[court] + 0.5 * slope * rows[court]
            reference[court] = ground[court]
    target = 100.0 + _texture(rng, (size, size), 1.2, 60.0)
    order = np.argsort(np.round(disparity).ravel(), kind="stable")
    ys, xs = np.unravel_index(order, disparity.shape)
    xt = xs - np.round(disparity.ravel()[order]).astype(np.int64)
    inside = xt >= 0
    target[ys[inside], xt[inside]] = reference[ys[inside], xs[inside]]
    reference += rng.normal(0.0, 1.0, reference.shape).astype(np.float32)
    target += rng.normal(0.0, 1.0, target.shape).astype(np.float32)
    return reference.astype(np.float32), target.astype(np.float32), truth, disparity


def _best_iou(truth: np.ndarray, labels: np.ndarray, ident: int) -> float:
    mask = truth == ident
    under = labels[mask]
    under = under[under > 0]
    if under.size == 0:
        return 0.0
    other = labels == np.bincount(under).argmax()
    return float((mask & other).sum() / (mask | other).sum())


@pytest.fixture(scope="module")
def boxes_found():
    reference, target, truth, disparity = _stereo_scene()
    return height_objects(reference, target, ObjectsParams(method="height", census_side=256)), truth, disparity


def test_boxes_on_sloped_ground_are_found(boxes_found):
    found, truth, _ = boxes_found
    assert found.method == "height" and found.note == ""
    ious = [_best_iou(truth, found.reference, i) for i in range(1, len(BOXES) + 1)]
    assert min(ious) > 0.75, ious
    assert found.reference.max() == len(BOXES)  # nothing on the sloped ground


def test_boxes_move_by_their_own_disparity(boxes_found):
    found, truth, disparity = boxes_found
    for ident, (r, c, _, _) in enumerate(BOXES, start=1):
        found_id = _majority(found.reference, truth == ident)
        assert abs(found.modal_disparity[found_id] - np.round(disparity[r, c])) < 1.0


def _majority(labels: np.ndarray, mask: np.ndarray) -> int:
    under = labels[mask]
    return int(np.bincount(under[under > 0]).argmax())


def test_height_is_in_disparity_pixels_without_geometry(boxes_found):
    found, truth, _ = boxes_found
    full = found.height.full(truth.shape)
    inner = cv2.erode((truth > 0).astype(np.uint8), np.ones((9, 9), np.uint8)) > 0
    assert found.height.unit == "px"
    assert abs(float(np.nanmedian(full[inner])) - BOX_RISE) < 1.5
    ground = cv2.dilate((truth > 0).astype(np.uint8), np.ones((25, 25), np.uint8)) == 0
    assert abs(float(np.nanmedian(full[ground]))) < 0.5


def test_flat_scene_gives_no_objects_and_a_note():
    reference, target, truth, _ = _stereo_scene(boxes=())
    found = height_objects(reference, target, ObjectsParams(method="height", census_side=256))
    assert found.method == "height"
    assert not found.reference.any() and not found.target.any()
    assert "flat" in found.note or "no elevated region" in found.note


def test_unmatchable_pair_falls_back_to_the_image_only_method():
    rng = np.random.default_rng(5)
    reference = _texture(rng, (192, 192), 1.0, 50.0) + 100
    target = _texture(rng, (192, 192), 1.0, 50.0) + 100  # another scene: nothing matches
    found = height_objects(reference, target, ObjectsParams(method="height", min_valid_share=0.6))
    assert found.method == "mbi" and found.height is None
    assert "consistent on" in found.note and "image-only" in found.note


def test_consistency_is_measured_on_the_overlap_of_the_images():
    # The target covers 40 % of the reference's ground (an affine-rectified crop of
    # another extent): the unmatched 60 % is no failure of the disparity.
    reference, target, truth, _ = _stereo_scene()
    target[int(0.4 * target.shape[0]) :] = np.nan
    found = height_objects(reference, target, ObjectsParams(method="height", census_side=256, min_valid_share=0.6))
    assert found.method == "height", found.note
    assert found.height.valid_share > 0.6  # over the whole image it would be under 0.4
    assert _best_iou(truth, found.reference, 1) > 0.75  # the box inside the overlap


def test_a_pair_too_small_for_census_takes_the_image_only_objects():
    reference, target, _, _ = _stereo_scene(size=24, boxes=((4, 4, 10, 10),))
    found = height_objects(reference, target, ObjectsParams(method="height"))
    assert found.method == "mbi" and "too small" in found.note


def test_ground_follows_a_slope_under_a_box():
    rows, cols = np.mgrid[0:128, 0:128].astype(np.float32)
    plane = 4.0 + 0.05 * cols - 0.02 * rows
    disparity = plane.copy()
    disparity[40:80, 40:90] += 10.0
    ground = ground_disparity(disparity, 100, 10.0, 2.0)
    assert np.abs(ground - plane)[5:-5, 5:-5].max() < 0.6


def test_ground_of_wide_windows_follows_a_slope_to_the_corners():
    # sigma 30 px: the plane fits are solved on 7 px blocks and resampled
    rows, cols = np.mgrid[0:250, 0:250].astype(np.float32)
    plane = 3.0 + 0.04 * cols + 0.03 * rows
    disparity = plane.copy()
    disparity[60:110, 120:200] += 8.0
    disparity[np.random.default_rng(2).random(disparity.shape) < 0.1] = np.nan
    ground = ground_disparity(disparity, 120, 10.0, 1.0)
    assert np.abs(ground - plane).max() < 0.1


def test_a_roof_matches_better_at_its_disparity_than_a_raised_patch_of_ground():
    rng = np.random.default_rng(3)
    size, rise = 160, 6
    reference = 100.0 + _texture(rng, (size, size), 1.2, 60.0)
    labels = np.zeros((size, size), np.int32)
    labels[30:70, 40:90] = 1  # a roof, truly raised
    labels[100:140, 40:90] = 2  # ground the disparity raised by mistake
    reference[30:70, 40:90] = 170.0 + _texture(rng, (40, 50), 1.2, 40.0)
    target = 100.0 + _texture(rng, (size, size), 1.2, 60.0)
    target[:, :-4] = reference[:, 4:]  # the ground at disparity 4, the roof at 4 + rise
    target[30:70, 40 - 4 - rise : 90 - 4 - rise] = reference[30:70, 40:90]
    measured = np.where(labels > 0, 4.0 + rise, 4.0).astype(np.float32)
    ground = np.full((size, size), 4.0, np.float32)
    heights = HeightMap(measured, ground, measured - ground, "px", 1.0, 1, (0.0, 16.0), 1.0)
    found = object_disparities(reference.astype(np.float32), target.astype(np.float32), labels, heights)
    roof, patch = found[1], found[2]
    assert abs(roof[0] - (4 + rise)) < 0.5
    assert roof[2] > ObjectsParams().min_match_score  # census cost lower at D̄m than at the ground's
    assert patch[2] < 0.0


def test_a_strip_of_ground_inside_the_outline_does_not_pull_dm_off_the_roof():
    rng = np.random.default_rng(4)
    size, rise = 160, 2
    reference = 100.0 + _texture(rng, (size, size), 1.2, 60.0)
    reference[50:74, 60:84] = 170.0 + _texture(rng, (24, 24), 1.2, 40.0)  # a roof 24 x 24 px
    target = 100.0 + _texture(rng, (size, size), 1.2, 60.0)
    target[:, :-4] = reference[:, 4:]  # the ground at disparity 4, the roof at 4 + rise
    target[50:74, 60 - 4 - rise : 84 - 4 - rise] = reference[50:74, 60:84]
    labels = np.zeros((size, size), np.int32)
    labels[44:80, 54:90] = 1  # the outline snapped 6 px out: more ground than roof under it
    measured = np.where(labels > 0, 4.0 + rise, 4.0).astype(np.float32)  # the coarse map: the roof's
    ground = np.full((size, size), 4.0, np.float32)
    heights = HeightMap(measured, ground, measured - ground, "px", 1.0, 1, (0.0, 16.0), 1.0)
    census = census_descriptors(reference.astype(np.float32)), census_descriptors(target.astype(np.float32))
    rows, cols = np.nonzero(labels == 1)
    whole = object_census_disparity(*census, rows, cols, 4.0 + rise, 3)
    assert abs(whole - 4.0) < 0.5  # all its pixels: the ground wins
    # sigma 2 px (0.5 m at 0.25 m a pixel): the core 2 px inside the outline, more roof than ground
    found = object_disparities(reference.astype(np.float32), target.astype(np.float32), labels, heights, 2.0, 3, census)
    assert abs(found[1][0] - (4 + rise)) < 0.5


def test_a_raised_patch_that_no_image_edge_bounds_is_left_out():
    # Box 2 keeps the ground's texture: raised by the disparity alone, as a lawn a
    # matcher lifts; the other boxes are roofs brighter than the ground. The tree rules
    # are off, so that only the outline can tell them apart.
    reference, target, truth, _ = _stereo_scene(plain=(2,))
    params = ObjectsParams(
        method="height", census_side=256, tree_texture=100.0, tree_rectangularity=0.0, tree_alignment=0.0,
        find_missed=False, find_in_removed=False,
    )
    found = height_objects(reference, target, params)
    assert not found.reference[truth == 2].any()
    assert all(_best_iou(truth, found.reference, i) > 0.75 for i in (1, 3, 4))
    assert found.mismatched >= 1
    # the analyst sees where it went and why: the patch's pixels carry the outline rule's code
    assert LEFT_OUT_RULES[5].endswith("(outline_edge)")
    assert np.mean(found.left_out[truth == 2] == 5) > 0.75
    assert not found.left_out[found.reference > 0].any()
    kept = height_objects(reference, target, replace(params, outline_edge=0.0))  # the rule off
    assert _best_iou(truth, kept.reference, 2) > 0.5
    features = object_features(reference, kept.reference, kept.height)
    outline = {i: features[_majority(kept.reference, truth == i)]["outline"] for i in range(1, 5)}
    assert outline[2] < params.outline_edge < min(outline[i] for i in (1, 3, 4)), outline


def test_holes_are_filled_but_a_courtyard_on_the_ground():
    labels = np.zeros((60, 60), np.int32)
    labels[5:55, 5:55] = 1
    labels[15:35, 15:35] = 0  # a hole 20 x 20 px mostly on the ground: a courtyard
    labels[40:46, 40:46] = 0  # a hole the ground mask does not reach (roof furniture the watershed missed)
    labels[0:3, 0:3] = 2  # another object in the corner, untouched
    ground = np.zeros(labels.shape, bool)
    ground[16:34, 14:36] = True  # 81 % of the courtyard
    filled = _fill_holes(labels, ground)
    assert not filled[15:35, 15:35].any()
    assert (filled[40:46, 40:46] == 1).all()
    assert (filled[0:3, 0:3] == 2).all()
    everything = _fill_holes(labels, np.zeros(labels.shape, bool))
    assert (everything[5:55, 5:55] == 1).all()


def test_a_courtyard_stays_out_of_its_building():
    # one building 96 x 96 px with a courtyard 36 x 36 px of ground in its middle
    reference, target, truth, _ = _stereo_scene(boxes=((80, 80, 96, 96),), courts={1: (110, 110, 36, 36)})
    found = height_objects(reference, target, ObjectsParams(method="height", census_side=256))
    building = _majority(found.reference, truth == 1)
    assert np.mean(found.reference[110:146, 110:146] == building) < 0.2
    assert _best_iou(truth, found.reference, 1) > 0.8


def test_a_notched_roof_stays_a_building_and_a_grove_is_a_tree():
    size = 200
    labels = np.zeros((size, size), np.int32)
    labels[20:80, 20:100] = 1  # a U-shaped roof: 60 x 80 with a 40 x 50 court open to the top
    labels[20:60, 35:85] = 0
    for row, col in ((130, 40), (130, 100), (180, 70), (145, 70)):  # a grove: four crowns in a triangle
        cv2.circle(labels, (col, row), 11, 2, -1)
    reference = np.full((size, size), 100.0, np.float32)  # no texture: the shapes alone decide
    zero = np.zeros((size, size), np.float32)
    heights = HeightMap(zero + 8.0, zero, zero + 8.0, "m", 1.0, 1, (0.0, 16.0), 1.0)
    features = object_features(reference, labels, heights)
    roof, grove = features[1], features[2]
    assert roof["rectangularity"] == pytest.approx(2800 / 4800, abs=0.05)  # ragged by area alone
    assert roof["hull_rectangularity"] > 0.95  # its hull is the whole rectangle
    assert grove["hull_rectangularity"] < ObjectsParams().tree_hull_rectangularity
    assert not is_tree(roof, ObjectsParams())
    assert is_tree(grove, ObjectsParams())


def test_shape_and_height_features_match_a_direct_computation_over_every_pixel():
    size, factor = 203, 3  # the census grid does not divide the image
    labels = np.zeros((size, size), np.int32)
    corners = cv2.boxPoints(((60.0, 70.0), (70.0, 36.0), 27.0)).astype(np.int32)
    cv2.fillPoly(labels, [corners], 1)  # a rotated roof
    labels[130:170, 20:60] = 2  # a roof in two parts with a hole
    labels[140:150, 30:40] = 0
    labels[130:160, 75:90] = 2
    labels[150:201, 150:203] = 3  # against the image's edges
    rng = np.random.default_rng(4)
    cells = -(-size // factor) - 1  # the grid stops short of the image's last pixels
    rows, cols = np.mgrid[0:cells, 0:cells]
    height = (0.3 * rows - 0.1 * cols + rng.normal(0.0, 0.5, (cells, cells))).astype(np.float32)
    height[5, 5] = np.nan
    heights = HeightMap(height, np.zeros_like(height), height, "m", 1.0, factor, (0.0, 16.0), 1.0)
    features = object_features(np.full((size, size), 100.0, np.float32), labels, heights)
    coarse = labels[::factor, ::factor][:cells, :cells]
    for index in (1, 2, 3):
        points = cv2.findNonZero((labels == index).astype(np.uint8))
        (_, _), (w, h), _ = cv2.minAreaRect(points)
        assert features[index]["rectangularity"] == pytest.approx((labels == index).sum() / (w * h), rel=1e-5)
        assert features[index]["hull_rectangularity"] == pytest.approx(
            cv2.contourArea(cv2.convexHull(points)) / (w * h), rel=1e-5
        )
        at = np.nonzero((coarse == index) & np.isfinite(height))
        design = np.column_stack([at[0], at[1], np.ones(at[0].size)])
        coef, *_ = np.linalg.lstsq(design, height[at].astype(np.float64), rcond=None)
        assert features[index]["height"] == pytest.approx(float(np.median(height[at])))
        assert features[index]["roughness"] == pytest.approx(np.sqrt(np.mean((design @ coef - height[at]) ** 2)))


def test_a_textured_rectangle_is_a_roof_and_a_textured_blob_a_tree():
    size = 160
    labels = np.zeros((size, size), np.int32)
    labels[20:60, 20:70] = 1  # a small roof ...
    cv2.circle(labels, (110, 110), 22, 2, -1)  # ... and a crown, both as textured
    rng = np.random.default_rng(5)
    reference = (100.0 + 40.0 * rng.standard_normal((size, size))).astype(np.float32)
    reference[labels == 0] = 100.0 + 2.0 * rng.standard_normal(int((labels == 0).sum()))  # smooth ground
    zero = np.zeros((size, size), np.float32)
    heights = HeightMap(zero + 8.0, zero, zero + 8.0, "m", 1.0, 1, (0.0, 16.0), 1.0)
    features = object_features(reference, labels, heights)
    roof, crown = features[1], features[2]
    rules = ObjectsParams(tree_alignment=0.0)  # the noise has no edges to align: tests/test_tree_alignment.py
    assert roof["texture"] > rules.tree_texture and crown["texture"] > rules.tree_texture
    assert roof["rectangularity"] >= rules.roof_rectangularity > crown["rectangularity"]
    assert not is_tree(roof, rules)
    assert is_tree(crown, rules)
    assert is_tree(roof, ObjectsParams(roof_rectangularity=2.0, tree_alignment=0.0))  # texture alone decides


def test_checked_census_keeps_what_pandoras_cross_check_keeps():
    reference, target, _, disparity = _stereo_scene(size=128, boxes=((30, 40, 40, 40),))
    ours = checked_census(reference, target, (0.0, 24.0), CensusParams())
    pandora = census_disparity(reference, target, (0.0, 24.0), CensusParams(cross_check="accurate"))
    assert np.mean(np.isfinite(ours) == np.isfinite(pandora)) > 0.98
    both = np.isfinite(ours) & np.isfinite(pandora)
    assert np.allclose(ours[both], pandora[both])
    hidden = np.zeros(ours.shape, bool)  # ground just left of the box, hidden from the target
    hidden[34:66, 33:38] = True
    assert np.isnan(ours[hidden]).mean() > 0.8
    assert np.mean(np.abs(ours - np.round(disparity))[np.isfinite(ours)] <= 1.0) > 0.95


def test_occlusions_are_filled_from_the_lower_side():
    disparity = np.array([[1.0, np.nan, np.nan, 5.0, 5.0, np.nan, 5.0]], np.float32)
    assert np.allclose(fill_occlusions(disparity), [[1, 1, 1, 5, 5, 5, 5]])


def test_the_height_spread_leaves_out_cells_without_height():
    rng = np.random.default_rng(3)
    height = rng.normal(5.0, 3.0, (9, 11)).astype(np.float32)
    height[:2] = np.nan  # the census window's margin at the top
    height[5, 4:7] = np.nan
    height[7:, 9:] = np.nan
    expected = np.zeros_like(height)
    for row in range(height.shape[0]):
        for col in range(height.shape[1]):
            window = height[max(row - 1, 0) : row + 2, max(col - 1, 0) : col + 2]
            if np.isfinite(window).any():
                expected[row, col] = np.nanmax(window) - np.nanmin(window)
    assert np.allclose(_valid_spread(height), expected)


@pytest.mark.parametrize("row", [0, 230])
def test_a_building_cut_by_the_frame_is_seeded_by_its_height(row):
    # a 26 x 60 px building against the top or the bottom of the image, on a 4 px census
    # grid whose first and last two rows the census window leaves without a disparity;
    # the searches that start from image segments are off: the height seeds alone
    reference, target, truth, _ = _stereo_scene(boxes=((row, 100, 26, 60),))
    params = ObjectsParams(method="height", census_side=64, find_missed=False, find_in_removed=False, find_clipped=False)
    found = height_objects(reference, target, params)
    assert found.height.factor == 4
    assert _best_iou(truth, found.reference, 1) > 0.8


def test_transfer_moves_each_object_by_its_disparity():
    labels = np.zeros((40, 60), np.int32)
    labels[5:15, 20:30] = 1
    labels[20:30, 40:55] = 2
    moved = transfer_to_target(labels, {1: 4.4, 2: 12.0})
    expected = np.zeros_like(labels)
    expected[5:15, 16:26] = 1  # round(4.4) = 4 px to the left
    expected[20:30, 28:43] = 2
    assert np.array_equal(moved, expected)


def test_transfer_lets_the_nearer_object_win_and_clips_at_the_border():
    labels = np.zeros((20, 40), np.int32)
    labels[5:10, 2:8] = 1
    labels[5:10, 12:18] = 2
    moved = transfer_to_target(labels, {1: 4.0, 2: 10.0})
    assert np.array_equal(np.flatnonzero(moved[6] == 1), np.arange(0, 2))  # 2:4 covered by 2
    assert np.array_equal(np.flatnonzero(moved[6] == 2), np.arange(2, 8))


def test_association_holds_by_construction_and_flags_contradicting_matches():
    labels = np.zeros((50, 80), np.int32)
    labels[5:20, 30:50] = 1
    labels[25:45, 30:50] = 2
    moved = transfer_to_target(labels, {1: 10.0, 2: 10.0})
    ref_xy = np.array([[35, 8], [40, 10], [45, 15], [35, 30], [40, 35], [45, 40]], np.float32)
    tgt_xy = ref_xy - np.array([[10, 0], [10, 0], [10.5, 0], [2, 0], [3, 0], [10, 0]], np.float32)
    matches = Matches(ref_xy, tgt_xy)
    association = associate_by_height(labels, moved, {1: 10.0, 2: 10.0}, matches, AssociationParams(min_matches=2))
    first, second = association.objects
    assert (first.ref_id, first.tgt_id, first.method, first.modal_disparity) == (1, 1, "height", 10.0)
    assert first.evidence == "agrees" and not first.flagged and first.n_invariant == 3
    assert second.evidence == "contradicts" and second.flagged and second.n_invariant == 1


def test_objects_without_disparity_stay_unassociated():
    labels = np.zeros((20, 20), np.int32)
    labels[2:6, 2:6] = 1
    labels[10:15, 10:15] = 2
    association = associate_by_height(labels, transfer_to_target(labels, {1: 1.0}), {1: 1.0}, Matches.empty())
    assert [o.ref_id for o in association.objects] == [1] and association.unassociated_ref == (2,)


def test_geojson_reads_back_as_the_labels(tmp_path):
    from rasterio.features import rasterize

    labels = np.zeros((30, 40), np.int32)
    labels[3:10, 5:20] = 1
    labels[15:28, 22:35] = 2
    labels[20:25, 26:31] = 0  # a courtyard
    path = write_geojson(tmp_path / "objects.geojson", labels, {1: {"modal_disparity": 3.5}})
    data = read_geojson(path)
    assert data["coordinates"] == "pixel" and [f["id"] for f in data["features"]] == [1, 2]
    assert data["features"][0]["properties"] == {"id": 1, "modal_disparity": 3.5}
    shapes = [(f["geometry"], f["id"]) for f in data["features"]]
    assert np.array_equal(rasterize(shapes, out_shape=labels.shape, dtype="int32"), labels)


def test_geojson_is_in_map_coordinates_when_georeferenced(tmp_path):
    labels = np.zeros((10, 10), np.int32)
    labels[2:4, 3:6] = 1
    raster = Raster(np.zeros((10, 10), np.uint8), gdal={"crs": None, "transform": (500000.0, 0.5, 0.0, 4000000.0, 0.0, -0.5)})
    data = read_geojson(write_geojson(tmp_path / "o.geojson", labels, raster=raster))
    ring = np.array(data["features"][0]["geometry"]["coordinates"][0])
    assert data["coordinates"] == "map"
    assert ring[:, 0].min() == 500000.0 + 3 * 0.5 and ring[:, 0].max() == 500000.0 + 6 * 0.5
    assert ring[:, 1].max() == 4000000.0 - 2 * 0.5 and ring[:, 1].min() == 4000000.0 - 4 * 0.5


def test_process_writes_the_objects_it_used(tmp_path):
    from demo_data_gen import generate
    from radcons.io import load_pair
    from radcons.pipeline import Pipeline
    from radcons.summary import write_outputs

    pair = generate(size=192, seed=1, scenario="none")
    params = Params.from_preset("radcons").with_stage("objects", method="height", use_supplied=False)
    run = Pipeline(params).run(pair, until="association")
    write_outputs(run, tmp_path / "out")
    written = load_pair(tmp_path / "out")
    assert np.array_equal(written.reference_objects, run.objects.reference)
    assert np.array_equal(written.target_objects, run.objects.target)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["objects"]["method"] == "height"
    polygons = read_geojson(tmp_path / "out" / summary["objects"]["polygons"]["reference"])
    ids = sorted(f["id"] for f in polygons["features"])
    assert ids == sorted(int(i) for i in np.unique(run.objects.reference) if i > 0)
    associated = {o.ref_id: o.modal_disparity for o in run.association.objects}
    for feature in polygons["features"]:
        if feature["id"] in associated:
            assert feature["properties"]["modal_disparity"] == pytest.approx(associated[feature["id"]])


def test_the_radcons_preset_finds_objects_from_height_and_the_paper_preset_from_the_image():
    assert Params.from_preset("radcons").objects.method == "height"
    assert Params.from_preset("paper").objects.method == "mbi"


@pytest.mark.parametrize(
    "change",
    [
        {"method": "lidar"},
        {"census_side": 8},
        {"min_valid_share": 1.5},
        {"min_area_m2": 100.0, "max_area_m2": 50.0},
        {"min_height_m": 0.0},
        {"census_cross_check": "both"},
        {"ground_window_m": float("nan")},
        {"min_object_height": 0.0},
        {"min_match_score": 3.0},
        {"tree_hull_rectangularity": 1.5},
        {"roof_rectangularity": 2.5},
        {"outline_edge": -0.5},
        {"spilled_roof_texture": -0.5},
    ],
)
def test_bad_height_params_are_refused(change):
    with pytest.raises(ParamsError):
        ObjectsParams(**change)


def test_a_green_box_is_a_tree_by_its_colour_and_the_pipeline_reads_the_colour(boxes_found):
    from radcons.errors import InputError
    from radcons.io import Pair
    from radcons.pipeline import Pipeline

    reference, target, truth, _ = _stereo_scene()
    found, _, _ = boxes_found
    greenness = np.full(truth.shape, -0.02, np.float32)  # grey roofs and ground
    greenness[truth == 2] = 0.15  # box 2 is a crown
    greenness[truth == 3] = np.nan  # box 3 has no colour there
    params = ObjectsParams(method="height", census_side=256)
    green = height_objects(reference, target, params, greenness=greenness)
    assert green.reference.max() == len(BOXES) - 1 and green.trees == found.trees + 1
    assert not green.reference[truth == 2].any()
    assert LEFT_OUT_RULES[7].endswith("(tree_greenness)")
    assert np.mean(green.left_out[truth == 2] == 7) > 0.9 and not green.left_out[truth == 1].any()
    assert set(green.modal_disparity) == set(range(1, len(BOXES)))
    for ident in (1, 3, 4):  # the others kept whole, with their D̄m
        mask = truth == ident
        assert _best_iou(truth, green.reference, ident) == pytest.approx(_best_iou(truth, found.reference, ident))
        assert green.modal_disparity[_majority(green.reference, mask)] == found.modal_disparity[_majority(found.reference, mask)]
    limit = height_objects(reference, target, replace(params, tree_greenness=0.2), greenness=greenness)
    assert limit.reference.max() == len(BOXES)  # a crown greener than the limit only
    with pytest.raises(InputError, match="greenness map's shape"):
        height_objects(reference, target, params, greenness=greenness[:-1])
    scale = lambda image: np.clip(image, 0, 255).astype(np.uint8)  # noqa: E731
    pair = Pair(Raster(scale(reference), greenness=greenness), Raster(scale(target)), name="boxes")
    run_params = Params.from_preset("radcons").with_stage("objects", method="height", census_side=256)
    run = Pipeline(run_params).run(pair, until="objects")
    assert not run.objects.reference[truth == 2].any() and run.objects.reference[truth == 1].any()


@pytest.mark.realdata
@pytest.mark.slow
def test_a_wooded_mountain_without_buildings_gives_no_objects(shared_data):
    # Mont Ventoux (Pleiades): the affine-rectified target covers a third of the frame,
    # the slopes are covered with trees and nothing is built there.
    from radcons.geometry import settle_geometry
    from radcons.io import load_pair_files
    from radcons.pipeline import Pipeline

    folder = shared_data / "pleiades_ventoux"
    pair = settle_geometry(load_pair_files(folder / "left_image.tif", folder / "right_image.tif"))
    run = Pipeline(Params.from_preset("radcons")).run(pair, until="objects")
    reference, target = run.images("original")
    overlap = np.isfinite(reference) & np.isfinite(target)
    assert overlap.mean() < 0.5  # the case: most of the frame is outside the overlap
    assert run.objects.method == "height", run.objects.note
    assert run.objects.height.valid_share > 0.8
    assert not run.objects.reference.any() and run.objects.trees > 0


def test_a_kept_matching_gives_the_objects_of_a_fresh_one_and_one_of_other_census_fields_is_not_used():
    from demo_data_gen import generate
    from radcons.stages.objects.matching import PairMatching, match_pair

    pair = generate(size=256, seed=1, scenario="mixed")
    reference, target = pair.reference.as_float32(), pair.target.as_float32()
    geometry = {"gsd_m": pair.metadata["gsd_m"], "base_to_height": pair.metadata["base_to_height"]}
    params = ObjectsParams(method="height", find_missed=False)
    kept = match_pair(reference, target, params, gsd_m=geometry["gsd_m"])
    assert kept.failure == "" and kept.key == PairMatching.key_of(reference.shape, params, geometry["gsd_m"])
    # other rules and a search whose segments were not computed with the matching
    tuned = replace(params, tree_texture=1.0, find_missed=True)
    with_kept = height_objects(reference, target, tuned, matching=kept, **geometry)
    fresh = height_objects(reference, target, tuned, **geometry)
    assert np.array_equal(with_kept.reference, fresh.reference) and with_kept.modal_disparity == fresh.modal_disparity
    # a matching of another census grid does not stand for this one's
    coarse = match_pair(reference, target, replace(params, census_cell_m=3.0), gsd_m=geometry["gsd_m"])
    assert coarse.factor != kept.factor
    with_coarse = height_objects(reference, target, tuned, matching=coarse, **geometry)
    assert np.array_equal(with_coarse.reference, fresh.reference) and with_coarse.height.factor == kept.factor


def test_a_pair_too_small_to_match_is_said_so_by_its_matching():
    from radcons.stages.objects.matching import match_pair

    image = np.random.default_rng(0).random((20, 40)).astype(np.float32)
    matching = match_pair(image, image)
    assert "too small" in matching.failure and matching.disparity is None
    found = height_objects(image, image, matching=matching)
    assert found.method == "mbi" and "too small" in found.note


def test_a_census_step_is_its_factor_in_disparity_pixels_of_height():
    from dataclasses import replace as with_fields

    from radcons.stages.objects.ground import HeightMap

    grid = np.zeros((4, 4), np.float32)
    heights = HeightMap(grid, grid, grid, "m", 1 / 6.99, 2, (-5.0, 6.0), 0.9)  # 7 m per full-image px
    assert heights.step == pytest.approx(2 * 6.99)  # the census at half resolution
    assert with_fields(heights, factor=1).step == pytest.approx(6.99)
