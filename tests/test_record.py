"""Rerun recordings of a run: read the .rrd back and check what a reviewer would see."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rerun as rr
from rerun.chunk import RrdReader

from radcons.errors import InputError, RadconsError
from radcons.evaluate.compare import Comparison, MethodResult
from radcons.evaluate.matching import MatcherParams
from radcons.io import Pair, Raster
from radcons.params import Params
from radcons.pipeline import IMAGE_STAGES, Run
from radcons.record import PREVIEW_MAX_SIDE, default_blueprint, log_run, save_recording, view_recording
from radcons.record.raster import block_mean, display_range
from radcons.results import Association, Matches, ObjectAssociation, ObjectFit, ObjectLabels, StageImages

RERUN = Path(sys.executable).with_name("rerun")
#: rerun's ChannelDatatype codes of the buffers read back here.
DTYPES = {6: np.uint8, 8: np.uint16, 34: np.float32}


# ----------------------------------------------------------------------------- reading back


def rows(path: Path, entity: str) -> list[dict]:
    """Every logged row of ``entity``: index values (stage, tuning_step) and components."""
    out = []
    for chunk in RrdReader(path).stream():
        if chunk.entity_path != entity:
            continue
        batch = chunk.to_record_batch()
        for i in range(batch.num_rows):
            out.append({name: batch.column(name)[i] for name in batch.schema.names})
    return out


def component(row: dict, suffix: str):
    """The value of the row's component whose name ends with ``suffix`` (None if absent)."""
    for name, value in row.items():
        if name.endswith(suffix) and value.is_valid:
            return value
    return None


def image_at(path: Path, entity: str) -> np.ndarray:
    """The single image logged at ``entity``."""
    return image_of(only(path, entity, ":buffer"))


def image_of(row: dict) -> np.ndarray:
    """Decode the image buffer of a DepthImage / SegmentationImage row."""
    fmt = component(row, ":format").as_py()[0]
    buffer = component(row, ":buffer").values[0].values.to_numpy(zero_copy_only=False)
    return np.frombuffer(buffer.tobytes(), DTYPES[fmt["channel_datatype"]]).reshape(fmt["height"], fmt["width"])


def at_stage(path: Path, entity: str) -> dict[int, dict]:
    return {row["stage"].as_py(): row for row in rows(path, entity) if "stage" in row}


def only(path: Path, entity: str, having: str | None = None) -> dict:
    """The single row of ``entity`` (that holds a component whose name ends with ``having``)."""
    found = [row for row in rows(path, entity) if having is None or component(row, having) is not None]
    assert len(found) == 1, f"{entity}: {len(found)} rows with {having!r}"
    return found[0]


def entity_paths(path: Path) -> set[str]:
    return set(RrdReader(path).store().schema().entity_paths())


# ----------------------------------------------------------------------------- a run built by hand

H, W = 24, 32


