"""The objects' ground choice: the windows' ground (default) or CNES Bulldozer's drape cloth."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from radcons.errors import ParamsError
from radcons.stages.objects.ground import drape_ground
from radcons.stages.objects.params import ObjectsParams
from radcons.stages.objects.run import height_objects
from test_objects_height import BOX_RISE, BOXES, _best_iou, _stereo_scene


def _plane_with_boxes(size: int = 200) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A sloped ground plane (disparity px), the same plus four boxes 8 px high, and the boxes' mask.

    The boxes stand 40 px or more from the plane's high edges, where Bulldozer's cloth
    sags below a slope (by up to 2.5 px here).
    """
    rows, cols = np.mgrid[0:size, 0:size].astype(np.float32)
    plane = 5.0 + 0.04 * cols + 0.02 * rows
    boxes = np.zeros((size, size), bool)
    for r, c, h, w in ((30, 40, 20, 30), (110, 30, 25, 25), (60, 120, 30, 20), (125, 110, 20, 28)):
        boxes[r : r + h, c : c + w] = True
    return plane, np.where(boxes, plane + 8.0, plane).astype(np.float32), boxes


def test_the_default_ground_is_the_windows():
    assert ObjectsParams().ground == "windows"


def test_an_unknown_ground_is_refused_in_one_line():
    with pytest.raises(ParamsError) as raised:
        ObjectsParams(ground="cloth")
    assert str(raised.value) == "[objects] ground must be one of windows, bulldozer, got 'cloth'"


def test_bulldozer_not_installed_is_said_in_one_line(monkeypatch):
    monkeypatch.setitem(sys.modules, "bulldozer", None)  # import bulldozer now raises ImportError
    with pytest.raises(ParamsError) as raised:
        drape_ground(np.zeros((32, 32), np.float32), 1.0, 1.0, 30.0)
    message = str(raised.value)
    assert "\n" not in message and "bulldozer-dtm" in message and "radcons[bulldozer]" in message


def test_bulldozer_ground_under_boxes_is_the_plane():
    pytest.importorskip("bulldozer")
    plane, disparity, boxes = _plane_with_boxes()
    disparity[:4] = np.nan  # an invalid strip at the border takes the nearest ground
    ground = drape_ground(disparity, 1.0, 1.0, 30.0)
    assert ground.shape == disparity.shape and ground.dtype == np.float32
    assert np.isfinite(ground).all()
    error = np.abs(ground - plane)
    assert error[boxes].max() < 0.5
    assert np.median(error[~boxes]) < 0.2
    assert error.max() < 3.0  # the sag at the high edges, far from the boxes' 8 px


def test_bulldozer_ground_is_in_disparity_px_whatever_the_scale():
    pytest.importorskip("bulldozer")
    plane, disparity, boxes = _plane_with_boxes()
    ground = drape_ground(disparity, 1.0, 4.0, 30.0)  # 4 disparity px a metre: the surface 4 times lower
    error = np.abs(ground - plane)
    assert error[boxes].max() < 1.0  # a ground left in metres would be 4-12 px off
    assert np.median(error[~boxes]) < 0.25


def test_bulldozer_ground_without_a_valid_pixel_is_nan():
    pytest.importorskip("bulldozer")
    ground = drape_ground(np.full((16, 16), np.nan, np.float32), 1.0, 1.0, 30.0)
    assert np.isnan(ground).all()


def test_boxes_on_sloped_ground_are_found_over_bulldozer_ground():
    pytest.importorskip("bulldozer")
    reference, target, truth, disparity = _stereo_scene()
    found = height_objects(reference, target, ObjectsParams(method="height", census_side=256, ground="bulldozer"))
    ious = [_best_iou(truth, found.reference, i) for i in range(1, len(BOXES) + 1)]
    assert min(ious) > 0.75, ious
    assert found.reference.max() == len(BOXES)  # nothing on the sloped ground
    full = found.height.full(truth.shape, "ground")
    on_ground = (truth == 0) & np.isfinite(full)
    assert np.median(np.abs(full - disparity)[on_ground]) < 1.0
    inner = found.height.full(truth.shape)[truth > 0]
    assert abs(float(np.nanmedian(inner)) - BOX_RISE) < 1.5
