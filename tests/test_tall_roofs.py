"""A textured, nearly rectangular object taller than a city's trees is a roof (``[objects] tall_roof_height_m``)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from radcons.errors import ParamsError
from radcons.stages.objects.features import object_features
from radcons.stages.objects.ground import HeightMap
from radcons.stages.objects.rules import (
    TALL_ROOF_HULL_RECTANGULARITY,
    TALL_ROOF_RECTANGULARITY,
    is_tall_roof,
    is_tree,
)
from radcons.stages.objects.run import ObjectsParams


def _heights(shape: tuple[int, int], metres: float) -> HeightMap:
    """Every pixel ``metres`` above a ground at disparity 0, one metre a disparity pixel."""
    zero = np.zeros(shape, np.float32)
    return HeightMap(zero + metres, zero, zero + metres, "m", 1.0, 1, (0.0, 2.0 * metres), 1.0)


def _scene() -> tuple[np.ndarray, np.ndarray]:
    """The roof of an apartment block with its tanks and heaters, and a grove of textured crowns.

    The roof is a rectangle with a corner cut off (it fills about 0.83 of its
    rectangle), covered with small square boxes of random grey: as textured as the
    crowns, with square edges. The crowns are discs of grey noise.
    """
    rng = np.random.default_rng(7)
    labels = np.zeros((260, 260), np.int32)
    labels[20:100, 20:120] = 1
    labels[20:55, 20:60] = 0  # the corner the snapping cut off
    for row, col in ((180, 60), (185, 100), (215, 80)):
        cv2.circle(labels, (col, row), 22, 2, -1)
    reference = (90.0 + 2.0 * rng.standard_normal(labels.shape)).astype(np.float32)  # smooth ground
    roof = labels == 1
    reference[roof] = 170.0
    for _ in range(60):  # tanks and solar heaters: squares of 4-9 px
        row, col, side = int(rng.integers(20, 95)), int(rng.integers(20, 115)), int(rng.integers(4, 10))
        box = np.zeros(labels.shape, bool)
        box[row : row + side, col : col + side] = True
        reference[box & roof] = float(rng.uniform(60.0, 250.0))
    crowns = labels == 2
    reference[crowns] = 120.0 + 45.0 * rng.standard_normal(int(crowns.sum()))
    return reference, labels


def test_a_textured_apartment_roof_is_a_tree_by_texture_but_a_roof_by_its_height():
    reference, labels = _scene()
    rules = ObjectsParams()
    tall = object_features(reference, labels, _heights(labels.shape, 25.0), sigma=1.0)
    roof, grove = tall[1], tall[2]
    assert roof["texture"] > rules.tree_texture and grove["texture"] > rules.tree_texture, (roof, grove)
    assert TALL_ROOF_RECTANGULARITY <= roof["rectangularity"] < rules.roof_rectangularity, roof
    assert roof["hull_rectangularity"] >= TALL_ROOF_HULL_RECTANGULARITY, roof
    assert roof["alignment"] >= rules.tree_alignment, roof
    assert is_tree(roof, rules)  # by texture alone, as before the rule ...
    assert is_tall_roof(roof, rules) and not is_tree(roof, rules, metric=True)  # ... not where heights are metric
    assert grove["hull_rectangularity"] < TALL_ROOF_HULL_RECTANGULARITY, grove  # round crowns
    assert not is_tall_roof(grove, rules) and is_tree(grove, rules, metric=True)
    low = object_features(reference, labels, _heights(labels.shape, 12.0), sigma=1.0)[1]
    assert not is_tall_roof(low, rules) and is_tree(low, rules, metric=True)  # as high as a tree: the texture decides
    assert not is_tall_roof(roof, ObjectsParams(tall_roof_height_m=0.0))  # off


def test_a_tall_rectangular_object_whose_edges_turn_every_way_stays_a_tree():
    reference, labels = _scene()
    rules = ObjectsParams()
    roof = object_features(reference, labels, _heights(labels.shape, 25.0), sigma=1.0)[1]
    crowns = {**roof, "alignment": 0.5 * rules.tree_alignment}  # the same shape, edges every way
    assert not is_tall_roof(crowns, rules) and is_tree(crowns, rules, metric=True)


@pytest.mark.parametrize("value", [-1.0, 1001.0, float("nan")])
def test_a_tall_roof_height_out_of_range_is_refused(value):
    with pytest.raises(ParamsError, match="tall_roof_height_m"):
        ObjectsParams(method="height", tall_roof_height_m=value)


@pytest.mark.realdata
@pytest.mark.slow
def test_apartment_blocks_of_kahramanmaras_are_objects(shared_data):
    # Pleiades, Kahramanmaras, two dates before the earthquake (RPC-rectified, heights in
    # metres): a block 28 m high whose roof carries water tanks and solar heaters
    # (texture 1.4 times the image's median gradient, rectangularity 0.86, alignment 0.44).
    from dataclasses import replace

    from radcons.geometry import settle_geometry
    from radcons.io import load_pair_files
    from radcons.params import Params
    from radcons.pipeline import Pipeline

    folder = shared_data / "pleiades_kahramanmaras_prepost"
    pair = settle_geometry(
        load_pair_files(next(folder.glob("pre_event_img1*.tif")), next(folder.glob("pre_event_img2*.tif")))
    )
    preset = Params.from_preset("radcons")
    params = replace(preset, objects=replace(preset.objects, use_supplied=False))
    objects = Pipeline(params).run(pair, until="objects").objects
    assert objects.height.unit == "m"
    block = objects.reference[275:292, 685:702]
    assert (block > 0).mean() > 0.9
