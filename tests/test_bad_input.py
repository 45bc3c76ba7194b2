"""Bad inputs through the real command line: one line, the right exit code, inputs untouched.

Each case builds its inputs in a temporary folder, runs ``radcons`` as a subprocess, and
checks the exit status, that stderr is one line naming the problem, that no traceback is
printed, and that every input file is byte-identical afterwards.
"""

from __future__ import annotations

import hashlib
import subprocess
import sys
import time
from dataclasses import fields
from pathlib import Path
from typing import Callable

import numpy as np
import pytest
import tifffile

from radcons.io import Pair, Raster, save_pair, write_raster
from radcons.param_spec import spec_of
from radcons.stages.objects.params import ObjectsParams


def radcons(*args: object, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "radcons.cli", *map(str, args)], capture_output=True, text=True, timeout=timeout
    )


def _texture(shape: tuple[int, int], seed: int, dtype: type = np.uint16, scale: float = 1000.0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    base = rng.random(shape).astype(np.float32)
    return (base * scale + 10).astype(dtype)


def _pair_folder(root: Path, name: str = "pair", size: int = 64) -> Path:
    ref = _texture((size, size), 0)
    tgt = np.roll(ref, -3, axis=1)
    pair = Pair(Raster(ref, {}, None, None), Raster(tgt, {}, None, None), name=name)
    return save_pair(pair, root / name).parent


def _digests(root: Path) -> dict[Path, str]:
    return {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(root.rglob("*")) if p.is_file()}


# Each case: a function that builds inputs under a folder and returns the arguments after
# ``radcons``, the expected exit code, and a piece of the expected message.
Case = Callable[[Path], tuple[list[object], int, str]]


def out_is_input_folder(d: Path):
    pair = _pair_folder(d)
    return ["process", pair, "--out", pair], 2, "would replace the input"


def out_is_parent_of_input(d: Path):
    pair = _pair_folder(d)
    return ["process", pair, "--out", d], 2, "would replace the input"


def out_inside_input_folder(d: Path):
    pair = _pair_folder(d)
    return ["process", pair, "--out", pair / "result"], 2, "inside the input pair folder"


def out_is_input_image(d: Path):
    a, b = write_raster(d / "a.tif", _texture((32, 32), 1)), write_raster(d / "b.tif", _texture((32, 32), 2))
    return ["process", a, b, "--out", a], 2, "would replace the input"


def out_is_unrelated_folder(d: Path):
    pair = _pair_folder(d)
    (d / "mine").mkdir()
    (d / "mine" / "notes.txt").write_text("keep me")
    return ["process", pair, "--out", d / "mine"], 2, "not an earlier radcons result"


def out_is_a_file(d: Path):
    pair = _pair_folder(d)
    (d / "file").write_text("x")
    return ["process", pair, "--out", d / "file"], 2, "not a folder"


def out_under_a_file(d: Path):
    pair = _pair_folder(d)
    (d / "file").write_text("x")
    return ["process", pair, "--out", d / "file" / "out"], 2, "is a file, not a folder"


def until_unknown(d: Path):
    return ["process", _pair_folder(d), "--out", d / "o", "--until", "bogus"], 2, "invalid choice"


def params_is_folder(d: Path):
    return ["process", _pair_folder(d), "--out", d / "o", "--params", d], 2, "not a folder"


def params_missing(d: Path):
    return ["process", _pair_folder(d), "--out", d / "o", "--params", d / "none.toml"], 2, "not found"


def _with_params(d: Path, text: str, message: str) -> tuple[list, int, str]:
    """``process`` of a good pair with a parameter file holding ``text``: exit 2 with ``message``."""
    path = d / "p.toml"
    path.write_text(text)
    return ["process", _pair_folder(d), "--out", d / "o", "--params", path], 2, message


def max_size_huge(d: Path):
    return _with_params(d, "[objects]\nmax_size = 1000000000\n", "longer than the image's smaller side")


def blend_width_nan(d: Path):
    return _with_params(d, "[refine]\nblend_width = nan\n", "blend_width must be a finite number")


def ratio_inf(d: Path):
    return _with_params(d, "[association]\nratio = inf\n", "ratio must be a finite number")


def gain_range_short(d: Path):
    return _with_params(d, "[refine]\ngain_range = [0.5]\n", "gain_range must be a list of 2")


def smoothness_iterations_huge(d: Path):
    return _with_params(d, "[smoothness]\niterations = 100000000\n", "iterations must be in [1, 100]")


def objects_ground_unknown(d: Path):
    return _with_params(d, '[objects]\nground = "cloth"\n', "ground must be one of windows, bulldozer, got 'cloth'")


def objects_method_unknown(d: Path):
    return _with_params(d, '[objects]\nmethod = "lidar"\n', "[objects] method must be one of mbi, height")


def background_smoothing_too_wide(d: Path):
    return _with_params(d, "[refine]\nbackground_smoothing = 50\n", "background_smoothing must be in [0, 10]")


def local_min_light_beyond_one(d: Path):
    return _with_params(d, "[refine]\nlocal_min_light = 1.5\n", "[refine] local_min_light must be in [0, 1], got 1.5")


def local_min_light_nan(d: Path):
    return _with_params(d, "[refine]\nlocal_min_light = nan\n", "[refine] local_min_light must be a finite number")


def local_tiles_zero(d: Path):
    return _with_params(d, "[refine]\nlocal_tiles = 0\n", "[refine] local_tiles must be in [1, 64], got 0")


def rectify_method_unknown(d: Path):
    return _with_params(d, '[rectify]\nmethod = "magic"\n', "[rectify] method must be one of auto, rpc, affine")


def noise_gate_below_one(d: Path):
    return _with_params(d, "[sharpness]\nnoise_gate = 0.5\n", "noise_gate must be in [1, inf]")


def noise_coded_gate_below_one(d: Path):
    return _with_params(d, "[sharpness]\nnoise_coded_gate = 0.5\n", "noise_coded_gate must be in [1, inf]")


def noise_max_sigma_beyond_max_sigma(d: Path):
    return _with_params(d, "[sharpness]\nnoise_max_sigma = 9\n", "needs 0 < noise_max_sigma <= max_sigma")


def min_object_height_negative(d: Path):
    return _with_params(d, "[objects]\nmin_object_height = -1\n", "[objects] min_object_height must be in [0.05, 100]")


def noise_flat_margin_negative(d: Path):
    return _with_params(d, "[sharpness]\nnoise_flat_margin = -0.1\n", "noise_flat_margin must be in [0, inf]")


def noise_aware_background_without_histogram(d: Path):
    text = '[refine]\nbackground = "global"\nbackground_noise = true\n'
    return _with_params(d, text, "background_noise needs background")


def missed_scale_zero(d: Path):
    return _with_params(d, "[objects]\nmissed_scale = 0\n", "[objects] missed_scale must be in [10, 10000]")


def missed_margin_negative(d: Path):
    return _with_params(d, "[objects]\nmissed_margin = -0.1\n", "[objects] missed_margin must be in [0, 1]")


def missed_rectangularity_beyond_one(d: Path):
    return _with_params(d, "[objects]\nmissed_rectangularity = 1.5\n", "[objects] missed_rectangularity must be in [0, 1]")


def shadow_texture_beyond_two(d: Path):
    return _with_params(d, "[objects]\nshadow_texture = 3\n", "[objects] shadow_texture must be in [0, 2]")


def tree_alignment_beyond_one(d: Path):
    return _with_params(d, "[objects]\ntree_alignment = 1.5\n", "[objects] tree_alignment must be in [0, 1]")


def spilled_roof_texture_beyond_two(d: Path):
    return _with_params(d, "[objects]\nspilled_roof_texture = 2.5\n", "[objects] spilled_roof_texture must be in [0, 2]")


def rectify_orient_unknown(d: Path):
    return _with_params(d, '[rectify]\norient = "sideways"\n', "[rectify] orient must be one of relief, rotation")


def tall_roof_height_m_negative(d: Path):
    return _with_params(d, "[objects]\ntall_roof_height_m = -5\n", "[objects] tall_roof_height_m must be in [0, 1000] m")


def crown_alignment_beyond_one(d: Path):
    return _with_params(d, "[objects]\ncrown_alignment = 1.2\n", "[objects] crown_alignment must be in [0, 1]")


def crown_rectangularity_beyond_two(d: Path):
    return _with_params(d, "[objects]\ncrown_rectangularity = 2.5\n", "[objects] crown_rectangularity must be in [0, 2]")


def crown_height_negative(d: Path):
    return _with_params(d, "[objects]\ncrown_height = -1\n", "[objects] crown_height must be in [0, 100]")


def dark_height_negative(d: Path):
    return _with_params(d, "[objects]\ndark_height = -1\n", "[objects] dark_height must be in [0, 100]")


def shadow_trim_beyond_one(d: Path):
    return _with_params(d, "[objects]\nshadow_trim = 1.5\n", "[objects] shadow_trim must be in [0, 1]")


def outline_band_negative(d: Path):
    return _with_params(d, "[objects]\noutline_band = -2\n", "[objects] outline_band must be in [0, 20] px")


def outline_edge_negative(d: Path):
    return _with_params(d, "[objects]\noutline_edge = -1\n", "[objects] outline_edge must be in [0, 100]")


def census_cell_m_zero(d: Path):
    return _with_params(d, "[objects]\ncensus_cell_m = 0\n", "[objects] census_cell_m must be in [0.05, 50] m")


def textured_roof_rectangularity_beyond_two(d: Path):
    return _with_params(
        d, "[objects]\ntextured_roof_rectangularity = 3\n", "[objects] textured_roof_rectangularity must be in [0, 2]"
    )


def tree_greenness_beyond_one(d: Path):
    return _with_params(d, "[objects]\ntree_greenness = 1.5\n", "[objects] tree_greenness must be in [-1, 1]")


def cross_check_objects_not_a_switch(d: Path):
    return _with_params(d, '[objects]\ncross_check_objects = "yes"\n', "cross_check_objects must be true or false")


def removed_scale_zero(d: Path):
    return _with_params(d, "[objects]\nremoved_scale = 0\n", "[objects] removed_scale must be in [10, 10000]")


def find_in_removed_not_a_switch(d: Path):
    return _with_params(d, '[objects]\nfind_in_removed = "yes"\n', "find_in_removed must be true or false")


def find_clipped_not_a_switch(d: Path):
    return _with_params(d, '[objects]\nfind_clipped = 1\n', "find_clipped must be true or false")


def join_wings_not_a_switch(d: Path):
    return _with_params(d, '[objects]\njoin_wings = 1\n', "join_wings must be true or false")


def join_roof_halves_not_a_switch(d: Path):
    return _with_params(d, '[objects]\njoin_roof_halves = 1\n', "join_roof_halves must be true or false")


def complete_gables_not_a_switch(d: Path):
    return _with_params(d, '[objects]\ncomplete_gables = 1\n', "complete_gables must be true or false")


def roof_rectangularity_beyond_two(d: Path):
    return _with_params(d, "[objects]\nroof_rectangularity = 3\n", "[objects] roof_rectangularity must be in [0, 2]")


def tree_hull_rectangularity_beyond_one(d: Path):
    return _with_params(d, "[objects]\ntree_hull_rectangularity = 1.5\n", "[objects] tree_hull_rectangularity must be in [0, 1]")


def disparity_radius_too_wide(d: Path):
    return _with_params(d, "[objects]\ndisparity_radius = 40\n", "[objects] disparity_radius must be in [0, 16] px")


def band_out_of_range(d: Path):
    return ["process", _pair_folder(d), "--out", d / "o", "--band", "5"], 2, "--band 5 is out of range"


def tiles_too_small(d: Path):
    return ["process", _pair_folder(d), "--out", d / "o", "--tiles", "10"], 2, "--tiles must be between 64 and 16384"


def tiles_not_whole_blocks(d: Path):
    return ["process", _pair_folder(d), "--out", d / "o", "--tiles", "100"], 2, "a multiple of 64, got 100"


def scene_label_raster_of_three_bands(d: Path):
    pair = _pair_folder(d)
    tifffile.imwrite(pair / "labels.tif", np.ones((64, 64, 3), np.uint8), photometric="rgb")
    manifest = (pair / "pair.toml").read_text()
    (pair / "pair.toml").write_text(manifest + 'reference_objects = "labels.tif"\ntarget_objects = "labels.tif"\n')
    return ["process", pair, "--out", d / "o", "--tiles", "64"], 2, "an object label raster has one"


def inspect_memory_limit_unreadable(d: Path):
    return ["inspect", "--memory-limit", "lots", "--port", "0"], 2, "--memory-limit must be a size such as 4G or 512M, got 'lots'"


def memory_limit_unreadable(d: Path):
    return ["process", _pair_folder(d), "--out", d / "o", "--memory-limit", "lots"], 2, "--memory-limit must be a size"


def matcher_unknown(d: Path):
    return ["evaluate", _pair_folder(d), "--matcher", "sgbm,mc-cnn"], 2, "unknown: mc-cnn"


def nodata_not_representable(d: Path):
    a, b = write_raster(d / "a.tif", _texture((32, 32), 1)), write_raster(d / "b.tif", _texture((32, 32), 2))
    return ["process", a, b, "--out", d / "o", "--nodata", "-1"], 2, "cannot occur in a uint16 image"


def multipage_tiff(d: Path):
    path = d / "stack.tif"
    tifffile.imwrite(path, _texture((3, 32, 32), 1), photometric="minisblack")
    b = write_raster(d / "b.tif", _texture((32, 32), 2))
    return ["process", path, b, "--out", d / "o"], 2, "multi-page TIFF (3 images)"


def infinite_pixels(d: Path):
    image = _texture((32, 32), 1, np.float32)
    image[:2, :3] = np.inf
    a, b = write_raster(d / "a.tif", image), write_raster(d / "b.tif", _texture((32, 32), 2, np.float32))
    return ["process", a, b, "--out", d / "o"], 2, "6 pixel(s) are infinite"


def huge_pixel(d: Path):
    image = _texture((32, 32), 1, np.float32)
    image[5, 5] = 3e38
    a, b = write_raster(d / "a.tif", image), write_raster(d / "b.tif", _texture((32, 32), 2, np.float32))
    return ["process", a, b, "--out", d / "o"], 2, "1 pixel(s) exceed"


def one_row_image(d: Path):
    a, b = write_raster(d / "a.tif", _texture((1, 64), 1)), write_raster(d / "b.tif", _texture((1, 64), 2))
    return ["process", a, b, "--out", d / "o"], 2, "smaller side"


def unknown_method(d: Path):
    return ["evaluate", _pair_folder(d), "--methods", "original,magic"], 2, "unknown method(s) magic"


def json_is_folder(d: Path):
    return ["evaluate", _pair_folder(d), "--methods", "original", "--json", d], 2, "--json is a folder"


def rrd_is_input(d: Path):
    pair = _pair_folder(d)
    return ["process", pair, "--out", d / "o", "--rrd", pair / "reference.tif"], 2, "would overwrite an input"


def too_large_for_memory(d: Path):
    # A sparse TIFF of 60000 x 60000 uint16 pixels (its tiles not written): refused from its
    # header, never read, by `evaluate`, which runs in memory (`process` takes such a pair in
    # scene mode).
    import rasterio

    path = d / "big.tif"
    with rasterio.open(path, "w", driver="GTiff", width=60000, height=60000, count=1, dtype="uint16",
                       tiled=True, blockxsize=1024, blockysize=1024, BIGTIFF="YES", SPARSE_OK=True):
        pass
    return ["evaluate", path, path, "--methods", "original"], 2, "Mpx per image and would need about"


def blank_scene(d: Path):
    # Two header-only (sparse) GeoTIFFs of 60000 x 60000 pixels, all zero: `process` takes them
    # in scene mode and refuses them from a decimated read, before a cluster streams them.
    import rasterio

    paths = [d / "blank_reference.tif", d / "blank_target.tif"]
    for path in paths:
        with rasterio.open(path, "w", driver="GTiff", width=60000, height=60000, count=1, dtype="uint8",
                           tiled=True, blockxsize=256, blockysize=256, BIGTIFF="YES", SPARSE_OK=True):
            pass
    return ["process", *paths, "--out", d / "o"], 2, "blank_reference.tif: the image is constant (0 at all"


def _manifest_target(d: Path, target: str) -> Path:
    """A good pair folder whose manifest's ``target`` is replaced by ``target``."""
    pair = _pair_folder(d)
    manifest = pair / "pair.toml"
    manifest.write_text(manifest.read_text().replace('target = "target.tif"', f"target = {target!r}"))
    return pair


def manifest_target_absolute(d: Path):
    pair = _manifest_target(d, "/etc/hostname")
    return ["process", pair, "--out", d / "o"], 2, "pair.toml: target = '/etc/hostname' points outside the pair folder"


def manifest_target_climbs_out(d: Path):
    write_raster(d / "x.tif", _texture((64, 64), 5))
    pair = _manifest_target(d, "../x.tif")
    return ["evaluate", pair, "--methods", "original"], 2, "pair.toml: target = '../x.tif' points outside the pair folder"


def manifest_target_link_leaves(d: Path):
    pair = _manifest_target(d, "link.tif")
    (pair / "link.tif").symlink_to(write_raster(d / "elsewhere.tif", _texture((64, 64), 5)))
    return ["process", pair, "--out", d / "o"], 2, "target = 'link.tif' is a symbolic link that leads outside the pair folder"


def manifest_link_leaves_in_inspect(d: Path):
    pair = _manifest_target(d, "link.tif")
    (pair / "link.tif").symlink_to(write_raster(d / "elsewhere.tif", _texture((64, 64), 5)))
    return ["inspect", pair, "--port", "0"], 2, "target = 'link.tif' is a symbolic link that leads outside the pair folder"


def scheduler_not_an_address(d: Path):
    args = ["process", _pair_folder(d), "--out", d / "o", "--scheduler", "notaurl"]
    return args, 2, "--scheduler 'notaurl' is not a Dask scheduler address such as tcp://host:8786: it names no port"


def input_symlink_loop(d: Path):
    (d / "loop_a.tif").symlink_to(d / "loop_b.tif")
    (d / "loop_b.tif").symlink_to(d / "loop_a.tif")
    b = write_raster(d / "b.tif", _texture((32, 32), 2))
    return ["process", d / "loop_a.tif", b, "--out", d / "o"], 2, "loop_a.tif: a symbolic link loop"


def params_out_is_folder(d: Path):
    return ["params", d], 2, "is a folder; name the file to write, such as"


def tiles_zero(d: Path):
    return ["process", _pair_folder(d), "--out", d / "o", "--tiles", "0"], 2, "a multiple of 64, got 0"


def tiles_negative(d: Path):
    return ["process", _pair_folder(d), "--out", d / "o", "--tiles", "-64"], 2, "a multiple of 64, got -64"


def image_below_the_stages_minimum(d: Path):
    # 8 px passed the old size check, then the sharpness stage refused it after the stages before it ran
    a, b = write_raster(d / "a.tif", _texture((8, 8), 1)), write_raster(d / "b.tif", _texture((8, 8), 2))
    return ["process", a, b, "--out", d / "o"], 2, "a.tif: the image is 8 x 8 px; its smaller side needs at least 16 px"


def view_truncated_recording(d: Path):
    import rerun as rr

    whole, cut = d / "whole.rrd", d / "cut.rrd"
    recording = rr.RecordingStream("radcons", recording_id="bad-input")
    recording.save(whole)
    recording.log("image", rr.Image(_texture((64, 64), 1, np.uint8, 200.0)))
    recording.disconnect()
    cut.write_bytes(whole.read_bytes()[:-100])
    return ["view", cut, "--port", "0"], 2, "cut.rrd: a corrupt or truncated rerun recording"


CASES: list[Case] = [
    out_is_input_folder, out_is_parent_of_input, out_inside_input_folder, out_is_input_image,
    out_is_unrelated_folder, out_is_a_file, out_under_a_file, until_unknown, params_is_folder,
    params_missing, max_size_huge, blend_width_nan, ratio_inf, gain_range_short,
    smoothness_iterations_huge, objects_ground_unknown, objects_method_unknown, background_smoothing_too_wide, rectify_method_unknown,
    local_min_light_beyond_one, local_min_light_nan, local_tiles_zero,
    noise_gate_below_one, noise_coded_gate_below_one, noise_max_sigma_beyond_max_sigma, min_object_height_negative,
    noise_flat_margin_negative, noise_aware_background_without_histogram,
    tree_hull_rectangularity_beyond_one, roof_rectangularity_beyond_two, join_roof_halves_not_a_switch, complete_gables_not_a_switch, join_wings_not_a_switch, removed_scale_zero, find_in_removed_not_a_switch, find_clipped_not_a_switch, missed_scale_zero, missed_margin_negative, missed_rectangularity_beyond_one,
    tree_greenness_beyond_one, tree_alignment_beyond_one, spilled_roof_texture_beyond_two, tall_roof_height_m_negative, rectify_orient_unknown, dark_height_negative, crown_alignment_beyond_one, crown_rectangularity_beyond_two, crown_height_negative, shadow_trim_beyond_one, outline_band_negative, outline_edge_negative, census_cell_m_zero, textured_roof_rectangularity_beyond_two, shadow_texture_beyond_two, cross_check_objects_not_a_switch,
    disparity_radius_too_wide,
    band_out_of_range, tiles_too_small, tiles_not_whole_blocks, scene_label_raster_of_three_bands,
    memory_limit_unreadable, inspect_memory_limit_unreadable, matcher_unknown, nodata_not_representable, multipage_tiff, infinite_pixels, huge_pixel,
    one_row_image, unknown_method, json_is_folder, rrd_is_input, too_large_for_memory, blank_scene,
    manifest_target_absolute, manifest_target_climbs_out, manifest_target_link_leaves, manifest_link_leaves_in_inspect,
    scheduler_not_an_address, input_symlink_loop, params_out_is_folder, tiles_zero, tiles_negative,
    image_below_the_stages_minimum, view_truncated_recording,
]


@pytest.mark.parametrize("case", CASES, ids=[case.__name__ for case in CASES])
def test_bad_input_is_refused_in_one_line_and_inputs_are_unchanged(tmp_path, case):
    args, code, message = case(tmp_path)
    before = _digests(tmp_path)
    result = radcons(*args)
    assert result.returncode == code, result.stderr
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert "Traceback" not in result.stderr
    assert message in lines[-1], lines
    assert len([line for line in lines if line.startswith("radcons")]) == 1, lines
    assert _digests(tmp_path) == before, "an input changed"


def _out_of_range(spec) -> float:
    """A value just outside a declared range (above it where it has a top)."""
    return spec.high + 1 if spec.high is not None else spec.low - 1


_BASIC_OBJECTS = [(f.name, spec_of(f)) for f in fields(ObjectsParams) if spec_of(f).basic]


@pytest.mark.parametrize(
    "name, spec", [(n, s) for n, s in _BASIC_OBJECTS if s.low is not None or s.high is not None], ids=lambda v: str(v)
)
def test_each_basic_objects_parameter_out_of_range_is_refused_in_one_line(tmp_path, name, spec):
    value = _out_of_range(spec)
    path = tmp_path / "p.toml"
    path.write_text(f"[objects]\n{name} = {value!r}\n")
    args = ["process", _pair_folder(tmp_path), "--out", tmp_path / "o", "--params", path]
    result = radcons(*args)
    assert result.returncode == 2, result.stderr
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and f"[objects] {name} must be in" in lines[0], lines
    assert not (tmp_path / "o").exists()


def test_failure_is_one_line_with_exit_1_and_debug_shows_the_traceback(tmp_path, monkeypatch):
    from radcons import cli

    def boom(args):
        raise RuntimeError("something broke")

    monkeypatch.setitem(cli._COMMANDS, "params", boom)
    assert cli.main(["params"]) == 1
    with pytest.raises(RuntimeError):
        cli.main(["params", "--debug"])


def test_mixed_bit_depths_keep_each_image_in_its_own_range(tmp_path):
    ref = _texture((96, 96), 0, np.uint16, 2000.0)
    tgt8 = (np.roll(ref, -4, axis=1).astype(np.float32) / 2010 * 255).astype(np.uint8)
    a, b = write_raster(tmp_path / "a.tif", ref), write_raster(tmp_path / "b.tif", tgt8)
    result = radcons("process", a, b, "--out", tmp_path / "own", "--quiet", "--until", "refine")
    assert result.returncode == 0, result.stderr
    out_t = tifffile.imread(tmp_path / "own" / "target.tif")
    assert out_t.dtype == np.uint8
    # Not saturated (it was all 255 when the target was clipped in the reference's range).
    assert (out_t == 255).mean() < 0.05 and out_t.max() > 128
    result = radcons("process", a, b, "--out", tmp_path / "common", "--quiet", "--until", "refine", "--output-dtype", "common")
    assert result.returncode == 0, result.stderr
    assert tifffile.imread(tmp_path / "common" / "target.tif").dtype == np.uint16


def _image_digests(folder: Path) -> tuple[str, str]:
    return tuple(hashlib.sha256((folder / f"{key}.tif").read_bytes()).hexdigest() for key in ("reference", "target"))


def test_a_rerun_killed_at_any_point_leaves_a_whole_result(tmp_path):
    """kill -9 a re-run into an existing --out at several moments: the folder holds the old
    complete result or the new complete one, never a mix; the next run leaves nothing behind."""
    import json
    import signal

    from radcons.io import load_pair

    pair = _pair_folder(tmp_path, size=160)
    old, new = tmp_path / "old", tmp_path / "new"
    old_run = ["--until", "association", "--quiet"]
    new_run = ["--preset", "paper", "--quiet"]
    for folder, options in ((old, old_run), (new, new_run)):
        assert radcons("process", pair, "--out", folder, *options).returncode == 0
    complete = {_image_digests(old): "original", _image_digests(new): "smoothness"}
    assert len(complete) == 2
    out = tmp_path / "out"
    seen = set()
    for delay in (0.3, 0.8, 1.2, 1.6, 2.0, 2.5, 3.0, 4.0):
        assert radcons("process", pair, "--out", out, *old_run).returncode == 0
        child = subprocess.Popen(
            [sys.executable, "-m", "radcons.cli", "process", pair, "--out", out, *new_run],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )
        time.sleep(delay)
        child.send_signal(signal.SIGKILL)
        child.wait()
        if not out.exists():  # killed between moving the old result aside and the new one in
            from radcons.io import recover_folder

            recover_folder(out)
        stage = complete.get(_image_digests(out))
        assert stage is not None, f"a mixed result after a kill at {delay} s"
        assert json.loads((out / "summary.json").read_text())["stages"][-1] == stage
        load_pair(out)
        seen.add(stage)
    assert radcons("process", pair, "--out", out, *new_run).returncode == 0
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".out")) == []
    assert not list(out.glob("*.part")) and not list(out.glob(".*"))
    assert "original" in seen  # the early kills came before the swap
