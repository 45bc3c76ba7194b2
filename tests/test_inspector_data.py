"""The inspector's pair loading and parameter checks, driven from Python (no browser).

Bands and geometry as ``radcons process`` takes them, the Data tab's words about them, the
pair dropdown after failed loads, the uploads folder, and parameters checked against the
pair before a run.
"""

from __future__ import annotations

from dataclasses import replace

import math
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from conftest import wait_for_run
from demo_data_gen import generate
from inspector.describe import bands_text, geometry_text, rectification_text
from radcons.io import save_pair


def _start(tmp_path, **kwargs):
    from inspector.app import InspectorApp

    kwargs.setdefault("demo_size", 128)
    app = InspectorApp(port=0, record_dir=tmp_path / "rec", preset="paper", **kwargs).start()
    assert app.wait_idle(180)
    return app


@pytest.fixture()
def app(tmp_path):
    app = _start(tmp_path, max_upload_mib=1)
    try:
        yield app
    finally:
        app.stop()


def _notes(app):
    """Notifications sent by the app, as ``(title, body)``."""
    sent = []
    app.context.notify = lambda client, title, body, error=True: sent.append((title, body))
    return sent


# ----------------------------------------------------------------------------- parameters


@pytest.mark.parametrize(
    "stage, changes, message",
    [
        ("objects", {"max_size": 10**9}, "[objects] max_size = 1000000000 px is longer than the image's smaller side (128 px)"),
        ("smoothness", {"search_window": 201}, "[smoothness] search_window = 201 px is longer than the image's smaller side (128 px)"),
        ("objects", {"min_contrast": math.nan}, "[objects] min_contrast must be a finite number"),
        ("refine", {"gain_range": (0.5,)}, "[refine] gain_range must be a list of 2 numbers"),
    ],
)
def test_bad_values_are_refused_with_the_command_lines_message(app, stage, changes, message):
    sent = _notes(app)
    params, generation, displayed = app.session.params, app.context.compute.generation, app.displayed
    name = next(iter(changes))
    before = app.tuning.stages[stage].handles[name].value
    app.tuning.on_param_change(stage, changes, None)
    assert app.wait_idle(60)
    assert app.session.params is params
    assert app.context.compute.generation == generation  # no run asked for
    assert app.displayed is displayed  # the last good result stays
    assert app.tuning.stages[stage].handles[name].value == before
    assert len(sent) == 1 and sent[0][0] == f"Invalid {stage} parameter"
    assert sent[0][1].startswith(message), sent


def test_a_number_control_sent_inf_is_refused(app, monkeypatch):
    """A client may send any number: inf in an integer control is refused with the message
    of the command line, not a crash. (viser refuses to set inf from Python, so the control
    is stood in for.)"""
    sent = _notes(app)
    params = app.session.params
    controls = app.tuning.stages["objects"]
    monkeypatch.setitem(controls.handles, "max_size", SimpleNamespace(value=math.inf))
    controls._changed("max_size", SimpleNamespace(client=None))
    assert app.session.params is params
    assert len(sent) == 1 and sent[0][1].startswith("[objects] max_size must be a finite number"), sent
    assert controls.handles["max_size"].value == params.objects.max_size


# ----------------------------------------------------------------------------- loading


def _upload(app, role: str, name: str, content: bytes) -> None:
    from viser import UploadedFile

    app.data.on_upload(role, SimpleNamespace(target=SimpleNamespace(value=UploadedFile(name, content)), client=None))


def test_invalid_parameter_is_refused_and_the_control_reset(app):
    params = app.session.params
    app.tuning.on_param_change("uniformity", {"zeta": 1.7}, None)
    assert app.session.params is params
    assert app.tuning.stages["uniformity"].handles["zeta"].value == pytest.approx(params.uniformity.zeta)


def test_uploads_are_capped_checked_and_then_loaded(app):
    work = app.session.work
    _upload(app, "reference", "huge.png", b"\x89PNG" + bytes(2 * 2**20))
    _upload(app, "reference", "notes.txt", b"hello")
    _upload(app, "reference", "fake.tif", b"II*\x00garbage")
    assert app.data.uploads == {} and app.session.work is work
    image = np.random.default_rng(0).integers(0, 255, (64, 80), dtype=np.uint8)
    _upload(app, "reference", "left.png", cv2.imencode(".png", image)[1].tobytes())
    _upload(app, "target", "right.png", cv2.imencode(".png", np.roll(image, 3, axis=1))[1].tobytes())
    assert app.wait_idle(120)
    assert app.session.work is not work and app.session.work.full.shape == (64, 80)
    np.testing.assert_array_equal(app.session.work.full.reference.data, image)
    assert app.displayed.final


