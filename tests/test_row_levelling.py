"""Levelling the rows of a pair delivered as rectified: the target's vertical offset taken out."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest
import scipy.ndimage

from demo_data_gen import generate
from radcons.geometry import level_rows
from radcons.io import Raster, save_pair
from radcons.stages.rectify.row_levelling import (
    ROW_TOLERANCE_PX,
    level_target,
    measure_row_offset,
    vertical_offset_plane,
)

#: The vertical offset ``dy = y_ref - y_tgt = a x + b y + c`` put into the target below.
PLANE = (0.0015, -0.001, 1.8)


@pytest.fixture(scope="module")
def demo():
    return generate(size=384, seed=3, scenario="none")


def _offset(image: np.ndarray, plane: tuple[float, float, float], order: int = 3) -> np.ndarray:
    """``image`` moved up by the plane: ``out(x, y) = image(x, y + dy(x, y))`` (scipy, not OpenCV)."""
    rows, cols = np.mgrid[0 : image.shape[0], 0 : image.shape[1]].astype(np.float64)
    dy = plane[0] * cols + plane[1] * rows + plane[2]
    return scipy.ndimage.map_coordinates(image.astype(np.float64), [rows + dy, cols], order=order, mode="nearest")


@pytest.fixture(scope="module")
def offset_pair(demo):
    """The demo pair whose target (and its labels) the plane moved up."""
    dtype = demo.target.data.dtype
    target = np.clip(np.rint(_offset(demo.target.data, PLANE)), 0, np.iinfo(dtype).max).astype(dtype)
    labels = _offset(demo.target_objects, PLANE, order=0).astype(demo.target_objects.dtype)
    return replace(demo, target=Raster(target), target_objects=labels)


def test_the_plane_is_fitted_by_least_squares_on_the_inliers():
    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 1000, (300, 2))
    dy = 0.002 * xy[:, 0] - 0.001 * xy[:, 1] + 2.0 + rng.normal(0, 0.2, 300)
    dy[:40] += rng.uniform(5, 30, 40)  # false matches
    plane, inliers = vertical_offset_plane(xy, dy, float(np.median(dy)), 1.0)
    assert not inliers[:40].any() and inliers[40:].mean() > 0.99
    design = np.column_stack([xy[inliers], np.ones(inliers.sum())])
    direct = np.linalg.solve(design.T @ design, design.T @ dy[inliers])  # the normal equations
    np.testing.assert_allclose(plane, direct, rtol=1e-8, atol=1e-10)


def test_the_offset_put_into_the_target_is_measured(offset_pair):
    found = measure_row_offset(offset_pair.reference.as_float32(), offset_pair.target.as_float32())
    assert found.applied and found.inliers >= 50
    rows, cols = offset_pair.shape
    for x, y in [(0, 0), (cols - 1, 0), (0, rows - 1), (cols - 1, rows - 1), (cols / 2, rows / 2)]:
        truth = PLANE[0] * x + PLANE[1] * y + PLANE[2]
        assert abs(found.plane[0] * x + found.plane[1] * y + found.plane[2] - truth) < 0.15
    assert found.after < 0.3 < 1.5 < found.before


def test_levelling_gives_back_the_target_and_its_labels(demo, offset_pair):
    levelled = level_rows(offset_pair)
    assert levelled.metadata["rows"].startswith("target rows levelled")
    assert levelled.target.data.dtype == demo.target.data.dtype and levelled.target.greenness is None
    inner = (slice(8, -8), slice(8, -8))
    truth = demo.target.data[inner].astype(float)
    before = np.abs(offset_pair.target.data[inner] - truth).mean()
    after = np.abs(levelled.target.data[inner].astype(float) - truth).mean()
    assert after < 0.35 * before
    agree = levelled.target_objects[inner] == demo.target_objects[inner]
    assert agree.mean() > 0.99 > (offset_pair.target_objects[inner] == demo.target_objects[inner]).mean()
    assert levelled.reference is offset_pair.reference and levelled.disparity is offset_pair.disparity


def test_an_exact_pair_is_left_as_it_is(demo):
    same = level_rows(demo)
    assert same.target is demo.target and same.target_objects is demo.target_objects
    assert same.metadata["rows"].startswith("rows not levelled") and f"within {ROW_TOLERANCE_PX:g} px" in same.metadata["rows"]


def test_a_featureless_pair_is_left_with_a_note():
    flat = np.full((128, 128), 900, np.uint16)
    pair = replace(generate(size=128, seed=0, scenario="none"), target=Raster(flat), target_objects=None)
    same = level_rows(pair)
    assert same.target is pair.target and "no SIFT match" in same.metadata["rows"]


def test_invalid_pixels_stay_invalid_and_the_rest_is_not_lost(offset_pair):
    data = offset_pair.target.data.astype(np.float32)
    data[100:140, 200:260] = np.nan
    levelled = level_target(data, PLANE, np.isfinite(data))
    hole = np.isnan(levelled)
    assert hole[104:136, 204:256].all()  # the hole, moved by about 2 px, keeps its core
    assert hole.sum() < np.isnan(data).sum() + 16 * 384  # a cubic footprint around it, and the edges
    assert not hole[200:300, 4:-4].any()


def test_process_levels_a_pair_and_keep_rows_leaves_it(tmp_path, offset_pair):
    folder = save_pair(replace(offset_pair, disparity=None, change_mask=None), tmp_path / "pair").parent
    for extra, expected in [((), "target rows levelled"), (("--keep-rows",), "not checked")]:
        out = tmp_path / f"out{len(extra)}"
        result = subprocess.run(
            [sys.executable, "-m", "radcons.cli", "process", folder, "--out", out, "--until", "global", "--quiet", *extra],
            capture_output=True, text=True, timeout=600,
        )
        assert result.returncode == 0, result.stderr
        assert json.loads((out / "summary.json").read_text())["rows"].startswith(expected)


def test_a_scene_target_is_levelled_window_by_window_as_in_memory(tmp_path, offset_pair):
    """Scene mode reads the same levelled target, window by window, as the in-memory route."""
    from radcons.scene import open_scene_pair
    from radcons.scene.levelling import LevelledImage, level_scene_rows

    folder = save_pair(replace(offset_pair, disparity=None, change_mask=None), tmp_path / "pair").parent
    scene = level_scene_rows(open_scene_pair([folder]))
    memory = level_rows(offset_pair)
    assert isinstance(scene.target, LevelledImage) and scene.metadata["rows"].startswith("target rows levelled")
    assert np.allclose(scene.target.plane, measure_row_offset(
        offset_pair.reference.as_float32(), offset_pair.target.as_float32()).plane, atol=0.2)
    for window in [(0, 128, 0, 384), (100, 260, 50, 300), (256, 384, 128, 384)]:
        r0, r1, c0, c1 = window
        read = scene.target.read(window).astype(float)
        whole = memory.target.data[r0:r1, c0:c1].astype(float)
        raw = offset_pair.target.data[r0:r1, c0:c1].astype(float)
        assert read.shape == whole.shape and np.abs(read - whole).mean() < 0.05 * np.abs(raw - whole).mean()
        labels = scene.target_objects.read(window)
        assert np.mean(labels == memory.target_objects[r0:r1, c0:c1]) > 0.98


def test_process_in_scene_mode_levels_the_rows(tmp_path, offset_pair):
    folder = save_pair(replace(offset_pair, disparity=None, change_mask=None), tmp_path / "pair").parent
    for extra, expected in [((), "target rows levelled"), (("--keep-rows",), "not checked")]:
        out = tmp_path / f"out{len(extra)}"
        result = subprocess.run(
            [sys.executable, "-m", "radcons.cli", "process", folder, "--out", out, "--tiles", "128",
             "--until", "global", "--quiet", *extra],
            capture_output=True, text=True, timeout=600,
        )
        assert result.returncode == 0, result.stderr
        assert json.loads((out / "summary.json").read_text())["rows"].startswith(expected)


def test_the_inspectors_scene_previews_and_regions_show_the_levelled_target(tmp_path, offset_pair):
    """A scene-sized pair is tuned in the inspector on the target the whole-scene run levels."""
    from inspector.scene_preview import read_preview, read_region, scene_source

    folder = save_pair(replace(offset_pair, disparity=None, change_mask=None), tmp_path / "pair").parent
    source = scene_source([folder], 1000)
    memory = level_rows(offset_pair)
    box = (40, 60, 256, 200)
    region = read_region(source, box)
    x, y, width, height = box
    whole = memory.target.data[y : y + height, x : x + width].astype(float)
    raw = offset_pair.target.data[y : y + height, x : x + width].astype(float)
    read = region.target.data.astype(float)
    assert np.abs(read - whole).mean() < 0.05 * np.abs(raw - whole).mean()
    assert np.mean(region.target_objects == memory.target_objects[y : y + height, x : x + width]) > 0.98
    assert region.metadata["rows"].startswith("target rows levelled")
    preview, factor = read_preview(source, 192)
    assert factor == 2 and preview.metadata["rows"] == region.metadata["rows"]
    halved = [image.reshape(192, 2, 192, 2).astype(float).mean(axis=(1, 3)) for image in (memory.target.data, offset_pair.target.data)]
    inner = (slice(4, -4), slice(4, -4))
    levelled_error, raw_error = (np.abs(preview.target.data[inner] - image[inner]).mean() for image in halved)
    assert levelled_error < 0.5 * raw_error
    assert source.levelled is source.levelled  # measured once per source


@pytest.mark.parametrize("shifted", [True, False], ids=["levelled", "within-tolerance"])
def test_the_inspectors_full_resolution_run_takes_the_rows_its_previews_measured(tmp_path, monkeypatch, demo, offset_pair, shifted):
    """"Apply to full resolution" runs on the source's levelled pair: the offset is not measured again."""
    import radcons.scene.run
    from inspector.scene_job import SceneJob
    from inspector.scene_preview import scene_source
    from radcons.params import Params
    from radcons.scene import SceneOptions

    pair = offset_pair if shifted else demo
    folder = save_pair(replace(pair, disparity=None, change_mask=None), tmp_path / "pair").parent
    source = scene_source([folder], 1000)
    measured = source.levelled.metadata["rows"]
    assert measured.startswith("target rows levelled") if shifted else measured.startswith("rows not levelled") and "within" in measured

    def measure_again(_pair):
        raise AssertionError("the rows were measured again")

    monkeypatch.setattr(radcons.scene.run, "level_scene_rows", measure_again)
    job = SceneJob(lambda state: None)
    options = SceneOptions(tile=128, workers=1, processes=False)
    assert job.start(source.levelled, tmp_path / "out", Params.from_preset("radcons"), options, dict(source.reading))
    assert job.wait(300)
    assert job.state.phase == "done", job.state.message
    assert job.state.summary["rows"] == measured
    written = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert written["rows"] == measured
