"""Scene-sized pairs in the inspector: the decimated preview, and "Apply to full resolution"
driven through the real page against an in-memory ``radcons process`` of the same pair."""

from __future__ import annotations

import subprocess
import sys
import threading
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from radcons.errors import InputError


def _write_tif(path: Path, data: np.ndarray, overviews: tuple[int, ...] = ()) -> Path:
    import rasterio
    from rasterio.enums import Resampling

    profile = {"driver": "GTiff", "width": data.shape[1], "height": data.shape[0], "count": 1, "dtype": data.dtype.name,
               "tiled": True, "blockxsize": 256, "blockysize": 256}
    with rasterio.open(path, "w", **profile) as dataset:
        dataset.write(data, 1)
        if overviews:
            dataset.build_overviews(list(overviews), Resampling.average)
    return path


def _block_mean(image: np.ndarray, factor: int) -> np.ndarray:
    rows, cols = image.shape
    return image.reshape(rows // factor, factor, cols // factor, factor).astype(np.float64).mean(axis=(1, 3))


@pytest.fixture()
def scene_folder(tmp_path) -> tuple[Path, dict[str, np.ndarray]]:
    """A 768 x 1024 pair folder whose GeoTIFFs have overviews, with labels and a disparity."""
    from radcons.io import MANIFEST

    rng = np.random.default_rng(4)
    rows, cols = 768, 1024
    y, x = np.mgrid[0:rows, 0:cols]
    reference = (800 + 600 * np.sin(x / 37.0) * np.cos(y / 23.0) + rng.normal(0, 40, (rows, cols))).astype(np.uint16)
    target = (reference // 2 + 100).astype(np.uint16)
    labels = np.zeros((rows, cols), np.uint16)
    labels[100:300, 200:520] = 3
    labels[500:700, 600:900] = 7
    disparity = np.full((rows, cols), 8.0, np.float32)
    folder = tmp_path / "scene"
    folder.mkdir()
    for name, data in (("reference", reference), ("target", target)):
        _write_tif(folder / f"{name}.tif", data, (2, 4, 8))
    _write_tif(folder / "labels.tif", labels)
    _write_tif(folder / "disparity.tif", disparity)
    (folder / MANIFEST).write_text(
        'name = "wide"\nreference = "reference.tif"\ntarget = "target.tif"\nreference_objects = "labels.tif"\n'
        'target_objects = "labels.tif"\ndisparity = "disparity.tif"\n'
    )
    return folder, {"reference": reference, "target": target, "labels": labels}


def test_scene_sized_pairs_are_told_from_their_headers(scene_folder):
    from inspector.scene_preview import scene_source

    folder, _ = scene_folder
    assert scene_source([folder], 1024 * 768) is None  # not larger than the threshold
    assert scene_source([folder], None) is None  # far below the memory budget
    source = scene_source([folder], 1000)
    assert source is not None and source.shape == (768, 1024) and source.name == "wide"
    assert source.dtype == np.uint16
    pair = scene_source([folder / "reference.tif", folder / "target.tif"], 1000)
    assert pair is not None and pair.args == (folder / "reference.tif", folder / "target.tif")
    assert scene_source([folder / "missing"], 1000) is None  # the ordinary loader says what is wrong
    # radcons inspect --memory-limit: the budget an in-memory run of 768 x 1024 would pass
    from radcons.preflight import BYTES_PER_PIXEL

    needed = 768 * 1024 * BYTES_PER_PIXEL
    assert scene_source([folder], None, memory_limit=needed - 1) is not None
    assert scene_source([folder], None, memory_limit=needed) is None


def test_decimated_preview_is_the_block_mean_and_regions_are_exact(scene_folder):
    from inspector.scene_preview import read_preview, read_region, scene_source

    folder, truth = scene_folder
    source = scene_source([folder], 1000)
    preview, factor = read_preview(source, 256)
    assert factor == 4 and preview.shape == (192, 256) and preview.target.data.shape == (192, 256)
    for key in ("reference", "target"):
        shrunk = getattr(preview, key).data
        assert shrunk.dtype == np.float32
        # the file's overview (block averages of 2 x 2 of 2 x 2, each rounded) against an exact block mean
        assert np.abs(shrunk - _block_mean(truth[key], 4)).max() <= 1.0
    assert set(np.unique(preview.reference_objects)) == {0, 3, 7}
    assert np.mean(preview.reference_objects == truth["labels"][2::4, 2::4]) > 0.98
    np.testing.assert_array_equal(preview.disparity, 2.0)  # 8 px of the scene are 2 of the preview

    region = read_region(source, (100, 50, 300, 200))
    np.testing.assert_array_equal(region.reference.data, truth["reference"][50:250, 100:400])
    np.testing.assert_array_equal(region.target_objects, truth["labels"][50:250, 100:400])
    with pytest.raises(InputError, match="does not fit"):
        read_region(source, (900, 0, 300, 200))


def _sparse_scene(folder: Path, side: int, overview: np.ndarray | None) -> list[Path]:
    """Two ``side`` x ``side`` uint16 GeoTIFFs of which no block is written (a few hundred
    bytes on disk), each with an external overview file holding ``overview`` (if given)."""
    import rasterio

    folder.mkdir()
    paths = []
    for name in ("reference", "target"):
        path = folder / f"{name}.tif"
        with rasterio.open(path, "w", driver="GTiff", width=side, height=side, count=1, dtype="uint16", tiled=True,
                           blockxsize=256, blockysize=256, sparse_ok=True, BIGTIFF="YES"):
            pass
        if overview is not None:
            _write_tif(Path(f"{path}.ovr"), overview)
        paths.append(path)
    return paths


def test_a_huge_sparse_scene_opens_as_a_preview_from_its_overview(tmp_path):
    from inspector.context import Context
    from inspector.panels.data import DataPanel
    from inspector.paths import AllowedRoots
    from inspector.scene_preview import read_preview, scene_source

    side, factor = 40000, 32
    small = side // factor
    overview = (np.add.outer(np.arange(small), np.arange(small)) % 4000 + 10).astype(np.uint16)
    paths = _sparse_scene(tmp_path / "huge", side, overview)
    source = scene_source(paths, None)  # 1.6 Gpx per image: beyond any memory budget here
    assert source is not None and source.shape == (side, side)
    tracemalloc.start()
    try:
        preview, found = read_preview(source, small)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert found == factor and preview.shape == (small, small)
    # the overview's pixels, not the (all-zero) full-resolution blocks
    np.testing.assert_array_equal(preview.reference.data, overview.astype(np.float32))
    assert peak < 64 * 2**20  # one full image would be 3.2 GB
    panel = DataPanel(Context(), None, AllowedRoots([tmp_path]), [], small, {}, 1)
    work = panel.work_pair("huge", source, "preview")
    assert work.scene is source and work.factor == factor
    assert work.describe == f"preview {small}x{small} of a scene (1/{factor} of {side}x{side}, read decimated)"
    with pytest.raises(InputError, match="too large to tune whole"):
        panel.work_pair("huge", source, "full")
    region = panel.work_pair("huge", source, "region", (30000.0, 100.0))  # moved inside the scene
    assert region.region == (30000 - small // 2, 0, small, small) and region.scene is source
    assert region.pair.shape == (small, small) and region.pair.reference.data.dtype == np.uint16
    assert region.describe == f"region {small}x{small} at ({30000 - small // 2}, 0) of {side}x{side}"


# ----------------------------------------------------------------------------- the real page


@pytest.mark.browser
def test_apply_to_full_resolution_from_the_page_matches_an_in_memory_process(browser, tmp_path):
    from test_inspector_browser import open_page, open_stage, running, set_number, wait_until
    from test_scene import _read

    from demo_data_gen import generate
    from radcons.io import save_pair
    from radcons.params import Params

    size, tile = 256, 128
    folder = tmp_path / "pair"
    save_pair(generate(size=size, seed=2, scenario="mixed"), folder)
    expected_params = Params.from_preset("radcons").with_stage("sharpness", strength=0.8)
    with running(tmp_path, pairs=[folder], preset="radcons", preview_side=128, scene_pixels=size * size // 2,
                 scene_processes=False) as app:
        app.disparity.auto_review.value = False
        page, _ = open_page(browser, app)
        page.get_by_text("of a scene (1/2 of 256x256, read decimated)", exact=False).first.wait_for(timeout=30_000)
        assert app.session.work.scene is not None and app.session.work.pair.shape == (128, 128)
        page.get_by_role("tab", name="Export").click()
        set_number(page, "Tile size", tile)
        set_number(page, "Workers", 1)
        wait_until(lambda: app.scene.tile.value == tile and app.scene.workers.value == 1, what="the scene fields")
        out = tmp_path / f"{app.session.work.scene.name}-consistent"

        # A first run held at its first tile: the page and the tuning stay live, Cancel stops it.
        release, held = threading.Event(), threading.Event()
        show = app.scene.job.on_change

        def hold_at_tiles(state):
            show(state)
            if state.phase == "running" and state.step == "tiles" and not held.is_set():
                held.set()
                release.wait(120)

        app.scene.job.on_change = hold_at_tiles
        page.get_by_role("button", name="Apply to full resolution").click()
        wait_until(held.is_set, what="the scene run's first tile")
        page.get_by_text("Running: tiles", exact=False).first.wait_for(timeout=30_000)
        page.get_by_role("tab", name="Tune").click()
        open_stage(page, "sharpness", "strength")
        set_number(page, "strength", 0.8)
        wait_until(lambda: app.session.params == expected_params, what="the tuned strength")
        wait_until(lambda: app.session.run.params.sharpness.strength == 0.8 and not app.context.compute.busy,
                   what="a preview run with it while the scene runs")
        page.get_by_role("tab", name="Export").click()
        page.get_by_role("button", name="Cancel").click()
        wait_until(lambda: app.scene.job.state.phase == "cancelling", what="the cancel request")
        release.set()
        page.get_by_text("Cancelled;", exact=False).first.wait_for(timeout=60_000)
        assert not out.exists()
        app.scene.job.on_change = show

        page.get_by_role("button", name="Apply to full resolution").click()
        page.get_by_text("Wrote ", exact=False).first.wait_for(timeout=300_000)
        state = app.scene.job.state
        assert state.phase == "done" and state.summary["tiles"] == 4 and state.summary["shape"] == [size, size]
        assert state.out == out.resolve()
        page.get_by_text(str(state.out), exact=False).first.wait_for(timeout=10_000)
        assert state.summary["params"] == expected_params.to_dict()

    params_file = expected_params.save(tmp_path / "tuned.toml")
    memory = tmp_path / "in-memory"
    result = subprocess.run(
        [sys.executable, "-m", "radcons.cli", "process", str(folder), "--params", str(params_file), "--out", str(memory),
         "--quiet"], capture_output=True, text=True, timeout=600,
    )
    assert result.returncode == 0, result.stderr
    for key in ("reference", "target"):
        scene = _read(state.out / f"{key}.tif").astype(np.float64)
        reference = _read(memory / f"{key}.tif").astype(np.float64)
        difference = np.abs(scene - reference)
        span = reference.max() - reference.min()
        # rms under 0.5 % of the range, as tests/test_scene.py
        assert np.sqrt(np.mean(difference**2)) < 0.005 * span
        # no seam: the scene-minus-memory difference jumps across tile borders no more often than
        # elsewhere (objects associated from tiled keypoints may get fits a little apart, which
        # shifts whole objects, not tile halves; a 2 DN step along a border fails this)
        across, elsewhere = _difference_jumps(scene - reference, tile)
        assert np.mean(across > 1) <= 2 * np.mean(elsewhere > 1) + 0.01


# ----------------------------------------------------------------------------- the background run

def _options():
    """One worker thread in this process, tiles of 64 px (9 on a 192 px pair)."""
    from radcons.scene import SceneOptions

    return SceneOptions(tile=64, workers=1, processes=False)


@pytest.fixture()
def small_folder(tmp_path) -> Path:
    from demo_data_gen import generate
    from radcons.io import save_pair

    folder = tmp_path / "pair"
    save_pair(generate(size=192, seed=3, scenario="mixed"), folder)
    return folder


def _run_job(folder: Path, out: Path, params, hook=None):
    """Run a SceneJob on ``folder`` to its end, ``hook(job, state)`` on every change;
    returns the job and the states it went through."""
    from inspector.scene_job import SceneJob

    states = []

    def changed(state):
        states.append(state)
        if hook is not None:
            hook(job, state)

    job = SceneJob(changed)
    assert job.start([folder], out, params, _options(), {})
    assert job.wait(300)
    return job, states


def test_a_scene_run_can_be_cancelled_and_runs_one_at_a_time(tmp_path, small_folder):
    from radcons.params import Params

    out = tmp_path / "out"
    out.mkdir()
    (out / "pair.toml").write_text('reference = "old.tif"\n')  # an earlier result
    params = Params.from_preset("radcons")
    second = []

    def hook(job, state):
        if state.phase == "running" and state.step == "tiles" and state.done == 1 and not second:
            second.append(job.start([small_folder], out, params, _options(), {}))  # refused: one at a time
            job.cancel()

    job, states = _run_job(small_folder, out, params, hook)
    assert second == [False]
    assert job.state.phase == "cancelled" and "left as it was" in job.state.message
    assert "cancelling" in [s.phase for s in states]
    assert [p.name for p in out.iterdir()] == ["pair.toml"] and (out / "pair.toml").read_text() == 'reference = "old.tif"\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "pair"]  # nothing half-written beside it


def test_a_stage_scene_mode_refuses_is_reported_by_name(tmp_path, small_folder):
    from inspector.panels.scene import progress_text
    from radcons.params import Params

    job, _ = _run_job(small_folder, tmp_path / "out", Params.from_preset("paper"))  # its uniformity stage is on
    assert job.state.phase == "failed" and "cannot run the uniformity stage" in job.state.message
    assert not (tmp_path / "out").exists()
    assert progress_text(job.state).endswith(f"Failed: {job.state.message}")


def _difference_jumps(difference: np.ndarray, tile: int) -> tuple[np.ndarray, np.ndarray]:
    """Absolute steps of ``difference`` between neighbouring pixels: those across the tile
    borders (rows and columns at multiples of ``tile``), and all others."""
    rows, columns = np.abs(np.diff(difference, axis=0)), np.abs(np.diff(difference, axis=1))
    row_border = np.zeros(rows.shape[0], bool)
    row_border[np.arange(tile, difference.shape[0], tile) - 1] = True
    column_border = np.zeros(columns.shape[1], bool)
    column_border[np.arange(tile, difference.shape[1], tile) - 1] = True
    across = np.concatenate([rows[row_border].ravel(), columns[:, column_border].ravel()])
    elsewhere = np.concatenate([rows[~row_border].ravel(), columns[:, ~column_border].ravel()])
    return across, elsewhere


def test_difference_jumps_see_a_seam():
    """The seam measure of the page test fails a 2 DN step along a tile border."""
    rng = np.random.default_rng(0)
    difference = rng.integers(-1, 2, (256, 256)).astype(float) * (rng.random((256, 256)) < 0.01)
    across, elsewhere = _difference_jumps(difference, 128)
    assert np.mean(across > 1) <= 2 * np.mean(elsewhere > 1) + 0.01
    difference[:128, :128] += 2
    across, elsewhere = _difference_jumps(difference, 128)
    assert np.mean(across > 1) > 2 * np.mean(elsewhere > 1) + 0.01


def test_a_scene_without_overviews_is_streamed_in_bounded_memory(tmp_path):
    """GDAL streams a file without overviews whole for the decimated read; the preview keeps
    its block cache small (:data:`inspector.scene_preview.PREVIEW_CACHE`), in a fresh process
    whose peak resident memory is measured (VmHWM of its own address space: getrusage's
    maxrss would carry over the forking test process's peak through exec)."""
    side = 20000  # 800 MB per image at full resolution
    _sparse_scene(tmp_path / "plain", side, None)
    code = (
        "import re, sys\nfrom pathlib import Path\n"
        "from inspector.scene_preview import read_preview, scene_source\n"
        "folder = Path(sys.argv[1])\n"
        "preview, factor = read_preview(scene_source([folder / 'reference.tif', folder / 'target.tif'], None), 500)\n"
        "peak = int(re.search(r'VmHWM:\\s+(\\d+) kB', Path('/proc/self/status').read_text()).group(1)) * 1024\n"
        "print(preview.shape, factor, peak)\n"
    )
    result = subprocess.run([sys.executable, "-c", code, str(tmp_path / "plain")], capture_output=True, text=True,
                            timeout=300, cwd=Path(__file__).parents[1])
    assert result.returncode == 0, result.stderr
    shape_rows, shape_cols, factor, peak = result.stdout.replace("(", "").replace(")", "").replace(",", " ").split()
    assert (int(shape_rows), int(shape_cols), int(factor)) == (500, 500, 40)
    assert int(peak) < 640 * 2**20  # GDAL's default block cache took it to 958 MiB; capped, 320-430 MiB