def tiny_run(shape: tuple[int, int] = (H, W)) -> Run:
    """A small 12-bit run with known arrays: two buildings, matches, fits; every image stage."""
    rng = np.random.default_rng(5)
    ref_raw = rng.integers(10, 4000, shape).astype(np.uint16)
    tgt_raw = rng.integers(10, 4000, shape).astype(np.uint16)
    ref_labels = np.zeros(shape, np.int32)
    tgt_labels = np.zeros(shape, np.int32)
    ref_labels[2:8, 3:10] = 4
    tgt_labels[2:8, 1:8] = 9  # building 4 of the reference, shifted by 2 px
    ref_labels[12:20, 15:25] = 7
    tgt_labels[12:20, 12:22] = 2  # building 7, shifted by 3 px
    tgt_labels[20:23, 26:30] = 5  # only in the target
    truth = np.full(shape, 2.5, np.float32)
    truth[:, :3] = np.nan
    pair = Pair(Raster(ref_raw), Raster(tgt_raw), disparity=truth, name="tiny")
    results: dict = {}
    for index, stage in enumerate(IMAGE_STAGES):
        ref = ref_raw.astype(np.float32) * (1 + 0.1 * index) + 0.25
        tgt = tgt_raw.astype(np.float32) * (1 - 0.05 * index) + 0.5
        ref[0, 0] = np.nan  # an invalid pixel travels through every stage
        results[stage] = StageImages(ref, tgt, {})
    ref_xy = np.array([[5.0, 4.0], [8.0, 6.0], [6.0, 3.0], [20.0, 15.0], [18.0, 13.0], [2.0, 22.0]], np.float32)
    tgt_xy = ref_xy - np.array([[2.0, 0], [2.0, 0], [6.0, 0], [3.0, 0], [3.0, 0], [1.0, 0]], np.float32)
    links = (
        ObjectAssociation(4, 9, "sift", 2.0, np.array([0, 1, 2]), np.array([0, 1])),
        ObjectAssociation(7, 2, "sift", 3.0, np.array([3, 4]), np.array([3, 4])),
    )
    fits = (
        ObjectFit(4, 9, 1.1, 2.0, np.array([10.0, 50.0]), np.array([13.0, 57.0]), np.array([1.0, 0.5]), True),
        ObjectFit(7, 2, 1.0, 0.0, np.array([30.0]), np.array([31.0]), np.array([1.0]), False),
    )
    results["refine"] = StageImages(results["refine"].reference, results["refine"].target, {"fits": fits})
    results["objects"] = ObjectLabels(ref_labels, tgt_labels, "user")
    results["association"] = Association(Matches(ref_xy, tgt_xy), links, ())
    timings = {name: 0.01 * (i + 1) for i, name in enumerate(("objects", "association", *IMAGE_STAGES[1:]))}
    return Run(pair=pair, params=Params(), working_pair=pair, results=results, timings=timings, cached={})


def tiny_comparison(run: Run) -> Comparison:
    shape = run.pair.shape
    ours = np.full(shape, 2.5, np.float32)
    ours[5, 5:9] = np.nan  # failed
    ours[10, 10] = 6.0  # wrong by 3.5 px
    original = np.full(shape, 1.0, np.float32)

    def result(name, disparity, sim, rates):
        return MethodResult(name, sim, disparity, 0.5, rates, 1.2, {"matching": 0.1})

    return Comparison(
        pair_name="tiny",
        methods=(
            result("original", original, {4: 0.6, 7: 0.7}, {4: 0.1, 7: 0.2}),
            result("ours", ours, {4: 0.9, 7: 0.95}, {4: 0.8, 7: 0.85}),
        ),
        object_pairs=((4, 9), (7, 2)),
        disparity_range=(0.0, 8.0),
        matcher=MatcherParams(),
        threshold=1.0,
        has_ground_truth=True,
    )


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> tuple[Path, Run, Comparison]:
    run = tiny_run()
    comparison = tiny_comparison(run)
    path = tmp_path_factory.mktemp("rrd") / "tiny.rrd"
    save_recording(run, path, comparison=comparison)
    return path, run, comparison


# ----------------------------------------------------------------------------- stage images


def test_every_stage_of_both_images_round_trips_exactly(recorded):
    path, run, _ = recorded
    for side in ("reference", "target"):
        logged = at_stage(path, f"/pair/{side}/pixels/image")
        assert sorted(logged) == list(range(len(IMAGE_STAGES)))
        for index, stage in enumerate(IMAGE_STAGES):
            expected = getattr(run.results[stage], side)
            image = image_of(logged[index])
            assert image.shape == (H, W) and image.dtype == np.float32
            np.testing.assert_array_equal(image, expected)  # NaN where NaN, uint16 range kept


def test_both_images_of_a_stage_share_one_grey_range_covering_their_values(recorded):
    path, run, _ = recorded
    logged = {side: at_stage(path, f"/pair/{side}/pixels/image") for side in ("reference", "target")}
    for index, stage in enumerate(IMAGE_STAGES):
        ranges = {side: tuple(component(logged[side][index], ":depth_range").as_py()[0]) for side in logged}
        assert ranges["reference"] == ranges["target"]
        low, high = ranges["reference"]
        values = np.concatenate([image.ravel() for image in run.images(stage)])
        assert low == 0.0 and high == np.nanmax(values) > 255  # 12-bit values, not clipped to 8 bits


def test_stage_label_names_the_stage(recorded):
    path, _, _ = recorded
    labels = at_stage(path, "/pair/target/pixels/stage")
    assert [component(labels[i], ":labels").as_py()[0] for i in range(len(IMAGE_STAGES))] == [
        f"target · {stage}" for stage in IMAGE_STAGES
    ]


