"""The radcons command line, run as a real subprocess."""

from __future__ import annotations

import json
import subprocess
import tomllib
import sys
from pathlib import Path

import numpy as np
import pytest
import tomli_w

from radcons.io import Pair, Raster, load_pair, save_pair, write_raster

GEOREF = {33550: (12, 3, (0.5, 0.5, 0.0)), 33922: (12, 6, (0.0, 0.0, 0.0, 3.5e5, 5.4e6, 0.0))}


def radcons(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "radcons.cli", *map(str, args)],
        capture_output=True, text=True, cwd=cwd, timeout=600,
    )


@pytest.mark.parametrize("command", ["demo", "process", "evaluate", "inspect", "view", "params"])
def test_every_subcommand_has_help(command):
    result = radcons(command, "--help")
    assert result.returncode == 0 and "usage: radcons " + command in result.stdout


def _sizes(d: Path) -> tuple[Path, Path]:
    return (write_raster(d / "a.png", np.arange(100, dtype=np.uint8).reshape(10, 10)),
            write_raster(d / "b.png", np.arange(110, dtype=np.uint8).reshape(10, 11)))


def _garbage(d: Path) -> tuple[Path, Path]:
    (d / "a.tif").write_bytes(b"II*\x00garbage")
    return d / "a.tif", write_raster(d / "b.png", np.arange(100, dtype=np.uint8).reshape(10, 10))


def _all_nan(d: Path) -> tuple[Path, Path]:
    return (write_raster(d / "a.tif", np.full((9, 9), np.nan, np.float32)),
            write_raster(d / "b.tif", np.arange(81, dtype=np.float32).reshape(9, 9)))


@pytest.mark.parametrize(
    "make, message",
    [(_sizes, "b.png: reference is (10, 10) but target is (10, 11)"), (_garbage, "a.tif: unreadable"), (_all_nan, "a.tif: every pixel is NaN")],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, make, message):
    a, b = make(tmp_path)
    forced = ["--rectified"] if make is _sizes else []  # unforced, different sizes mean an unrectified pair
    result = radcons("process", a, b, "--out", tmp_path / "out", *forced)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("radcons: error: ") and message in lines[0]
    assert not (tmp_path / "out").exists()


def test_missing_pair_folder(tmp_path):
    result = radcons("process", tmp_path / "nowhere", "--out", tmp_path / "out")
    assert result.returncode == 2 and "nowhere" in result.stderr and "Traceback" not in result.stderr


def test_demo_then_process_keeps_dtype_georef_and_ground_truth(tmp_path):
    result = radcons("demo", tmp_path / "demo", "--size", "128", "--seed", "2", "--scenario", "mixed")
    assert result.returncode == 0, result.stderr
    demo = load_pair(tmp_path / "demo")
    assert demo.disparity is not None and demo.reference_objects is not None
    # give the demo pair georeferencing, as a GeoTIFF pair would carry
    geo = Pair(
        Raster(demo.reference.data, GEOREF), Raster(demo.target.data, GEOREF),
        disparity=demo.disparity, reference_objects=demo.reference_objects,
        target_objects=demo.target_objects, change_mask=demo.change_mask, name="geo",
    )
    save_pair(geo, tmp_path / "geo")
    params = tmp_path / "fast.toml"
    assert radcons("params", params).returncode == 0
    table = tomllib.loads(params.read_text())
    table["smoothness"]["iterations"] = 1
    params.write_text(tomli_w.dumps(table))
    result = radcons("process", tmp_path / "geo", "--out", tmp_path / "out", "--params", params, "--quiet")
    assert result.returncode == 0, result.stderr
    out = load_pair(tmp_path / "out")
    assert out.reference.data.dtype == demo.reference.data.dtype
    assert out.target.data.dtype == demo.target.data.dtype
    assert {c: v for c, (_, _, v) in out.target.georef.items()} == {c: v for c, (_, _, v) in GEOREF.items()}
    np.testing.assert_array_equal(out.disparity, demo.disparity)
    np.testing.assert_array_equal(out.reference_objects, demo.reference_objects)
    assert not np.array_equal(out.target.data, demo.target.data)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["stages"][-1] == "smoothness" and summary["associations"]
    from radcons.params import STAGES

    assert set(summary["timings_s"]) == set(STAGES)
    assert summary["params"]["smoothness"]["iterations"] == 1


def test_process_until_and_two_files(tmp_path):
    assert radcons("demo", tmp_path / "d", "--size", "128", "--scenario", "multi-temporal").returncode == 0
    result = radcons(
        "process", tmp_path / "d" / "reference.tif", tmp_path / "d" / "target.tif",
        "--out", tmp_path / "o", "--until", "global", "--quiet",
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["stages"] == ["original", "uniformity", "global"]
    assert summary["objects"]["source"] == "segmented"


def test_evaluate_writes_table_and_json(tmp_path):
    assert radcons("demo", tmp_path / "d", "--size", "160", "--seed", "1").returncode == 0
    params = tmp_path / "fast.toml"
    params.write_text("[smoothness]\niterations = 1\n")
    result = radcons(
        "evaluate", tmp_path / "d", "--methods", "original,histmatch,ours", "--params", params,
        "--json", tmp_path / "r.json", "--quiet",
    )
    assert result.returncode == 0, result.stderr
    assert "correct-matching rate" in result.stdout and "histmatch" in result.stdout
    data = json.loads((tmp_path / "r.json").read_text())
    assert list(data["methods"]) == ["original", "histmatch", "ours"]
    for method in data["methods"].values():
        assert 0.0 <= method["correct_rate"] <= 1.0 and method["similarity"]


def test_evaluate_unknown_method(tmp_path):
    assert radcons("demo", tmp_path / "d", "--size", "96").returncode == 0
    result = radcons("evaluate", tmp_path / "d", "--methods", "original,magic")
    assert result.returncode == 2 and "unknown method(s) magic" in result.stderr
