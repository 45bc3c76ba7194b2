"""The inspector's parts without a browser: allowed roots, the worker, drawing, previews,
generated controls, the object table, and the app's loading and validation paths."""

from __future__ import annotations

import dataclasses
import threading
import time
from types import SimpleNamespace

import cv2
import numpy as np
import pytest
import scipy.ndimage

from inspector import render
from inspector.objects import object_rows, reference_id_at, table_markdown
from inspector.paths import AllowedRoots, pair_sources
from inspector.state import centred_region, preview_pair, region_pair
from inspector.widgets import FieldSpec, field_spec
from inspector.worker import LatestWorker
from radcons.errors import InputError, ParamsError
from radcons.param_spec import describe, param, spec_of
from radcons.stages import STAGE_LIST
from radcons.io import Pair, Raster
from radcons.results import Association, Matches, ObjectAssociation, ObjectFit, ObjectLabels

# ----------------------------------------------------------------------------- paths


@pytest.fixture()
def tree(tmp_path):
    root = tmp_path / "root"
    (root / "pairs" / "a").mkdir(parents=True)
    (root / "pairs" / "a" / "pair.toml").write_text('reference = "l.png"\ntarget = "r.png"\n')
    outside = tmp_path / "outside"
    (outside / "b").mkdir(parents=True)
    (outside / "b" / "pair.toml").write_text('reference = "l.png"\ntarget = "r.png"\n')
    (root / "escape").symlink_to(outside, target_is_directory=True)
    (root / "inner").symlink_to(root / "pairs", target_is_directory=True)
    return root, outside


def test_paths_inside_the_roots_resolve(tree):
    root, _ = tree
    roots = AllowedRoots([root])
    assert roots.check(root / "pairs" / "a") == (root / "pairs" / "a").resolve()
    assert roots.check(root / "inner" / "a") == (root / "pairs" / "a").resolve()
    assert roots.check(root) == root.resolve()


@pytest.mark.parametrize("relative", ["../outside/b", "escape/b", "escape", "pairs/../../outside"])
def test_paths_leaving_the_roots_are_refused(tree, relative):
    root, _ = tree
    with pytest.raises(InputError, match="outside the folders"):
        AllowedRoots([root]).check(root / relative)


def test_missing_paths_and_single_files(tree, tmp_path):
    root, outside = tree
    allowed = outside / "b" / "pair.toml"
    roots = AllowedRoots([root], files=[allowed])
    assert roots.check(allowed) == allowed.resolve()
    with pytest.raises(InputError, match="outside"):
        roots.check(outside / "b")
    with pytest.raises(InputError, match="no such file"):
        roots.check(root / "nothing")


def test_discovered_pairs_stay_inside(tree):
    root, _ = tree
    found = AllowedRoots([root]).discover_pairs()
    assert found == [(root / "pairs" / "a").resolve()]


def test_pair_sources_take_images_in_twos(tmp_path):
    images = []
    for name in ("l.png", "r.png", "x.png"):
        cv2.imwrite(str(tmp_path / name), np.zeros((4, 4), np.uint8))
        images.append(tmp_path / name)
    roots, sources = pair_sources(images[:2], [])
    assert [s.files for s in sources] == [(images[0].resolve(), images[1].resolve())]
    assert roots.check(images[0])
    with pytest.raises(InputError):
        roots.check(images[2])
    with pytest.raises(InputError, match="in twos"):
        pair_sources(images, [])


# ----------------------------------------------------------------------------- worker


def test_worker_runs_the_newest_request_and_drops_stale_results():
    worker = LatestWorker("test")
    gate = threading.Event()
    computed, delivered = [], []

    def job(value):
        def compute(j):
            if value == 0:
                gate.wait(10)
            computed.append(value)
            return value

        return compute

    try:
        worker.submit(job(0), lambda j, r: delivered.append(r))
        time.sleep(0.05)  # let the first job start and block
        generations = [worker.submit(job(v), lambda j, r: delivered.append(r)) for v in range(1, 11)]
        gate.set()
        assert worker.wait_idle(10)
        assert computed == [0, 10]  # the nine in between were replaced before they started
        assert delivered == [10]  # the first finished after newer requests: dropped
        assert generations == list(range(2, 12)) and worker.generation == 11
    finally:
        worker.stop()


def test_worker_reports_errors():
    worker = LatestWorker("test")
    errors = []
    try:
        worker.submit(lambda j: 1 / 0, fail=lambda j, exc: errors.append(type(exc)))
        assert worker.wait_idle(10)
        assert errors == [ZeroDivisionError]
    finally:
        worker.stop()