def test_invalid_input_pixels_are_marked(recorded):
    path, _, _ = recorded
    mask = image_at(path, "/pair/reference/pixels/nodata")
    assert mask[0, 0] == 1 and mask.sum() == 1
    assert "/pair/target/pixels/nodata" not in entity_paths(path)


# ----------------------------------------------------------------------------- objects and matches


def annotation_labels(path: Path, entity: str) -> dict[int, tuple[str, int]]:
    """Class id -> (label, packed RGBA colour) of the annotation context at ``entity``."""
    context = component(only(path, entity, ":context"), ":context").as_py()[0]
    infos = [entry["class_description"]["info"] for entry in context]
    return {info["id"]: (info["label"], info["color"]) for info in infos}


def test_associated_objects_share_class_and_colour_in_both_images(recorded):
    path, run, _ = recorded
    ref = image_at(path, "/pair/reference/pixels/objects")
    tgt = image_at(path, "/pair/target/pixels/objects")
    labels = annotation_labels(path, "/pair")
    objects = run.objects
    for ref_id, tgt_id in ((4, 9), (7, 2)):
        ref_class = np.unique(ref[objects.reference == ref_id])
        tgt_class = np.unique(tgt[objects.target == tgt_id])
        assert ref_class.size == 1 and tgt_class.tolist() == ref_class.tolist()
        label, _ = labels[int(ref_class[0])]
        assert f"object {ref_id} (target {tgt_id})" in label
    assert "C 0.60 → 0.90 (ours)" in labels[int(ref[objects.reference == 4][0])][0]
    assert (ref[objects.reference == 0] == 0).all() and (tgt[objects.target == 0] == 0).all()
    lonely = np.unique(tgt[objects.target == 5])
    assert lonely.size == 1 and lonely[0] not in np.unique(ref)
    assert "target object 5 (no partner)" in labels[int(lonely[0])][0]
    colours = {labels[int(np.unique(ref[objects.reference == i])[0])][1] for i in (4, 7)}
    assert len(colours) == 2  # distinct pairs, distinct colours


def test_regions_the_height_method_left_out_are_logged_with_their_rule(tmp_path):
    from dataclasses import replace

    from radcons.record.colors import LEFT_OUT_RGB
    from radcons.stages.objects.rules import LEFT_OUT_RULES
    from radcons.stages.objects.regions import HeightObjects

    run = tiny_run()
    labels = run.objects
    codes = np.zeros((H, W), np.uint8)
    codes[14:22, 2:9] = 1  # a grove
    codes[2:6, 20:28] = 5  # a raised lawn
    objects = HeightObjects(labels.reference, labels.target, "segmented", left_out=codes)
    run = replace(run, results={**run.results, "objects": objects})
    path = tmp_path / "left_out.rrd"
    save_recording(run, path)
    np.testing.assert_array_equal(image_at(path, "/pair/reference/pixels/left_out"), codes)
    context = annotation_labels(path, "/pair/reference/pixels/left_out")
    for code in (1, 5):
        red, green, blue = LEFT_OUT_RGB[code]
        assert context[code] == (LEFT_OUT_RULES[code], (red << 24) | (green << 16) | (blue << 8) | 255)
    plain = tmp_path / "plain.rrd"  # objects without left-out regions log none
    save_recording(tiny_run(), plain)
    with pytest.raises(AssertionError):
        only(plain, "/pair/reference/pixels/left_out")


def test_match_lines_join_matching_points_with_the_target_beside(recorded):
    path, run, _ = recorded
    matches = run.association.matches
    shift = component(only(path, "/pair/target"), ":translation").as_py()[0]
    assert shift[0] >= W and shift[1] == 0  # the target is placed right of the reference
    strips = []
    for part in ("invariant", "other"):
        strips += component(only(path, f"/pair/matches/{part}"), ":strips").as_py()
    assert len(strips) == len(matches)
    joined = {(tuple(a), (b[0] - shift[0], b[1])) for a, b in strips}
    expected = {(tuple(r), tuple(t)) for r, t in zip(matches.ref_xy.tolist(), matches.tgt_xy.tolist())}
    assert joined == expected
    invariant = component(only(path, "/pair/matches/invariant"), ":strips").as_py()
    assert {tuple(a) for a, _ in invariant} == {tuple(matches.ref_xy[i]) for i in (0, 1, 3, 4)}
    ends = component(only(path, "/pair/target/keypoints"), ":positions").as_py()
    np.testing.assert_array_equal(np.array(ends), matches.tgt_xy)


