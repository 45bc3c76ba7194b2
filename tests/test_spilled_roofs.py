"""A ragged object that is smooth and square is roofs, not a tree (``[objects] spilled_roof_texture``)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from radcons.errors import ParamsError
from radcons.stages.objects.features import object_features
from radcons.stages.objects.ground import HeightMap
from radcons.stages.objects.rules import (
    SPILLED_ROOF_ALIGNMENT,
    SPILLED_ROOF_HULL_RECTANGULARITY,
    SPILLED_ROOF_RECTANGULARITY,
    is_spilled_roof,
    is_tree,
)
from radcons.stages.objects.run import ObjectsParams


def _flat_heights(shape: tuple[int, int]) -> HeightMap:
    """Every pixel 8 m above a ground at disparity 0 (the features' height entries unused here)."""
    zero = np.zeros(shape, np.float32)
    return HeightMap(zero + 8.0, zero, zero + 8.0, "m", 1.0, 1, (0.0, 16.0), 1.0)


def _scene() -> tuple[np.ndarray, np.ndarray]:
    """Two row houses set back from each other as one region, a grove of smooth crowns, and a thin L.

    The houses and the crowns are smooth (grey noise of 1) on a textured ground (noise of
    12), so that their ``texture`` is low; the L is as smooth and as square, but fills
    little of its rectangle.
    """
    labels = np.zeros((240, 240), np.int32)
    labels[20:60, 20:50] = 1  # the first house ...
    labels[55:95, 48:78] = 1  # ... and the next one, set back by 35 px: a staircase
    for row, col in ((150, 40), (150, 75), (185, 57)):  # three crowns
        cv2.circle(labels, (col, row), 17, 2, -1)
    labels[120:200, 120:130] = 3  # a thin L, 10 px wide with arms of 80 px (two walls)
    labels[190:200, 120:200] = 3
    rng = np.random.default_rng(3)
    reference = (80.0 + 12.0 * rng.standard_normal(labels.shape)).astype(np.float32)
    inside = labels > 0
    reference[inside] = 200.0 + rng.standard_normal(int(inside.sum()))
    return reference, labels


def test_smooth_square_row_houses_are_roofs_and_smooth_crowns_stay_trees():
    reference, labels = _scene()
    features = object_features(reference, labels, _flat_heights(labels.shape), sigma=1.0)
    houses, grove, walls = features[1], features[2], features[3]
    rules = ObjectsParams()
    for feature in (houses, grove, walls):  # all three are ragged with a round hull, and smooth
        assert feature["rectangularity"] < rules.tree_rectangularity, feature
        assert feature["hull_rectangularity"] < rules.tree_hull_rectangularity, feature
        assert feature["texture"] <= rules.spilled_roof_texture, feature
    assert houses["alignment"] >= SPILLED_ROOF_ALIGNMENT and houses["rectangularity"] >= SPILLED_ROOF_RECTANGULARITY
    assert grove["alignment"] < SPILLED_ROOF_ALIGNMENT  # the crowns' edges turn every way
    assert walls["alignment"] >= SPILLED_ROOF_ALIGNMENT and walls["rectangularity"] < SPILLED_ROOF_RECTANGULARITY
    assert is_spilled_roof(houses, rules) and not is_tree(houses, rules)
    assert not is_spilled_roof(grove, rules) and is_tree(grove, rules)
    assert not is_spilled_roof(walls, rules) and is_tree(walls, rules)
    off = ObjectsParams(spilled_roof_texture=0.0)
    assert is_tree(houses, off)  # the rule off: ragged is a tree, as before


def test_a_textured_ragged_object_stays_a_tree_however_square():
    reference, labels = _scene()
    rng = np.random.default_rng(4)
    houses = labels == 1
    reference[houses] = 200.0 + 40.0 * rng.standard_normal(int(houses.sum()))  # leaves, not a roof
    feature = object_features(reference, labels, _flat_heights(labels.shape), sigma=1.0)[1]
    assert feature["texture"] > ObjectsParams().spilled_roof_texture
    assert is_tree(feature, ObjectsParams())


def test_a_smooth_square_ring_around_a_courtyard_is_roofs_and_a_thin_l_stays_a_tree():
    # A roof around a courtyard, open on one side (a C, 10 px wide): it fills a third of its
    # rectangle, far less than the row houses, but its convex hull nearly all of it.
    reference, labels = _scene()
    labels[labels == 1] = 0
    ring = np.zeros(labels.shape, bool)
    ring[10:100, 10:100] = True
    ring[20:90, 20:90] = False
    ring[45:65, 90:100] = False  # the opening
    labels[ring] = 1
    reference[ring] = 200.0 + np.random.default_rng(5).standard_normal(int(ring.sum()))
    features = object_features(reference, labels, _flat_heights(labels.shape), sigma=1.0)
    ring_feature, walls = features[1], features[3]
    rules = ObjectsParams()
    assert ring_feature["rectangularity"] < SPILLED_ROOF_RECTANGULARITY, ring_feature
    assert ring_feature["hull_rectangularity"] >= SPILLED_ROOF_HULL_RECTANGULARITY, ring_feature
    assert ring_feature["texture"] <= rules.spilled_roof_texture
    assert ring_feature["alignment"] >= SPILLED_ROOF_ALIGNMENT
    assert is_spilled_roof(ring_feature, rules) and not is_tree(ring_feature, rules)
    assert walls["hull_rectangularity"] < SPILLED_ROOF_HULL_RECTANGULARITY, walls  # two walls: a thin L
    assert is_tree(walls, rules)


@pytest.mark.realdata
@pytest.mark.slow
def test_a_hipped_roof_around_a_courtyard_on_us3d_is_an_object(shared_data):
    # US3D JAX_072: a hipped roof around a courtyard, 10 m high, split at its corners into
    # two L-shaped pairs of planes (rectangularity 0.31-0.37, hulls 0.83-0.84).
    from dataclasses import replace

    from radcons.geometry import settle_geometry
    from radcons.io import load_pair_files
    from radcons.params import Params
    from radcons.pipeline import Pipeline

    folder = shared_data / "us3d_jacksonville_multidate"
    pair = settle_geometry(
        load_pair_files(folder / "JAX_072_011_022_LEFT_RGB.tif", folder / "JAX_072_011_022_RIGHT_RGB.tif", rectified=True)
    )
    preset = Params.from_preset("radcons")
    params = replace(preset, objects=replace(preset.objects, use_supplied=False))
    labels = Pipeline(params).run(pair, until="objects").objects.reference
    top_plane, left_plane = labels[555:568, 645:690], labels[568:585, 612:648]
    assert (top_plane > 0).mean() > 0.9 and (left_plane > 0).mean() > 0.9
    courtyard = labels[585:615, 665:690]  # the courtyard's floor, on the ground
    assert (courtyard > 0).mean() < 0.2


@pytest.mark.parametrize("value", [-0.1, 2.5, float("nan")])
def test_a_spilled_roof_texture_out_of_range_is_refused(value):
    with pytest.raises(ParamsError, match="spilled_roof_texture"):
        ObjectsParams(method="height", spilled_roof_texture=value)