# ----------------------------------------------------------------------------- drawing


def test_display_uses_one_range_for_both_images():
    rng = np.random.default_rng(1)
    dark = rng.uniform(100, 200, (64, 64)).astype(np.float32)
    bright = rng.uniform(300, 900, (64, 64)).astype(np.float32)
    low, high = render.display_range(dark, bright, percentiles=(0, 100))
    assert (low, high) == (float(dark.min()), float(bright.max()))
    shown = [render.to_display(image, (low, high)) for image in (dark, bright)]
    expected = [np.clip(np.floor((im - low) / (high - low) * 255 + 0.5), 0, 255) for im in (dark, bright)]
    for got, want in zip(shown, expected):
        assert np.abs(got.astype(int) - want).max() <= 1
    assert shown[0].mean() < shown[1].mean() - 50  # the brightness difference stays visible


def test_error_map_colours():
    truth = np.array([[1.0, 1.0, 1.0, np.nan]], np.float32)
    disparity = np.array([[1.5, 3.0, np.nan, 2.0]], np.float32)
    colours = render.error_map(disparity, truth)
    assert [tuple(c) for c in colours[0]] == [render.CORRECT_RGB, render.WRONG_RGB, render.FAILED_RGB, (0, 0, 0)]


def test_outline_is_the_object_border():
    labels = np.zeros((20, 20), np.int32)
    labels[4:12, 5:15] = 3
    mask = labels == 3
    expected = mask & ~scipy.ndimage.binary_erosion(mask, np.ones((3, 3)))
    np.testing.assert_array_equal(render.outline_mask(labels), expected)


def test_overlay_draws_only_what_is_asked():
    labels = np.zeros((40, 40), np.int32)
    labels[10:30, 10:30] = 1
    assert not render.draw_overlay((40, 40), labels=labels, outlines=False, names={}).any()
    ids = render.draw_overlay((40, 40), labels=labels, outlines=False)  # names=None: each object's id
    assert ids[:, :, 3].any() and not ids[labels == 0].any()
    outlined = render.draw_overlay((40, 40), labels=labels, colours={1: (10, 200, 30)}, names={})
    edge = render.outline_mask(labels)
    assert (outlined[edge] == (10, 200, 30, 255)).all() and not outlined[~edge].any()
    change = np.zeros((40, 40), bool)
    change[:5] = True
    assert (render.draw_overlay((40, 40), change=change)[:5, :, 3] > 0).all()


def test_swipe_and_point_cloud():
    left = np.zeros((10, 40, 3), np.uint8)
    right = np.full((10, 40, 3), 200, np.uint8)
    out = render.swipe_composite(left, right, 0.25)
    assert (out[:, :9] == 0).all() and (out[:, 12:] == 200).all()
    disparity = np.full((30, 60), 5.0, np.float32)
    disparity[10:20, 20:40] = 9.0
    disparity[0, 0] = np.nan
    points, rgb = render.point_cloud(disparity, np.full((30, 60), 7, np.uint8), height_scale=2.0)
    assert len(points) == 30 * 60 - 1 and (rgb == 7).all()
    heights = np.unique(np.round(points[:, 2] * 60 / 2.0, 4))
    np.testing.assert_allclose(heights, [0.0, 4.0])  # relative to the median disparity, in px


# ----------------------------------------------------------------------------- previews


def _pair(height=96, width=160, disparity=8.0) -> Pair:
    rng = np.random.default_rng(3)
    reference = rng.integers(0, 4000, (height, width)).astype(np.uint16)
    target = rng.integers(0, 4000, (height, width)).astype(np.uint16)
    labels = np.zeros((height, width), np.int32)
    labels[10:40, 20:60] = 1
    return Pair(
        Raster(reference), Raster(target), disparity=np.full((height, width), disparity, np.float32),
        reference_objects=labels, target_objects=labels.copy(), change_mask=labels > 0,
    )


def test_preview_is_a_block_mean_and_scales_the_disparity():
    pair = _pair()
    preview, factor = preview_pair(pair, 80)
    assert factor == 2 and preview.shape == (48, 80)
    block = pair.reference.data.astype(np.float64).reshape(48, 2, 80, 2).mean(axis=(1, 3))
    np.testing.assert_allclose(preview.reference.data, block, rtol=1e-5)
    np.testing.assert_allclose(preview.disparity, 4.0)
    assert preview.reference_objects.shape == (48, 80) and preview.reference_objects[10, 15] == 1
    assert preview_pair(pair, 512) == (pair, 1)