def test_fits_plot_points_and_fitted_lines(recorded):
    path, run, _ = recorded
    row = only(path, "/fits/plot/points")
    points = np.array(component(row, ":positions").as_py())
    owners = component(row, ":labels").as_py()
    for fit in run.fits:
        mine = points[[label == f"object {fit.ref_id}" for label in owners]]
        np.testing.assert_array_equal(mine, np.column_stack([fit.x, fit.y]))
    lines = only(path, "/fits/plot/lines")
    strips = component(lines, ":strips").as_py()
    labels = component(lines, ":labels").as_py()
    assert labels[0].startswith("object 4: y = 1.100 x + 2.0") and labels[1].endswith("(not applied)")
    for x, y in strips[0]:
        assert y == pytest.approx(1.1 * x + 2.0)


# ----------------------------------------------------------------------------- disparity review


def test_disparity_maps_truth_and_error_with_failures_marked(recorded):
    path, run, comparison = recorded
    truth = run.pair.disparity
    np.testing.assert_array_equal(image_at(path, "/disparity/truth"), truth)
    for method in comparison.methods:
        base = f"/disparity/{method.name}"
        np.testing.assert_array_equal(image_at(path, f"{base}/map"), method.disparity)
        error = image_at(path, f"{base}/error")
        with np.errstate(invalid="ignore"):
            np.testing.assert_allclose(error, np.abs(method.disparity - truth))
        status = image_at(path, f"{base}/error/status")
        failed = np.isnan(method.disparity) & ~np.isnan(truth)
        unknown = np.isnan(truth)
        assert set(np.unique(status[failed])) <= {2} and (status[unknown] == 1).all()
        assert (status[~failed & ~unknown] == 0).all()
    ours_error = image_at(path, "/disparity/ours/error")
    assert ours_error[10, 10] == pytest.approx(3.5)
    labels = annotation_labels(path, "/disparity")
    assert "failed" in labels[2][0] and "no ground truth" in labels[1][0]


# ----------------------------------------------------------------------------- metrics, summary, blueprint


def tensor(row: dict, suffix: str) -> np.ndarray:
    """Values of a 1-D tensor component (bar heights, bar positions) read back."""
    return np.asarray(component(row, suffix).as_py()[0]["buffer"], np.float64)


def test_per_object_metrics_as_bar_charts(recorded):
    path, _, comparison = recorded
    for entity, field in (("similarity", "similarity"), ("matching_rate", "object_rates")):
        for method in comparison.methods:
            row = only(path, f"/metrics/{entity}/{method.name}")
            np.testing.assert_allclose(tensor(row, ":values"), [getattr(method, field)[i] for i in (4, 7)])
            assert np.round(tensor(row, ":abscissa")).tolist() == [4, 7]  # bars stand at the object ids
    positions = [tensor(only(path, f"/metrics/similarity/{m}"), ":abscissa")[0] for m in ("original", "ours")]
    assert positions[0] != positions[1]  # the methods' bars stand side by side


def test_summary_names_parameters_timings_and_objects(recorded):
    path, run, _ = recorded
    text = component(only(path, "/summary"), ":text").as_py()[0]
    assert text.startswith("# tiny")
    assert "## Parameters" in text and "[uniformity]" in text and "[smoothness]" in text
    assert "## Timings" in text and "smoothness" in text
    object_rows = [line for line in text.splitlines() if line.startswith("| 4 |") or line.startswith("| 7 |")]
    assert len(object_rows) == 2 and "0.900" in object_rows[0] and "1.100" in object_rows[0]


def test_blueprint_is_stored_and_shows_the_review(recorded):
    path, _, _ = recorded
    reader = RrdReader(path)
    (blueprint,) = reader.blueprints()
    assert blueprint.application_id == "radcons"
    origins = set()
    for chunk in reader.stream(store=blueprint):
        batch = chunk.to_record_batch()
        if "ViewBlueprint:space_origin" in batch.schema.names:
            origins.update(o[0] for o in batch.column("ViewBlueprint:space_origin").to_pylist() if o)
    assert {
        "pair/reference", "pair/target", "pair", "fits", "summary",
        "disparity/ours/map", "disparity/truth", "disparity/ours/error",
        "disparity/original/map", "metrics/similarity", "metrics/matching_rate",
    } <= origins  # fmt: skip


