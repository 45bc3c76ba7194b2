"""Scene mode: block power iteration, tiles against the in-memory pipeline, whole-or-nothing output."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import scipy.ndimage

from demo_data_gen import generate
from radcons.errors import InputError, ParamsError, StageError
from radcons.io import load_pair, save_pair, write_raster
from radcons.noise import noise_sigma
from radcons.params import Params
from radcons.pipeline import Pipeline
from radcons.scene import SceneOptions, open_scene_pair, run_scene, scene_stages
from radcons.scene import stats as st
from radcons.scene.pairwide import HEIGHT_NOTE
from radcons.scene.source import SceneImage
from radcons.stages.global_norm.run import GlobalParams
from radcons.summary import output_images

#: One worker thread in this process: no process start-up, monkeypatches reach the tasks.
ONE_THREAD = SceneOptions(tile=128, workers=1, processes=False)


@pytest.fixture(scope="module")
def demo_folder(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("scene") / "pair"
    save_pair(generate(size=512, seed=0, scenario="mixed"), folder)
    return folder


@pytest.fixture(scope="module")
def in_memory(demo_folder) -> tuple[np.ndarray, np.ndarray, dict]:
    pair = load_pair(demo_folder)
    run = Pipeline(Params.from_preset("radcons")).run(pair)
    reference, target, _ = output_images(run, *run.images(), run.working_pair)
    return reference, target, run.results["refine"].info


def _read(path: Path) -> np.ndarray:
    import rasterio

    with rasterio.open(path) as dataset:
        return dataset.read(1)


def _scene_image(tmp_path: Path, data: np.ndarray) -> SceneImage:
    path = write_raster(tmp_path / "image.tif", data)
    return SceneImage(path, data.shape, data.dtype, None, {"crs": None, "transform": (0, 1, 0, 0, 0, 1), "rpcs": None})


def test_block_power_iteration_equals_full_svd(tmp_path):
    rng = np.random.default_rng(3)
    image = (rng.gamma(2.0, 200.0, (300, 220)) + np.linspace(0, 500, 220)).astype(np.float32)
    image[40:45, 10:30] = np.nan
    scene = _scene_image(tmp_path, image)
    blocks = st.row_blocks(scene.shape, pixels=220 * 37)  # 9 blocks, the last one short
    fill = float(np.nanmean(image))

    def gram(v):
        return np.sum([st.block_gram(b, scene, fill, v) for b in blocks], axis=0)

    expected = np.linalg.svd(np.where(np.isnan(image), fill, image).astype(np.float64), compute_uv=False)[0]
    assert len(blocks) == 9
    assert st.sigma_max_by_blocks(gram, 220) == pytest.approx(expected, rel=1e-5)


def test_lanczos_fallback_by_blocks_equals_full_svd(tmp_path):
    # two equal leading singular values: the power iteration cannot settle in 2 steps
    rng = np.random.default_rng(5)
    q1, _ = np.linalg.qr(rng.normal(size=(120, 120)))
    q2, _ = np.linalg.qr(rng.normal(size=(90, 90)))
    values = np.r_[50.0, 49.0, np.linspace(5, 1, 88)]
    image = (q1[:, :90] * values) @ q2.T
    scene = _scene_image(tmp_path, image.astype(np.float32))
    blocks = st.row_blocks(scene.shape, pixels=90 * 25)

    def gram(v):
        return np.sum([st.block_gram(b, scene, 0.0, v) for b in blocks], axis=0)

    def matvec(v):
        return np.concatenate([st.block_matvec(b, scene, 0.0, np.ravel(v)) for b in blocks])

    def rmatvec(u):
        return np.sum([st.block_rmatvec(b, scene, 0.0, np.ravel(u)) for b in blocks], axis=0)

    params = GlobalParams(max_iterations=2)
    power_only = st.sigma_max_by_blocks(gram, 90, params)
    sigma = st.sigma_max_by_blocks(gram, 90, params, matvec=matvec, rmatvec=rmatvec, rows=120)
    assert abs(power_only - 50.0) > 1e-3  # the fallback has something to do
    assert sigma == pytest.approx(np.linalg.svd(image.astype(np.float32), compute_uv=False)[0], rel=1e-5)


def test_histogram_lut_equals_skimage_match_histograms():
    from skimage.exposure import match_histograms

    rng = np.random.default_rng(1)
    source = rng.integers(0, 256, (64, 80)).astype(np.uint8)
    template = rng.integers(100, 2048, (70, 50)).astype(np.uint16)
    stats = [st.block_stats((0, a.shape[0], 0, a.shape[1]), _Array(a)) for a in (source, template)]
    values, mapped = st.histogram_lut(stats[0], stats[1], 0.5)
    expected = match_histograms(source.astype(np.float64), 0.5 * template.astype(np.float64))
    assert np.allclose(np.interp(source, values, mapped), expected)


class _Array:
    """An in-memory stand-in for a SceneImage (what block_stats reads)."""

    def __init__(self, data: np.ndarray) -> None:
        self.data, self.dtype, self.nodata = data, data.dtype, None

    def read(self, window):
        return self.data[window[0] : window[1], window[2] : window[3]]

    def to_float(self, data):
        return data.astype(np.float32)


def _border_mask(shape: tuple[int, int], tile: int) -> np.ndarray:
    mask = np.zeros(shape, bool)
    for edge in range(tile, shape[0], tile):
        mask[edge - 1 : edge + 1, :] = True
    for edge in range(tile, shape[1], tile):
        mask[:, edge - 1 : edge + 1] = True
    return mask


def test_scene_matches_in_memory_without_seams(tmp_path, demo_folder, in_memory):
    result = run_scene([demo_folder], tmp_path / "out", Params.from_preset("radcons"), ONE_THREAD)
    assert result.summary["tiles"] == 16
    # the demo 'mixed' pair's light varies across it: the tiles' correction is applied, as in memory
    done = in_memory[2]
    assert done["light_applied"] and result.summary["scene"]["light_applied"]
    assert result.summary["scene"]["light_spread"] == pytest.approx(done["light_spread"], rel=0.02)
    for key, expected in zip(("reference", "target"), in_memory[:2]):
        scene = _read(tmp_path / "out" / f"{key}.tif").astype(np.float64)
        difference = np.abs(scene - expected)
        span = float(expected.max()) - float(expected.min())
        assert np.sqrt(np.mean(difference**2)) < 0.005 * span
        # no seam: the tile borders differ from the in-memory image no more than the rest
        assert difference[_border_mask(scene.shape, 128)].max() <= 1.0
    manifest = load_pair(tmp_path / "out")
    assert manifest.reference.data.dtype == in_memory[0].dtype and manifest.target.data.dtype == in_memory[1].dtype


def test_noise_aware_background_from_counts_equals_the_stage():
    from radcons.stages.refine.background import added_noise_sigma, noise_aware_histogram_mapping

    rng = np.random.default_rng(4)
    signal = scipy.ndimage.gaussian_filter(rng.normal(size=(200, 240)), 4.0)
    signal = 300.0 * signal / signal.std()
    reference = np.clip(1500.0 + 2.0 * signal + rng.normal(0.0, 40.0, signal.shape), 0, 4095).astype(np.uint16)
    target = np.clip(90.0 + 0.5 * signal + rng.normal(0.0, 1.0, signal.shape), 0, 255).astype(np.uint8)
    lambdas = (0.8, 3.0)
    scaled = reference * np.float32(lambdas[0]), target * np.float32(lambdas[1])
    expected_sigma = added_noise_sigma(*scaled)
    expected = noise_aware_histogram_mapping(*scaled, expected_sigma)
    stats = [st.block_stats((0, a.shape[0], 0, a.shape[1]), _Array(a)) for a in (target, reference)]
    assert stats[1].variance == pytest.approx(float(np.var(reference.astype(np.float64))), rel=1e-9)
    noise = (noise_sigma(target.astype(np.float64)), noise_sigma(reference.astype(np.float64)))
    lut, added = st.noise_aware_lut(stats[0], stats[1], (lambdas[1], lambdas[0]), noise)
    assert expected_sigma > 1.0  # the cleaner target takes noise: the mapping is not plain matching
    assert added == pytest.approx(expected_sigma, rel=1e-4)
    np.testing.assert_allclose(np.interp(target, *lut), expected, atol=1e-3 * np.ptp(expected))


def _noisy_reference_pair(tmp_path: Path, seed: int, share: float) -> Path:
    """The 512 px demo 'mixed' pair, Gaussian noise of ``share`` of its range added to the reference, saved."""
    pair = generate(size=512, seed=0, scenario="mixed")
    data = pair.reference.data
    noisy = data + np.random.default_rng(seed).normal(0.0, share * float(np.ptp(data)), data.shape)
    noisy = np.clip(noisy, np.iinfo(data.dtype).min, np.iinfo(data.dtype).max).round().astype(data.dtype)
    return save_pair(pair.with_images(noisy, pair.target.data), tmp_path / "pair")


def test_scene_with_the_noise_aware_background_matches_in_memory(tmp_path):
    # the demo pair with a noisy reference: the cleaner target takes noise in the mapping
    folder = _noisy_reference_pair(tmp_path, 0, 0.04)
    outputs = {}
    for noise in (False, True):
        params = Params.from_preset("radcons").with_stage("refine", background_noise=noise)
        run = Pipeline(params).run(load_pair(folder))
        outputs[noise] = output_images(run, *run.images(), run.working_pair)[1].astype(np.float64)
    span = float(np.ptp(outputs[True]))
    # the noise-aware background changes the target by more than the tolerance below
    assert np.sqrt(np.mean((outputs[False] - outputs[True]) ** 2)) > 0.01 * span
    params = Params.from_preset("radcons").with_stage("refine", background_noise=True)
    result = run_scene([folder], tmp_path / "out", params, ONE_THREAD)
    assert result.summary["scene"]["background_added_sigma"] > 0.0
    scene = _read(tmp_path / "out" / "target.tif").astype(np.float64)
    assert np.sqrt(np.mean((scene - outputs[True]) ** 2)) < 0.005 * span


def test_objects_from_a_decimated_copy_stay_close(tmp_path, demo_folder, in_memory, monkeypatch):
    # association on the pair reduced twice, D̄m measured again and fits made at full resolution
    monkeypatch.setattr("radcons.scene.pass1.decimation_factor", lambda shape: 2)
    result = run_scene([demo_folder], tmp_path / "out", Params.from_preset("radcons"), ONE_THREAD)
    assert result.summary["scene"]["decimation"] == 2
    for key, expected in zip(("reference", "target"), in_memory[:2]):
        scene = _read(tmp_path / "out" / f"{key}.tif").astype(np.float64)
        span = float(expected.max()) - float(expected.min())
        assert np.sqrt(np.mean((scene - expected) ** 2)) < 0.005 * span


def test_a_scene_without_labels_says_it_used_the_image_only_objects(tmp_path):
    # the radcons preset asks for objects from height, which needs the whole pair's disparity
    pair = generate(size=256, seed=1, scenario="mixed")
    folder = save_pair(dataclasses.replace(pair, reference_objects=None, target_objects=None), tmp_path / "pair")
    result = run_scene([folder], tmp_path / "out", Params.from_preset("radcons"), ONE_THREAD, until="refine")
    scene = result.summary["scene"]
    assert (scene["objects_source"], scene["objects_method"]) == ("segmented", "mbi")
    assert scene["objects_note"] == HEIGHT_NOTE and scene["reference_objects"] > 0
    with_labels = run_scene([save_pair(pair, tmp_path / "labelled")], tmp_path / "out2", Params.from_preset("radcons"),
                            ONE_THREAD, until="refine")
    assert with_labels.summary["scene"]["objects_method"] == "user"
    assert "objects_note" not in with_labels.summary["scene"]


def test_full_resolution_association_of_a_decimated_scene_equals_the_stage(tmp_path, demo_folder, monkeypatch):
    # objects of the decimated copy, associated at full resolution: tiled SIFT and windowed
    # template matching give the stage's associations on the whole image
    monkeypatch.setattr("radcons.scene.pass1.decimation_factor", lambda shape: 2)
    params = Params.from_preset("radcons")
    result = run_scene([demo_folder], tmp_path / "out", params, ONE_THREAD, until="refine")
    expected = Pipeline(params).run(load_pair(demo_folder), until="association").association
    assert result.summary["scene"]["matches"] == len(expected.matches)
    found = {a["ref_id"]: a for a in result.summary["associations"]}
    assert sorted(found) == [obj.ref_id for obj in expected.objects]
    for obj in expected.objects:
        assert (found[obj.ref_id]["tgt_id"], found[obj.ref_id]["method"]) == (obj.tgt_id, obj.method)
        assert found[obj.ref_id]["modal_disparity"] == pytest.approx(obj.modal_disparity, abs=0.01)


def test_percentiles_from_grey_value_counts_equal_numpy():
    from radcons.scene.stats import percentile_of_counts

    values = np.random.default_rng(3).integers(0, 50, 1001)
    counts = np.bincount(values, minlength=50)
    for q in (0.5, 37.0, 99.5):
        assert percentile_of_counts(np.arange(50.0), counts, q) == pytest.approx(np.percentile(values, q))


def test_smoothness_in_scene_mode_stays_close(tmp_path, demo_folder):
    params = Params.from_preset("radcons").with_stage("smoothness", enabled=True, iterations=2)
    pair = load_pair(demo_folder)
    run = Pipeline(params).run(pair)
    expected = output_images(run, *run.images(), run.working_pair)[:2]
    result = run_scene([demo_folder], tmp_path / "out", params, SceneOptions(tile=256, workers=1, processes=False))
    assert "smoothness" in result.summary["stages"]
    for key, reference in zip(("reference", "target"), expected):
        scene = _read(tmp_path / "out" / f"{key}.tif").astype(np.float64)
        span = float(reference.max()) - float(reference.min())
        assert np.sqrt(np.mean((scene - reference) ** 2)) < 0.005 * span


def test_a_tile_failing_twice_stops_the_run_and_leaves_the_old_output(tmp_path, demo_folder, monkeypatch):
    out = tmp_path / "out"
    out.mkdir()
    (out / "pair.toml").write_text('reference = "old.tif"\n')
    (tmp_path / ".out.new-leftover").mkdir()  # what a run killed outright leaves behind
    log = tmp_path / "calls.txt"

    def failing(window, *args):  # runs on a worker: it counts its calls in a file
        with open(log, "a") as handle:
            handle.write(f"{window}\n")
        raise RuntimeError("disk went away")

    monkeypatch.setattr("radcons.scene.writer.output_tile", failing)
    with pytest.raises(StageError, match=r"tile rows \d+-\d+, columns \d+-\d+ failed 2 times: RuntimeError: disk went away"):
        run_scene([demo_folder], out, Params.from_preset("radcons"), ONE_THREAD)
    assert (out / "pair.toml").read_text() == 'reference = "old.tif"\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["calls.txt", "out"]
    lines = log.read_text().splitlines()
    assert max(lines.count(line) for line in lines) == 2  # tried twice, then the run stopped


def test_uniformity_and_unrectified_pairs_are_refused(tmp_path, demo_folder):
    with pytest.raises(ParamsError, match="uniformity"):
        scene_stages(Params.from_preset("paper"))
    assert scene_stages(Params.from_preset("paper"), until="objects") == ()
    with pytest.raises(ParamsError, match="background_smoothing = 1"):
        scene_stages(Params.from_preset("radcons").with_stage("refine", background_smoothing=1.0))
    assert "refine" in scene_stages(Params.from_preset("radcons"))
    image = np.zeros((20, 20), np.uint8)
    a, b = write_raster(tmp_path / "a.tif", image), write_raster(tmp_path / "b.tif", np.zeros((20, 24), np.uint8))
    with pytest.raises(InputError, match="rectified pairs of one size"):
        open_scene_pair([a, b])


def test_memory_refusal_points_to_scene_mode_and_disk_is_checked(tmp_path):
    from radcons import preflight

    image = write_raster(tmp_path / "a.tif", np.zeros((64, 64), np.uint16))
    headers = preflight.headers_of([image, image])
    with pytest.raises(InputError, match="--tiles"):
        preflight.check_memory(headers, [image, image], available=1000)
    assert preflight.needs_scene(headers, 1000) and not preflight.needs_scene(headers, 1 << 30)
    assert preflight.scene_output_bytes(headers) >= 2 * 64 * 64 * 2 * 4 // 3
    assert preflight.parse_size("1.5G") == 3 << 29 and preflight.parse_size("512MiB") == 512 << 20
    with pytest.raises(ParamsError):
        preflight.parse_size("lots")


def test_run_scene_checks_the_disk_and_can_be_cancelled(tmp_path, demo_folder, monkeypatch):
    import shutil

    with monkeypatch.context() as patch:
        patch.setattr("radcons.preflight.shutil.disk_usage", lambda path: shutil._ntuple_diskusage(1, 1, 1000))
        with pytest.raises(InputError, match="MiB free on its disk"):
            run_scene([demo_folder], tmp_path / "out", Params.from_preset("radcons"), ONE_THREAD)

    class Stop(Exception):
        pass

    def progress(step, done, total):
        if step == "tiles" and done == 3:
            raise Stop

    with pytest.raises(Stop):
        run_scene([demo_folder], tmp_path / "out", Params.from_preset("radcons"), ONE_THREAD, progress=progress)
    assert not any(tmp_path.iterdir())


def test_local_workers_limit_their_native_thread_pools():
    import os

    import cv2

    from radcons.scene.cluster import SceneCluster

    with SceneCluster(workers=1, threads=3) as cluster:
        cv2_threads = cluster.client.run(cv2.getNumThreads)
        environ = cluster.client.run(lambda: {k: os.environ.get(k) for k in ("OMP_NUM_THREADS", "NUMBA_NUM_THREADS")})
        nthreads = cluster.client.nthreads()
    assert list(cv2_threads.values()) == [3]
    assert list(environ.values()) == [{"OMP_NUM_THREADS": "3", "NUMBA_NUM_THREADS": "3"}]
    assert list(nthreads.values()) == [3]


def test_blank_scene_images_are_refused_from_a_sample(tmp_path):
    from radcons import preflight

    rng = np.random.default_rng(0)
    textured = write_raster(tmp_path / "textured.tif", rng.integers(1, 900, (300, 300)).astype(np.uint16))
    preflight.check_scene_content(textured, (300, 300))
    nan = write_raster(tmp_path / "nan.tif", np.full((300, 300), np.nan, np.float32))
    with pytest.raises(InputError, match="nan.tif: the image holds no valid pixel"):
        preflight.check_scene_content(nan, (300, 300))
    nodata = write_raster(tmp_path / "nodata.tif", np.full((300, 300), 7, np.uint16))
    with pytest.raises(InputError, match="no valid pixel"):
        preflight.check_scene_content(nodata, (300, 300), nodata=7.0)
    with pytest.raises(InputError, match=r"nodata.tif: the image is constant \(7 at all"):
        preflight.check_scene_content(nodata, (300, 300))



def test_a_blank_scene_is_refused_before_its_rows_are_levelled(tmp_path, monkeypatch):
    # levelling the rows reads windows of both images and matches them: a blank pair must not get there
    from radcons.scene import run as scene_run

    def levelling(pair):
        raise AssertionError("the rows were levelled before the content was checked")

    monkeypatch.setattr(scene_run, "level_scene_rows", levelling)
    rng = np.random.default_rng(0)
    textured = write_raster(tmp_path / "textured.tif", rng.integers(1, 900, (300, 300)).astype(np.uint16))
    blank = write_raster(tmp_path / "blank.tif", np.zeros((300, 300), np.uint16))
    with pytest.raises(InputError, match=r"blank.tif: the image is constant \(0 at all"):
        run_scene([textured, blank], tmp_path / "out", Params.from_preset("radcons"), ONE_THREAD)
    assert not (tmp_path / "out").exists()


class _Serial:
    """A stand-in for SceneCluster that runs the tasks here, in order."""

    def map(self, func, items, *shared, what="task"):
        return [func(item, *shared) for item in items]

    def submit(self, func, items, *shared):
        return self.map(func, items, *shared)

    def scatter(self, value):
        return value


def test_tiled_keypoints_are_the_stage_strongest(demo_folder, monkeypatch):
    # tiles of 256 px with their margins keep the keypoints the stage keeps on the whole image,
    # max_features per sample of tiles
    import dataclasses

    from radcons.scene import features
    from radcons.scene.pairwide import SceneLabels
    from radcons.scene.pass1 import sample_windows
    from radcons.stages.association.params import AssociationParams
    from radcons.stages.association.run import _detect

    monkeypatch.setattr(features, "FEATURE_TILE", 256)
    pair = open_scene_pair([demo_folder])
    labels = SceneLabels(pair.shape, pair.reference_objects, pair.target_objects)
    params = dataclasses.replace(AssociationParams(), max_features=300)
    image = pair.reference.read_float((0, pair.shape[0], 0, pair.shape[1]))
    levels = tuple(np.percentile(image, [0.5, 99.5]))
    tiles = sample_windows(pair.shape, 1 << 20, 256)
    expected, _ = _detect(image, params)
    # the whole scene as the threshold's sample: the same keypoints
    kept = features.Keypoints.join(
        features._strongest(_Serial(), pair.reference, labels, "reference", levels, params, tiles, tiles)
    )
    distance = np.hypot(*(expected[:, None, :] - kept.xy[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    assert abs(len(kept) - len(expected)) <= 0.01 * len(expected) and (distance < 0.5).mean() > 0.98
    # a quarter of it: max_features per quarter, about four times as many, the stage's among them
    kept = features.Keypoints.join(
        features._strongest(_Serial(), pair.reference, labels, "reference", levels, params, tiles, tiles[:1])
    )
    distance = np.hypot(*(expected[:, None, :] - kept.xy[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    assert 2.5 * len(expected) < len(kept) < 5.5 * len(expected) and (distance < 0.5).mean() > 0.98


def test_a_local_cluster_leaves_this_process_environment_as_it_was(monkeypatch):
    """Dask's nanny writes the workers' thread variables into the spawning process; the
    cluster puts them back (numba refuses a thread count changed after its threads started)."""
    import os

    from radcons.scene.cluster import THREAD_VARIABLES, SceneCluster

    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    monkeypatch.delenv("NUMBA_NUM_THREADS", raising=False)
    with SceneCluster(workers=1, threads=1) as cluster:
        assert cluster.client.run(lambda: os.environ.get("NUMBA_NUM_THREADS")) != {}
        assert os.environ.get("OMP_NUM_THREADS") == "2" and "NUMBA_NUM_THREADS" not in os.environ
    assert os.environ.get("OMP_NUM_THREADS") == "2" and "NUMBA_NUM_THREADS" not in os.environ
    assert set(THREAD_VARIABLES) >= {"OMP_NUM_THREADS", "NUMBA_NUM_THREADS"}


def _total_plus(item: int, shared: tuple[np.ndarray, str]) -> float:
    return item + float(shared[0].sum())


def test_equal_quantities_scattered_again_reach_their_tasks():
    """The pass sends equal quantities twice in a row when a stage changes nothing (no blur
    to match): the second set of tasks must still find them (under a key from the value's
    hash, about half of such rounds failed with "lost dependencies")."""
    from radcons.scene.cluster import SceneCluster

    with SceneCluster(workers=1, processes=False) as cluster:
        for _ in range(40):
            shared = (np.ones(100), "none")
            assert cluster.map(_total_plus, [0, 1, 2], cluster.scatter(shared)) == [100.0, 101.0, 102.0]


def test_matching_strip_by_strip_equals_matching_the_whole_scene(demo_folder, monkeypatch):
    # strips of 128 rows, each with its neighbours' keypoints, against the stage's matching
    # of all keypoints at once
    from radcons.scene import features
    from radcons.scene.pairwide import SceneLabels
    from radcons.scene.tiles import tile_grid
    from radcons.stages.association.params import AssociationParams
    from radcons.stages.association.run import _match_rows

    monkeypatch.setattr(features, "FEATURE_TILE", 128)
    pair = open_scene_pair([demo_folder])
    labels = SceneLabels(pair.shape, pair.reference_objects, pair.target_objects)
    params = AssociationParams()
    levels = tuple(
        tuple(np.percentile(image.read_float((0, pair.shape[0], 0, pair.shape[1])), [0.5, 99.5]))
        for image in (pair.reference, pair.target)
    )
    tiles = tile_grid(pair.shape, 128)
    matches, ref_labels, tgt_labels = features.scene_matches(_Serial(), pair, labels, levels, params, tiles)
    ref, tgt = (
        features.Keypoints.join(features._strongest(_Serial(), image, labels, which, level, params, tiles, tiles))
        for image, which, level in ((pair.reference, "reference", levels[0]), (pair.target, "target", levels[1]))
    )
    ref_idx, tgt_idx = _match_rows(ref.xy, ref.descriptors, tgt.xy, tgt.descriptors, params)
    assert len(ref_idx) > 50
    # matches whose two points lie in different strips are there too
    assert np.any(np.floor(ref.xy[ref_idx, 1] / 128) != np.floor(tgt.xy[tgt_idx, 1] / 128))
    np.testing.assert_array_equal(matches.ref_xy, ref.xy[ref_idx])
    np.testing.assert_array_equal(matches.tgt_xy, tgt.xy[tgt_idx])
    np.testing.assert_array_equal(ref_labels, ref.labels[ref_idx])
    np.testing.assert_array_equal(tgt_labels, tgt.labels[tgt_idx])


def test_scene_output_keeps_the_georeferencing_and_has_overviews(tmp_path, demo_folder):
    import rasterio
    import tomli_w

    crs = rasterio.crs.CRS.from_epsg(32637)
    transform = rasterio.transform.from_origin(500000.0, 4100000.0, 0.5, 0.5)
    pair = load_pair(demo_folder)
    folder = tmp_path / "geo"
    folder.mkdir()
    for key, raster in (("reference", pair.reference), ("target", pair.target)):
        data = raster.data
        profile = dict(driver="GTiff", height=data.shape[0], width=data.shape[1], count=1, dtype=data.dtype.name,
                       crs=crs, transform=transform, nodata=0)
        with rasterio.open(folder / f"{key}.tif", "w", **profile) as dataset:
            dataset.write(data, 1)
    (folder / "pair.toml").write_text(tomli_w.dumps({"name": "geo", "reference": "reference.tif", "target": "target.tif",
                                                    "rectified": True}))
    run_scene([folder], tmp_path / "out", Params.from_preset("radcons"), ONE_THREAD)
    for key in ("reference", "target"):
        with rasterio.open(tmp_path / "out" / f"{key}.tif") as dataset:
            assert dataset.crs == crs and dataset.transform == transform and dataset.nodata == 0
            assert dataset.overviews(1) == [2]  # 512 px: one level of 256 px
            full = dataset.read(1).astype(np.float64)
            half = dataset.read(1, out_shape=(256, 256)).astype(np.float64)
        # the overview is the 2 x 2 mean of the written image's valid (non-zero) pixels
        valid = (full != 0).reshape(256, 2, 256, 2).sum(axis=(1, 3))
        total = full.reshape(256, 2, 256, 2).sum(axis=(1, 3))
        expected = np.where(valid > 0, total / np.maximum(valid, 1), 0.0)
        np.testing.assert_allclose(half, expected, atol=0.5)
    assert not list((tmp_path / "out").glob(".*"))  # no scratch file left beside the outputs


def test_colour_scenes_are_read_as_their_luminance_like_in_memory(tmp_path, demo_folder):
    # an RGB pair in scene mode gives what its luminance, computed here with the BT.601
    # weights, gives as a one-band pair
    import rasterio
    import tomli_w

    pair = load_pair(demo_folder)
    folders = {kind: tmp_path / kind for kind in ("rgb", "grey")}
    for kind, folder in folders.items():
        folder.mkdir()
        (folder / "pair.toml").write_text(tomli_w.dumps({"name": kind, "reference": "reference.tif",
                                                        "target": "target.tif", "rectified": True}))
    for key, raster in (("reference", pair.reference), ("target", pair.target)):
        grey = raster.data.astype(np.float64)
        rgb = np.stack([grey, np.clip(grey * 1.2 + 30, 0, 65535), grey * 0.6]).round().astype(np.uint16)
        weights = np.array([0.299, 0.587, 0.114], np.float32)
        luminance = np.rint(np.tensordot(weights, rgb.astype(np.float32), axes=1)).astype(np.uint16)
        for kind, data in (("rgb", rgb), ("grey", luminance[None])):
            profile = dict(driver="GTiff", height=grey.shape[0], width=grey.shape[1], count=len(data), dtype="uint16")
            if kind == "rgb":
                profile["photometric"] = "RGB"
            with rasterio.open(folders[kind] / f"{key}.tif", "w", **profile) as dataset:
                dataset.write(data)
    outputs = {kind: run_scene([folder], tmp_path / f"{kind}_out", Params.from_preset("radcons"), ONE_THREAD)
               for kind, folder in folders.items()}
    assert outputs["rgb"].summary["associations"] == outputs["grey"].summary["associations"]
    for key in ("reference", "target"):
        np.testing.assert_array_equal(_read(tmp_path / "rgb_out" / f"{key}.tif"), _read(tmp_path / "grey_out" / f"{key}.tif"))
    # the band asked for, as it is
    one = open_scene_pair([folders["rgb"]], band=2)
    assert one.reference.band == 2 and one.reference.read((0, 4, 0, 4)).ndim == 2


def test_scene_noise_matching_smooths_the_noisier_image_as_in_memory(tmp_path):
    # the demo pair (a noisier 8-bit target, stretched by the global stage) with noise added
    # to the reference too: the sharpness stage smooths the noisier image to the other's noise
    folder = _noisy_reference_pair(tmp_path, 1, 0.01)
    outputs = {}
    for noise in ("keep", "cleaner"):
        run = Pipeline(Params.from_preset("radcons").with_stage("sharpness", noise=noise)).run(load_pair(folder))
        outputs[noise] = [image.astype(np.float64) for image in output_images(run, *run.images(), run.working_pair)[:2]]
    info = run.results["sharpness"].info
    assert info["denoised"] != "none" and info["denoise_sigma"] > 0.0
    index = ("reference", "target").index(info["denoised"])
    params = Params.from_preset("radcons").with_stage("sharpness", noise="cleaner")
    result = run_scene([folder], tmp_path / "out", params, ONE_THREAD)
    signed = info["denoise_sigma"] if index == 1 else -info["denoise_sigma"]
    assert result.summary["scene"]["denoise"] == pytest.approx(signed, abs=0.02)
    for key, kept, cleaner in zip(("reference", "target"), outputs["keep"], outputs["cleaner"]):
        span = float(np.ptp(cleaner))
        scene = _read(tmp_path / "out" / f"{key}.tif").astype(np.float64)
        assert np.sqrt(np.mean((scene - cleaner) ** 2)) < 0.005 * span
        if key == info["denoised"]:  # the smoothing moves that image by more than the tolerance
            assert np.sqrt(np.mean((kept - cleaner) ** 2)) > 0.01 * span