def test_preview_averages_the_valid_pixels_of_mostly_valid_blocks():
    pair = _pair(32, 32)
    pair.reference.nodata = 0
    pair.reference.data[:2, :2] = [[0, 50], [100, 150]]
    pair.reference.data[:2, 2:4] = [[0, 0], [0, 100]]
    preview, _ = preview_pair(pair, 16)
    assert preview.reference.data[0, 0] == pytest.approx(100.0)  # three valid of four
    assert np.isnan(preview.reference.data[0, 1])  # one valid of four
    assert preview.reference.nodata is None


def test_region_is_the_same_window_of_everything():
    pair = _pair()
    box = centred_region(pair.shape, (150, 5), 64)
    assert box == (96, 0, 64, 64)
    region = region_pair(pair, box)
    np.testing.assert_array_equal(region.target.data, pair.target.data[0:64, 96:160])
    np.testing.assert_array_equal(region.reference_objects, pair.reference_objects[0:64, 96:160])
    with pytest.raises(InputError):
        region_pair(pair, (150, 0, 64, 64))


# ----------------------------------------------------------------------------- controls


@dataclasses.dataclass(frozen=True)
class _Params:
    """Example parameters, declared as the stages declare theirs."""

    mode: str = param("a", "How to do it.", choices=("a", "b"), basic=True)
    flag: bool = param(True, "Whether to.")
    count: int = param(3, "A count.", range=(0, None))
    weight: float = param(0.25, "A weight.", range=(0.0, 1.0), step=0.05)
    big: float = param(40.0, "A length.", unit="m", range=(0.0, None))
    maybe: int | None = param(None, "Automatic when None.")


def test_controls_follow_the_declarations():
    specs = {f.name: field_spec(spec_of(f), f.default) for f in dataclasses.fields(_Params)}
    assert specs["mode"] == FieldSpec("dropdown", choices=("a", "b"))
    assert specs["flag"].kind == "checkbox"
    assert specs["count"] == FieldSpec("number", 0, None, 1)
    assert specs["weight"] == FieldSpec("slider", 0.0, 1.0, 0.05)
    assert specs["big"].kind == "number" and specs["big"].step == 1.0
    assert specs["maybe"] == FieldSpec("text", optional=True)
    assert describe(spec_of(dataclasses.fields(_Params)[4])) == "A length. ([0, inf] m)"


@pytest.mark.parametrize("stage", STAGE_LIST, ids=lambda s: s.name)
def test_every_control_offers_only_what_its_stage_accepts(stage):
    """Both ends of every slider, every choice, and no value one step outside the range."""
    defaults = stage.params()
    for field in dataclasses.fields(stage.params):
        spec = spec_of(field)
        assert spec.help.strip(), f"[{stage.name}] {field.name} has no help"
        default = getattr(defaults, field.name)
        control = field_spec(spec, default)
        kind = type(default)
        if control.kind == "dropdown":
            for choice in control.choices:
                stage.params(**{field.name: choice})
            with pytest.raises(ParamsError):
                stage.params(**{field.name: "no such choice"})
        elif control.kind == "slider":
            for end in (control.minimum, control.maximum):
                _accepts_alone(stage, field.name, kind(end))
            with pytest.raises(ParamsError):
                stage.params(**{field.name: kind(control.maximum + control.step)})


def _accepts_alone(stage, name, value):
    """The stage takes ``value``, unless only a cross-field rule (not the range) refuses it."""
    try:
        stage.params(**{name: value})
    except ParamsError as exc:
        assert "must be in" not in exc.reason and "must be one of" not in exc.reason, exc.reason


# ----------------------------------------------------------------------------- objects


def _run_like():
    labels_ref = np.zeros((20, 30), np.int32)
    labels_ref[2:8, 2:10] = 1
    labels_ref[10:18, 12:20] = 2
    labels_tgt = np.zeros((20, 30), np.int32)
    labels_tgt[10:18, 8:16] = 5
    matches = Matches(np.array([[14, 12], [15, 14], [16, 15]], np.float32), np.array([[10, 12], [11, 14], [12, 15]], np.float32))
    assoc = Association(matches, (ObjectAssociation(2, 5, "sift", 4.0, np.arange(3), np.arange(2)),), (1,))
    fit = ObjectFit(2, 5, 1.5, -3.0, np.ones(2), np.ones(2), np.ones(2), True)
    return SimpleNamespace(
        objects=ObjectLabels(labels_ref, labels_tgt, "user"), association=assoc, fits=(fit,),
    )