def _write_broken(root):
    broken = root / "broken"
    broken.mkdir(parents=True)
    (broken / "pair.toml").write_text('reference = "left.png"\ntarget = "missing.png"\n')
    cv2.imwrite(str(broken / "left.png"), np.zeros((64, 64), np.uint8))


def test_the_pair_dropdown_names_the_pair_loaded(tmp_path):
    root = tmp_path / "data"
    save_pair(generate(size=128, seed=1, scenario="mixed"), root / "good")
    _write_broken(root)
    app = _start(tmp_path, data_roots=[root])
    try:
        sent = _notes(app)
        # A folder typed in opens, and the dropdown names it.
        app.data.folder.value = str(root / "good")
        app.data.on_open_folder(SimpleNamespace(client=None))
        assert app.wait_idle(120)
        label = app.session.work.label
        assert label == "good" and app.data.pair.value == label and label in app.data.pair.options
        # A pair that fails to open: the dropdown goes back to the pair loaded.
        app.data.pair.value = "data/broken"
        assert app.wait_idle(120)
        assert sent[-1][0] == "Could not open data/broken" and "missing.png" in sent[-1][1]
        assert app.session.work.label == label and app.data.pair.value == label
        # The pair opened from its folder is opened again from the dropdown.
        app.data.pair.value = "built-in demo"
        assert app.wait_idle(120) and app.session.work.label == "built-in demo"
        app.data.pair.value = label
        assert app.wait_idle(120) and app.session.work.label == label
        assert app.session.work.full.shape == (128, 128)
    finally:
        app.stop()


def test_a_manifest_naming_a_file_outside_its_folder_is_refused(tmp_path):
    root = tmp_path / "data"
    save_pair(generate(size=64, seed=1, scenario="none"), root / "escape")
    save_pair(generate(size=64, seed=2, scenario="none"), tmp_path / "elsewhere")
    manifest = root / "escape" / "pair.toml"
    (root / "escape" / "link.tif").symlink_to(tmp_path / "elsewhere" / "target.tif")
    app = _start(tmp_path, data_roots=[root])
    try:
        sent = _notes(app)
        for target, message in (("/etc/hostname", "points outside the pair folder"),
                                ("link.tif", "is a symbolic link that leads outside the pair folder")):
            manifest.write_text(manifest.read_text().split("target = ")[0] + f"target = {target!r}\n")
            app.data.folder.value = str(root / "escape")
            app.data.on_open_folder(SimpleNamespace(client=None))
            assert app.wait_idle(120)
            assert sent[-1][0] == "Could not open escape" and f"target = {target!r} {message}" in sent[-1][1]
            assert app.session.work.label == "built-in demo"
    finally:
        app.stop()


def test_the_data_tab_says_when_the_run_leaves_the_noise_ratio_high(tmp_path):
    from radcons.noise import noise_ratio
    from radcons.summary import run_noise_notice

    save_pair(generate(size=256, seed=4, scenario="multi-sensor"), tmp_path / "pair")
    app = _start(tmp_path, pairs=[tmp_path / "pair"])
    try:
        run = wait_for_run(app)
        assert app.wait_idle(120)
        # the ratio of the images as the 16-bit output files hold them: whole levels
        notice = run_noise_notice(run, noise_ratio(*(np.rint(image) for image in run.images())))
        # the paper preset, tuned without its smoothness stage (run on request)
        assert notice is not None and "smoothness stage (the run stopped before it)" in notice
        assert app.data.noise_info.content == notice
    finally:
        app.stop()


def test_the_data_tab_says_whether_light_across_the_scene_was_corrected(tmp_path):
    from inspector.app import InspectorApp
    from inspector.describe import light_text
    from radcons.params import Params

    pair = generate(size=256, seed=1, scenario="none")
    x = (np.arange(256) + 0.5) / 256
    lit = pair.target.as_float32() * (0.7 + 0.6 * x)[None, :]  # +-30 % from left to right
    save_pair(pair.with_images(pair.reference.data, lit.astype(pair.target.data.dtype)), tmp_path / "pair")
    app = InspectorApp(port=0, record_dir=tmp_path / "rec", preset="radcons", pairs=[tmp_path / "pair"]).start()
    try:
        run = wait_for_run(app)
        assert app.wait_idle(120)
        done = run.results["refine"].info
        assert done["light_applied"] and done["light_spread"] >= 0.04
        assert f"corrected per tile (it moved the target by {done['light_spread']:.3f}" in app.data.noise_info.content
    finally:
        app.stop()
    params = Params.from_preset("radcons")
    kept = SimpleNamespace(params=params, results={"refine": SimpleNamespace(info={"background": "local", "light_spread": 0.0213, "light_applied": False})})
    assert "not corrected (the tile correction would move the target by 0.021" in light_text(kept)
    assert "below `local_min_light` 0.04" in light_text(kept)
    histogram = SimpleNamespace(params=params, results={"refine": SimpleNamespace(info={"background": "histogram"})})
    assert light_text(histogram) == "" and light_text(SimpleNamespace(params=params, results={})) == ""


