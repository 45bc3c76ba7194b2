"""Disparity review of every image stage in a recording, read back from the ``.rrd``."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rerun.chunk import RrdReader
from scipy import ndimage

from radcons.numerics.census import CensusParams
from radcons.evaluate.matching import MatcherParams
from radcons.io import Pair, Raster
from radcons.params import Params
from radcons.pipeline import IMAGE_STAGES, Run
from radcons.record import save_recording
from radcons.results import ObjectLabels, StageImages
from test_record import at_stage, component, entity_paths, image_of, rows

ROWS, COLS = 96, 160
SHIFT = 6
#: The stage whose target is unrelated noise: its matching must fail against the truth.
SCRAMBLED = "global"


def shifted_run(with_truth: bool = True) -> Run:
    """A run whose every stage but :data:`SCRAMBLED` is a textured pair moved by SHIFT px.

    ``reference(x, y) = target(x - SHIFT, y)``; the stages differ by gain and offset of
    the target (a radiometric difference), the scrambled stage by its whole content.
    """
    rng = np.random.default_rng(3)
    wide = ndimage.gaussian_filter(rng.normal(size=(ROWS, COLS + SHIFT)), 1.3)
    wide = 1000.0 + 400.0 * wide / np.abs(wide).max()
    reference = wide[:, :COLS].astype(np.float32)
    target = wide[:, SHIFT:].astype(np.float32)
    truth = np.full((ROWS, COLS), SHIFT, np.float32)
    truth[:, :SHIFT] = np.nan
    labels = np.zeros((ROWS, COLS), np.int32)
    labels[10:40, 30:80] = 1
    labels[50:90, 90:150] = 2
    pair = Pair(Raster(reference), Raster(target), disparity=truth if with_truth else None, name="shifted")
    results: dict = {"objects": ObjectLabels(labels, labels, "user")}
    for index, stage in enumerate(IMAGE_STAGES):
        moved = target * (1.0 + 0.02 * index) + 4.0 * index
        if stage == SCRAMBLED:
            moved = ndimage.gaussian_filter(rng.normal(size=(ROWS, COLS)), 1.3).astype(np.float32) * 400 + 1000
        results[stage] = StageImages(reference, moved.astype(np.float32), {})
    return Run(pair=pair, params=Params(), working_pair=pair, results=results, timings={}, cached={})


def scalars(path: Path, entity: str) -> dict[int, float]:
    out = {}
    for stage, row in at_stage(path, entity).items():
        out[stage] = float(component(row, ":scalars").as_py()[0])
    return out


def truth_rate(disparity: np.ndarray, truth: np.ndarray) -> float:
    known = np.isfinite(truth)
    return float((np.abs(disparity - truth)[known] < 1.0).sum() / known.sum())


@pytest.fixture(scope="module", params=["sgbm", "census"])
def recorded(request, tmp_path_factory) -> tuple[Path, Run]:
    run = shifted_run()
    matcher = MatcherParams() if request.param == "sgbm" else CensusParams()
    path = save_recording(run, tmp_path_factory.mktemp("rrd") / "stages.rrd", matcher=matcher)
    return path, run


def test_a_disparity_per_image_stage_against_the_known_shift(recorded):
    path, run = recorded
    maps = at_stage(path, "/disparity/stage/map")
    assert sorted(maps) == list(range(len(IMAGE_STAGES)))
    truth = run.pair.disparity
    for index, stage in enumerate(IMAGE_STAGES):
        disparity = image_of(maps[index])
        assert disparity.shape == (ROWS, COLS) and disparity.dtype == np.float32
        if stage == SCRAMBLED:
            assert truth_rate(disparity, truth) < 0.3
        else:
            assert truth_rate(disparity, truth) > 0.85, stage


def test_error_map_with_failures_marked_and_rates_per_stage(recorded):
    path, run = recorded
    truth = run.pair.disparity
    maps = at_stage(path, "/disparity/stage/map")
    errors = at_stage(path, "/disparity/stage/error")
    statuses = at_stage(path, "/disparity/stage/error/status")
    rates = scalars(path, "/metrics/stage/rate_all")
    assert sorted(errors) == sorted(rates) == list(range(len(IMAGE_STAGES)))
    for index in range(len(IMAGE_STAGES)):
        disparity = image_of(maps[index])
        error = image_of(errors[index])
        known = np.isfinite(truth) & np.isfinite(disparity)
        np.testing.assert_allclose(error[known], np.abs(disparity[known] - SHIFT), atol=1e-5)
        status = image_of(statuses[index])
        assert (status[np.isnan(disparity) & np.isfinite(truth)] == 2).all()  # failed match
        assert (status[np.isnan(truth)] == 1).all()  # no ground truth
        assert (status[known] == 0).all()
        assert rates[index] == pytest.approx(truth_rate(disparity, truth), abs=1e-6)
    assert rates[IMAGE_STAGES.index(SCRAMBLED)] < 0.3 < 0.85 < rates[0]
    assert sorted(scalars(path, "/metrics/stage/rate_objects")) == list(range(len(IMAGE_STAGES)))


def test_blueprint_shows_the_stage_disparity_beside_the_images(recorded):
    path, _ = recorded
    reader = RrdReader(path)
    (blueprint,) = reader.blueprints()
    origins = set()
    for chunk in reader.stream(store=blueprint):
        batch = chunk.to_record_batch()
        if "ViewBlueprint:space_origin" in batch.schema.names:
            origins.update(o[0] for o in batch.column("ViewBlueprint:space_origin").to_pylist() if o)
    assert {"pair/reference", "pair/target", "disparity/stage/map", "disparity/stage/error", "metrics/stage"} <= origins


def test_without_truth_the_range_comes_from_sift_matches_and_no_error_is_logged(tmp_path):
    run = shifted_run(with_truth=False)
    path = save_recording(run, tmp_path / "no_truth.rrd", matcher=MatcherParams())
    maps = at_stage(path, "/disparity/stage/map")
    assert sorted(maps) == list(range(len(IMAGE_STAGES)))
    truth = np.full((ROWS, COLS), SHIFT, np.float32)
    truth[:, :SHIFT] = np.nan
    assert truth_rate(image_of(maps[0]), truth) > 0.85  # the range found covers the shift
    paths = entity_paths(path)
    assert "/disparity/stage/error" not in paths and not any(p.startswith("/metrics/stage") for p in paths)


def test_without_truth_or_matches_a_note_says_why(tmp_path):
    run = shifted_run(with_truth=False)
    flat = np.full((ROWS, COLS), 7.0, np.float32)
    for stage in IMAGE_STAGES:
        run.results[stage] = StageImages(flat, flat, {})
    path = save_recording(run, tmp_path / "flat.rrd", matcher=MatcherParams())
    assert "/disparity/stage/map" not in entity_paths(path)
    (row,) = rows(path, "/disparity/stage/note")
    assert "no stage disparity" in component(row, ":text").as_py()[0]


def test_process_recording_holds_each_stage_disparity_and_error(tmp_path):
    radcons = [sys.executable, "-m", "radcons.cli"]
    subprocess.run([*radcons, "demo", tmp_path / "d", "--size", "128", "--seed", "2"], check=True, capture_output=True)
    params = tmp_path / "fast.toml"
    params.write_text("[smoothness]\niterations = 1\n")
    result = subprocess.run(
        [*radcons, "process", tmp_path / "d", "--out", tmp_path / "o", "--params", params,
         "--rrd", tmp_path / "p.rrd", "--matcher", "census", "--quiet"],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    stages = list(range(len(IMAGE_STAGES)))
    assert sorted(at_stage(tmp_path / "p.rrd", "/disparity/stage/map")) == stages
    assert sorted(at_stage(tmp_path / "p.rrd", "/disparity/stage/error")) == stages
    rates = scalars(tmp_path / "p.rrd", "/metrics/stage/rate_all")
    assert min(rates.values()) > 0.3  # census on a demo pair matches most pixels at every stage
    (summary,) = rows(tmp_path / "p.rrd", "/summary")
    assert "Dense matching of each stage (census)" in component(summary, ":text").as_py()[0]