def test_object_rows_and_picking():
    run = _run_like()
    rows = object_rows(run)
    assert [(r.ref_id, r.tgt_id, r.matches, r.invariant, r.gain) for r in rows] == [(1, None, 0, 0, pytest.approx(np.nan, nan_ok=True)), (2, 5, 3, 2, 1.5)]
    assert reference_id_at(run, "reference", 3, 4) == 1
    assert reference_id_at(run, "target", 9.5, 11.2) == 2  # target object 5 is associated with 2
    assert reference_id_at(run, "target", 0, 0) is None
    assert reference_id_at(run, "reference", 100, 4) is None


def test_object_table_marks_fits_limited_by_clipped_pixels():
    run = _run_like()
    text = table_markdown(object_rows(run), None, has_truth=False, reviewed=False)
    assert "| 1.500 / -3.0 |" in text
    run.fits = (dataclasses.replace(run.fits[0], gain=1.0, offset=-40.0, clipped=9, note="offset only: 9 of 10 points on clipped pixels"),)
    text = table_markdown(object_rows(run), None, has_truth=False, reviewed=False)
    assert "| 1.000 / -40.0ᶜ |" in text and "ᶜ clipped pixels" in text
    run.fits = (dataclasses.replace(run.fits[0], applied=False, clipped=0, note="too few points (2, min_points 3)"),)
    assert "| 1.000 / -40.0* |" in table_markdown(object_rows(run), None, has_truth=False, reviewed=False)


# ----------------------------------------------------------------------------- app


@pytest.fixture()
def app(tmp_path):
    from inspector.app import InspectorApp

    app = InspectorApp(port=0, demo_size=128, record_dir=tmp_path / "rec", max_upload_mib=1, preset="paper").start()
    try:
        assert app.wait_idle(120)
        yield app
    finally:
        app.stop()


def test_presets_set_every_stage(app):
    from radcons.params import Params

    app.tuning.preset.value = "radcons"
    assert app.session.params == Params.from_preset("radcons")
    assert app.tuning.stages["uniformity"].enabled.value is False
    refine = app.tuning.stages["refine"]
    assert refine.handles["points"].value == Params.from_preset("radcons").refine.points
    app.tuning.on_param_change("refine", {"min_points": 9}, None)
    app.tuning.on_stage_reset("refine", None)  # back to the preset's values, not the paper's
    assert app.session.params == Params.from_preset("radcons")
    assert app.wait_idle(120) and app.displayed.params == Params.from_preset("radcons")


def test_stage_reset_restores_the_defaults(app):
    from radcons.params import Params

    app.tuning.on_param_change("uniformity", {"mu": 0.3}, None)
    app.tuning.on_param_change("uniformity", {"enabled": False}, None)
    assert not app.session.params.enabled("uniformity")
    app.tuning.on_stage_reset("uniformity", None)
    assert app.session.params == Params()
    assert app.tuning.stages["uniformity"].handles["mu"].value == pytest.approx(0.1)
    assert app.tuning.stages["uniformity"].enabled.value is True


def test_live_runs_stop_just_before_smoothness():
    from inspector.app import LIVE_UNTIL
    from radcons.params import STAGES

    assert STAGES[STAGES.index(LIVE_UNTIL) + 1] == "smoothness"


def test_smoothness_runs_on_request_only(app):
    from inspector.app import LIVE_UNTIL
    from radcons.pipeline import Pipeline

    assert "smoothness" not in app.session.run.results and app.pipeline.calls["smoothness"] == 0
    app.view.stage.value = "smoothness"
    assert app.wait_idle(60)
    assert app.displayed.view == LIVE_UNTIL  # not run yet: the last stage reached is shown
    app.tuning.on_run_smoothness(SimpleNamespace(client=None))
    assert app.wait_idle(300)
    assert app.pipeline.calls["smoothness"] == 1 and app.displayed.view == "smoothness"
    expected = Pipeline().run(app.session.work.pair, app.session.params).images("smoothness")
    assert app.session.params.enabled("smoothness")
    for shown, reference in zip(app.displayed.images, expected):
        np.testing.assert_allclose(shown, reference, rtol=1e-5, atol=1e-3)
    app.tuning.on_param_change("uniformity", {"zeta": 0.6}, None)  # back to live tuning
    assert app.wait_idle(60)
    assert app.pipeline.calls["smoothness"] == 1 and app.displayed.view == LIVE_UNTIL