def test_the_uploads_folder_lives_from_the_first_upload_to_the_stop(tmp_path, monkeypatch):
    import tempfile

    temp = tmp_path / "tmp"
    temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    app = _start(tmp_path)
    try:
        assert list(temp.iterdir()) == []
        _upload(app, "reference", "left.png", cv2.imencode(".png", np.zeros((32, 32), np.uint8))[1].tobytes())
        assert [path.name[:16] for path in temp.iterdir()] == ["radcons-uploads-"]
    finally:
        app.stop()
    assert list(temp.iterdir()) == []


def _colour(grey: np.ndarray) -> np.ndarray:
    """A BGR picture whose bands (R, G, B in the file) are ``255 - g``, ``g // 2`` and ``g``."""
    return np.dstack([grey, grey // 2, 255 - grey])


def test_band_and_geometry_as_the_command_line_takes_them(tmp_path):
    pair = generate(size=128, seed=2, scenario="mixed")
    greys = [(raster.data // 8).astype(np.uint8) for raster in (pair.reference, pair.target)]
    files = [tmp_path / "left.png", tmp_path / "right.png"]
    for path, grey in zip(files, greys):
        cv2.imwrite(str(path), _colour(grey))
    app = _start(tmp_path, pairs=files, band=2)
    try:
        full = app.session.work.full
        np.testing.assert_array_equal(full.reference.data, greys[0] // 2)  # band 2 is G
        info = app.data.pair_info.content
        assert "Bands: band 2 of 3 (both images)" in info
        assert "Geometry: rectified: median vertical parallax of" in info  # equal sizes: checked
        assert wait_for_run(app).rectification is None and app.data.geometry_info.content == ""
    finally:
        app.stop()


@pytest.mark.parametrize("how", ["sizes", "--unrectified"])
def test_an_unrectified_pair_shows_its_resampling(tmp_path, how):
    # seed 1: enough SIFT matches show relief for the rectifier with OpenCV 4 and 5 alike
    # (seed 0's pair keeps 18 of the 20 it needs with OpenCV 5's SIFT)
    pair = generate(size=256, seed=1, scenario="mixed")
    files = [tmp_path / "left.png", tmp_path / "right.png"]
    cv2.imwrite(str(files[0]), pair.reference.data)
    cv2.imwrite(str(files[1]), pair.target.data[: -6 if how == "sizes" else None])
    app = _start(tmp_path, pairs=files, rectified=False if how == "--unrectified" else None)
    try:
        info = app.data.pair_info.content
        if how == "sizes":
            assert "Geometry: unrectified: the images differ in size ((256, 256) vs (250, 256))" in info
        else:
            assert "Geometry: unrectified (as given)" in info
        rectification = wait_for_run(app).rectification
        assert rectification is not None
        # The demo pair is rectified to begin with: its resampling leaves under 1 px.
        assert rectification.residual_parallax_median < 1.0
        text = app.data.geometry_info.content
        assert f"median {rectification.residual_parallax_median:.2f} px" in text
        assert f"p90 {rectification.residual_parallax_p90:.2f} px" in text
    finally:
        app.stop()


def test_the_data_tab_words():
    pair = generate(size=64, seed=0, scenario="none")
    assert bands_text(pair) == "Bands: single band (both images)"
    assert geometry_text(pair) == "rectified (as given)"
    levelled = replace(pair, metadata={**pair.metadata, "rows": "target rows levelled: vertical offset 2.43 px"})
    assert geometry_text(levelled) == "rectified (as given); target rows levelled: vertical offset 2.43 px"
    assert rectification_text(None, 1) == ""
    rectification = SimpleNamespace(
        residual_parallax_median=0.314, residual_parallax_p90=0.9, n_inliers=79, n_matches=299, disparity_range=(-18.2, 8.4),
        orientation="turned by 180 deg from the rotation rule: relief skew -0.45, below -0.25",
    )
    text = rectification_text(rectification, 2)
    assert "median 0.31 px, p90 0.90 px (px of the preview, 1:2)" in text
    assert "79 of 299 SIFT matches kept" in text and "disparity range -18 .. 8 px" in text
    assert "which way up: turned by 180 deg from the rotation rule: relief skew -0.45" in text
