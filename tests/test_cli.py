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

from pandora_cli import run_pandora_cli

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
    return (write_raster(d / "a.png", np.arange(400).astype(np.uint8).reshape(20, 20)),
            write_raster(d / "b.png", np.arange(420).astype(np.uint8).reshape(20, 21)))


def _garbage(d: Path) -> tuple[Path, Path]:
    (d / "a.tif").write_bytes(b"II*\x00garbage")
    return d / "a.tif", write_raster(d / "b.png", np.arange(100, dtype=np.uint8).reshape(10, 10))


def _all_nan(d: Path) -> tuple[Path, Path]:
    return (write_raster(d / "a.tif", np.full((16, 16), np.nan, np.float32)),
            write_raster(d / "b.tif", np.arange(256, dtype=np.float32).reshape(16, 16)))


@pytest.mark.parametrize(
    "make, message",
    [(_sizes, "b.png: reference is (20, 20) but target is (20, 21)"), (_garbage, "a.tif: unreadable"), (_all_nan, "a.tif: every pixel is NaN")],
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
    refine = summary["refine"]  # the background outside the objects, and whether light was corrected
    assert refine["background"] == "local" and 0.0 < refine["light_spread"] < 1.0
    assert refine["light_applied"] == (refine["light_spread"] >= summary["params"]["refine"]["local_min_light"])


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
    assert "histmatch" in result.stdout
    for matcher in ("sgbm", "census"):
        assert f"correct-matching rate, {matcher}" in result.stdout and f"matching s {matcher}" in result.stdout
    data = json.loads((tmp_path / "r.json").read_text())
    assert list(data["methods"]) == ["original", "histmatch", "ours"]
    for method in data["methods"].values():
        assert method["similarity"] and method["noise_ratio"] >= 1.0
    notice = data["noise_notice"]
    assert (notice is not None) == (data["methods"]["ours"]["noise_ratio"] > 1.5)
    assert notice is None or notice in result.stdout
    assert list(data["matchers"]) == ["sgbm", "census"]
    assert data["matchers"]["census"]["params"]["window_size"] == 5
    for matcher in data["matchers"].values():
        assert list(matcher["methods"]) == ["original", "histmatch", "ours"]
        for method in matcher["methods"].values():
            assert 0.0 <= method["rate_all"] <= 1.0 and 0.0 <= method["rate_objects"] <= 1.0


def test_evaluate_census_rates_agree_with_pandoras_command_line(tmp_path):
    """The census rates of `radcons evaluate` against Pandora's own command line on the same
    images (as read, unmapped: census sees only the order of grey levels), with the same
    settings and range, scored against the pair's known disparity here."""
    import cv2
    import rasterio
    from pandora.criteria import Criteria

    pandora = Path(sys.executable).with_name("pandora")
    if not pandora.exists():
        pytest.skip("Pandora's command line is not installed beside this Python")
    assert radcons("demo", tmp_path / "d", "--size", "128", "--seed", "3").returncode == 0
    params = tmp_path / "fast.toml"
    params.write_text("[smoothness]\niterations = 1\n")
    result = radcons(
        "evaluate", tmp_path / "d", "--methods", "original,ours", "--matcher", "census", "--params", params,
        "--json", tmp_path / "r.json", "--quiet",
    )
    assert result.returncode == 0, result.stderr
    ours = json.loads((tmp_path / "r.json").read_text())["matchers"]["census"]["methods"]["original"]

    images = {}
    for name in ("reference", "target", "disparity"):
        with rasterio.open(tmp_path / "d" / f"{name}.tif") as src:
            images[name] = src.read(1).astype(np.float32)
    truth = images["disparity"]
    profile = {"driver": "GTiff", "width": truth.shape[1], "height": truth.shape[0], "count": 1, "dtype": "float32"}
    for name in ("reference", "target"):
        with rasterio.open(tmp_path / f"{name}_f32.tif", "w", **profile) as dst:
            dst.write(images[name], 1)
    low, high = int(np.floor(np.nanmin(truth) - 2)), int(np.ceil(np.nanmax(truth) + 2))
    theirs, validity = run_pandora_cli(
        pandora, tmp_path / "reference_f32.tif", tmp_path / "target_f32.tif", low, high, tmp_path / "out"
    )
    theirs = -theirs  # Pandora's sign is the opposite of the project's
    theirs[(validity.astype(np.int64) & int(Criteria.PANDORA_MSK_PIXEL_INVALID)) != 0] = np.nan
    known = np.isfinite(truth)
    correct = np.abs(theirs - truth) < 1.0
    assert ours["rate_all"] == pytest.approx(correct[known].mean(), abs=0.002)
    labels = cv2.imread(str(tmp_path / "d" / "reference_objects.png"), cv2.IMREAD_UNCHANGED)
    rates = [correct[known & (labels == i)].mean() for i in np.unique(labels) if i > 0 and (known & (labels == i)).any()]
    assert ours["rate_objects"] == pytest.approx(np.mean(rates), abs=0.005)
    assert ours["rate_all"] > 0.5  # a real match, not chance agreement on failures


def test_evaluate_unknown_matcher(tmp_path):
    assert radcons("demo", tmp_path / "d", "--size", "96").returncode == 0
    result = radcons("evaluate", tmp_path / "d", "--matcher", "sgbm,mc-cnn")
    assert result.returncode == 2 and "unknown: mc-cnn" in result.stderr


def test_evaluate_unknown_method(tmp_path):
    assert radcons("demo", tmp_path / "d", "--size", "96").returncode == 0
    result = radcons("evaluate", tmp_path / "d", "--methods", "original,magic")
    assert result.returncode == 2 and "unknown method(s) magic" in result.stderr


# ------------------------------------------------------------------ scene mode


def test_process_in_scene_mode_writes_a_tiled_pair(tmp_path):
    assert radcons("demo", tmp_path / "demo", "--size", "256").returncode == 0
    result = radcons("process", tmp_path / "demo", "--out", tmp_path / "out", "--tiles", "128")
    assert result.returncode == 0, result.stderr
    assert "Dask dashboard" in result.stderr and "scene tiles 4/4" in result.stderr
    out = load_pair(tmp_path / "out")
    assert out.reference.data.shape == (256, 256)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["mode"] == "scene" and summary["tiles"] == 4


def test_scene_mode_is_chosen_past_the_memory_limit(tmp_path):
    assert radcons("demo", tmp_path / "demo", "--size", "256").returncode == 0
    # 256 x 256 px need about 20 MB in memory: a 10 MB budget sends the pair to scene
    # mode, whose workers need more than that, which is refused before anything runs
    result = radcons("process", tmp_path / "demo", "--out", tmp_path / "out", "--memory-limit", "10M")
    assert result.returncode == 2 and "scene mode needs at least" in result.stderr
    bad = radcons("process", tmp_path / "demo", "--out", tmp_path / "out", "--memory-limit", "lots")
    assert bad.returncode == 2 and "--memory-limit must be a size" in bad.stderr
    assert not (tmp_path / "out").exists()


def test_scene_mode_checks_the_disk_before_running(tmp_path, monkeypatch, capsys):
    import shutil

    from radcons import cli

    assert radcons("demo", tmp_path / "demo", "--size", "128").returncode == 0
    monkeypatch.setattr("radcons.preflight.shutil.disk_usage", lambda path: shutil._ntuple_diskusage(1, 1, 1000))
    assert cli.main(["process", str(tmp_path / "demo"), "--out", str(tmp_path / "out"), "--tiles", "128"]) == 2
    assert "MiB free on its disk" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