def test_rerun_verifies_the_file(recorded):
    path, _, _ = recorded
    result = subprocess.run([str(RERUN), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr


# ----------------------------------------------------------------------------- writing


def test_failed_write_leaves_the_old_file_and_no_partial_file(tmp_path):
    path = tmp_path / "run.rrd"
    path.write_bytes(b"old")
    run = tiny_run()
    comparison = tiny_comparison(run)
    wrong_shape = MethodResult("x", {}, np.zeros((3, 3), np.float32), None, {}, 1.0, {})
    bad = Comparison(**{**comparison.__dict__, "methods": (wrong_shape,)})
    with pytest.raises(InputError, match="differs from the pair"):
        save_recording(run, path, comparison=bad)
    assert path.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.rrd"]


def test_unwritable_destination_is_an_input_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_bytes(b"")
    with pytest.raises(InputError, match="cannot create the folder"):
        save_recording(tiny_run(), blocker / "run.rrd")


def test_recording_without_comparison_or_later_stages(tmp_path):
    run = tiny_run()
    for stage in ("global", "refine", "sharpness", "smoothness"):
        run.results.pop(stage, None)
    path = save_recording(run, tmp_path / "partial.rrd")
    paths = entity_paths(path)
    assert not any(p.startswith("/disparity") or p.startswith("/metrics") for p in paths)
    assert sorted(at_stage(path, "/pair/reference/pixels/image")) == [0, 1]


def block_means(image: np.ndarray, factor: int) -> np.ndarray:
    """Reference: the mean of the finite pixels of every block, one block at a time."""
    rows_, cols = -(-image.shape[0] // factor), -(-image.shape[1] // factor)
    out = np.full((rows_, cols), np.nan, np.float32)
    for i in range(rows_):
        for j in range(cols):
            block = image[i * factor : (i + 1) * factor, j * factor : (j + 1) * factor]
            if np.isfinite(block).any():
                out[i, j] = np.nanmean(block)
    return out


def test_large_images_are_logged_as_scaled_previews(tmp_path):
    shape = (6, PREVIEW_MAX_SIDE + 101)  # longest side just above the limit: factor 2
    run = tiny_run(shape)
    preview = save_recording(run, tmp_path / "preview.rrd")
    original = run.results["original"].reference
    image = image_of(at_stage(preview, "/pair/reference/pixels/image")[0])
    np.testing.assert_allclose(image, block_means(original, 2), rtol=1e-6)
    assert image.shape == (3, (shape[1] + 1) // 2)
    scale = component(only(preview, "/pair/reference/pixels"), ":scale").as_py()[0]
    assert scale[:2] == [2.0, 2.0]  # drawn over the full-resolution pixel grid
    objects = image_at(preview, "/pair/reference/pixels/objects")
    assert objects.shape == image.shape
    full = save_recording(run, tmp_path / "full.rrd", full_resolution=True)
    np.testing.assert_array_equal(image_of(at_stage(full, "/pair/reference/pixels/image")[0]), original)


def test_block_mean_ignores_nan_and_handles_partial_blocks():
    image = np.arange(35, dtype=np.float32).reshape(5, 7)
    image[0, 0] = np.nan
    image[3:5, 6] = np.nan  # a partial block with no finite pixel
    np.testing.assert_allclose(block_mean(image, 3), block_means(image, 3), rtol=1e-6)
    assert np.isnan(block_mean(np.full((4, 4), np.nan, np.float32), 2)).all()


def test_display_range_starts_at_black_and_reaches_the_brightest_value():
    assert display_range([np.array([[3.0, 200.0]], np.float32)]) == (0.0, 200.0)
    low, high = display_range([np.array([[np.nan, 120.0]], np.float32), np.array([[-4.0, 2047.0]], np.float32)])
    assert (low, high) == (-4.0, 2047.0)
    assert display_range([np.full((2, 2), np.nan, np.float32)]) == (0.0, 1.0)


# ----------------------------------------------------------------------------- tuning steps


def test_tuning_steps_log_scalars_over_the_tuning_timeline(tmp_path):
    path = tmp_path / "tuning.rrd"
    run = tiny_run()
    comparison = tiny_comparison(run)
    rec = rr.RecordingStream("radcons", recording_id="tuning-test")
    rec.save(path, default_blueprint=default_blueprint(["original", "ours"], tuning=True))
    for step in range(3):
        run.timings["uniformity"] = 0.5 + step
        log_run(run, rec, comparison, tuning_step=step)
    rec.disconnect()
    seconds = rows(path, "/metrics/tuning/seconds/uniformity")
    assert sorted((r["tuning_step"].as_py(), component(r, ":scalars").as_py()[0]) for r in seconds) == [
        (0, 0.5), (1, 1.5), (2, 2.5),
    ]  # fmt: skip
    assert all("stage" not in r for r in seconds)  # curves live on the tuning timeline only
    similarity = rows(path, "/metrics/tuning/quality/similarity/ours")
    assert [component(r, ":scalars").as_py()[0] for r in similarity if "tuning_step" in r] == [pytest.approx(0.925)] * 3
    images = rows(path, "/pair/reference/pixels/image")
    assert {(r["tuning_step"].as_py(), r["stage"].as_py()) for r in images} == {
        (step, stage) for step in range(3) for stage in range(len(IMAGE_STAGES))
    }
    with pytest.raises(InputError, match="tuning_step"):
        log_run(run, rec, tuning_step=-1)


# ----------------------------------------------------------------------------- viewer input checks


def test_view_rejects_missing_and_non_recording_files(tmp_path):
    with pytest.raises(InputError, match="not found"):
        view_recording(tmp_path / "missing.rrd", port=1)
    other = tmp_path / "image.rrd"
    other.write_bytes(b"\x89PNG\r\n\x1a\n")
    with pytest.raises(InputError, match="not a rerun recording"):
        view_recording(other)


def test_view_rejects_a_port_in_use(recorded):
    import socket

    path, _, _ = recorded
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        with pytest.raises(RadconsError, match="not available"):
            view_recording(path, port=busy.getsockname()[1])


# ----------------------------------------------------------------------------- a real pipeline run


def test_real_pipeline_run_is_recorded(tmp_path):
    from demo_data_gen import generate
    from radcons.workflow import evaluate_pair

    pair = generate(128, 2, "mixed")
    run, comparison = evaluate_pair(pair, ["original", "ours"], Params().with_stage("smoothness", iterations=1))
    path = save_recording(run, tmp_path / "demo.rrd", comparison=comparison)
    for side in ("reference", "target"):
        logged = at_stage(path, f"/pair/{side}/pixels/image")
        assert sorted(logged) == list(range(len(IMAGE_STAGES)))
        for index, stage in enumerate(IMAGE_STAGES):
            np.testing.assert_array_equal(image_of(logged[index]), getattr(run.results[stage], side))
    ref = image_at(path, "/pair/reference/pixels/objects")
    tgt = image_at(path, "/pair/target/pixels/objects")
    for link in run.association.objects:
        (ref_class,) = np.unique(ref[run.objects.reference == link.ref_id])
        assert ref_class > 0
    links_of_target: dict[int, list] = {}
    for link in run.association.objects:
        if link.tgt_id > 0:  # 0: template matching found the place but no target object there
            links_of_target.setdefault(link.tgt_id, []).append(link)
    for tgt_id, links in links_of_target.items():
        # a target object takes the class of its partner; when shared, of the best-supported one
        best = max((link.n_invariant, link.n_matches) for link in links)
        best_refs = [link.ref_id for link in links if (link.n_invariant, link.n_matches) == best]
        classes = {int(np.unique(ref[run.objects.reference == ref_id])[0]) for ref_id in best_refs}
        (tgt_class,) = np.unique(tgt[run.objects.target == tgt_id])
        assert int(tgt_class) in classes
    invariant = {int(i) for link in run.association.objects for i in link.invariant_indices}
    assert len(component(only(path, "/pair/matches/invariant"), ":strips").as_py()) == len(invariant)
    for method in ("original", "ours"):
        np.testing.assert_array_equal(image_at(path, f"/disparity/{method}/map"), comparison.method(method).disparity)
        assert f"/metrics/similarity/{method}" in entity_paths(path)
    result = subprocess.run([str(RERUN), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