def test_preview_full_resolution_and_region(tmp_path):
    from inspector.app import InspectorApp

    app = InspectorApp(port=0, demo_size=256, preview_side=128, record_dir=tmp_path / "rec", preset="paper").start()
    try:
        app.disparity.auto_review.value = False
        assert app.wait_idle(120)
        work = app.session.work
        assert work.mode == "preview" and work.factor == 2 and app.displayed.images[0].shape == (128, 128)
        assert app.session.run.pair is work.pair
        app.data.on_apply_full(SimpleNamespace(client=None))
        assert app.wait_idle(120)
        assert app.session.work.mode == "full" and app.displayed.images[0].shape == (256, 256)
        assert app.data.work_mode.value == "full"
        # Shift+click on the reference at pixel (200, 60) centres a full-resolution region there.
        place = app.viewport.placements["reference"]
        point = (place.centre[0] - 0.5 + 200 / 256, place.centre[1] - 0.5 + 60 / 256, 0.0)
        ray = SimpleNamespace(ray_origin=(point[0], point[1], -3.0), ray_direction=(0.0, 0.0, 1.0), client=None)
        app.view.on_scene_shift_click(ray)
        assert app.wait_idle(120)
        region = app.session.work
        assert region.mode == "region" and region.region == (128, 0, 128, 128)
        np.testing.assert_array_equal(region.pair.reference.data, region.full.reference.data[0:128, 128:256])
        assert app.displayed.images[0].shape == (128, 128)
    finally:
        app.stop()


def test_smoothness_is_fast_on_previews_only(tmp_path):
    from inspector.app import InspectorApp
    from radcons.stages.smoothness.run import preview_params

    app = InspectorApp(port=0, demo_size=256, preview_side=128, record_dir=tmp_path / "rec", preset="paper").start()
    try:
        app.disparity.auto_review.value = False
        assert app.wait_idle(120) and app.session.work.factor == 2
        app.tuning.on_run_smoothness(SimpleNamespace(client=None))
        assert app.wait_idle(300)
        fast = preview_params(app.session.params.smoothness)
        assert fast != app.session.params.smoothness
        assert app.session.run.params.smoothness == fast and "smoothness" in app.session.run.results
        assert app.session.run.params.uniformity == app.session.params.uniformity
        app.tuning.set_quietly(app.tuning.fast_smoothness, False)
        app.tuning.on_run_smoothness(SimpleNamespace(client=None))
        assert app.wait_idle(300)
        assert app.session.run.params == app.session.params
        app.tuning.set_quietly(app.tuning.fast_smoothness, True)
        app.data.on_apply_full(SimpleNamespace(client=None))
        assert app.wait_idle(120)
        app.tuning.on_run_smoothness(SimpleNamespace(client=None))
        assert app.wait_idle(300)
        assert app.session.work.mode == "full" and app.session.run.params == app.session.params
        assert "smoothness" in app.session.run.results
    finally:
        app.stop()


def test_first_pair_is_shown_before_the_panels(tmp_path, monkeypatch):
    """The demo pair (generated while a page would load) is on the viewport, as the pair's
    own pixels, when the panels are built; the later load reuses it."""
    import inspector.app as app_module
    from demo_data_gen import generate

    seen = {}

    def build_layout(server, *args, **kwargs):
        seen["shown"] = {name: picture.copy() for name, picture in app.viewport.shown.items()}
        return original(server, *args, **kwargs)

    original = app_module.build_layout
    monkeypatch.setattr(app_module, "build_layout", build_layout)
    app = app_module.InspectorApp(port=0, demo_size=128, demo_seed=3, record_dir=tmp_path / "rec")
    app.start()
    try:
        assert app.wait_idle(120)
        pair = generate(size=128, seed=3, scenario="mixed")
        for name, raster in (("reference", pair.reference), ("target", pair.target)):
            shown = seen["shown"][name].astype(float).ravel()
            assert shown.shape == (128 * 128,) and shown.std() > 3
            assert np.corrcoef(shown, raster.data.astype(float).ravel())[0, 1] > 0.99
        np.testing.assert_array_equal(app.session.work.full.reference.data, pair.reference.data)
    finally:
        app.stop()
