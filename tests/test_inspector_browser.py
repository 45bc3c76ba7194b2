"""The inspector driven through its real page: a live server and headless Chromium.

Each test starts its own server on a free port with a small demo pair and stops it at the
end. Tests wait on state (the server's session, the page's text, the canvas pixels), never
on fixed sleeps.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections import Counter
from contextlib import contextmanager
from pathlib import Path

import cv2
import numpy as np
import pytest
import scipy.ndimage
from playwright.sync_api import TimeoutError as PlaywrightTimeoutError

from conftest import wait_for_shown_params, wait_until  # noqa: F401 - wait_until is also imported from here

pytestmark = pytest.mark.browser

SIZE = 192


# ----------------------------------------------------------------------------- helpers


@contextmanager
def running(tmp_path: Path, **kwargs):
    from inspector.app import InspectorApp

    kwargs.setdefault("preset", "paper")  # the paper's stages: uniformity is on
    app = InspectorApp(port=0, demo_size=SIZE, record_dir=tmp_path / "recordings", **kwargs).start()
    try:
        yield app
    finally:
        app.stop()


def open_page(browser, app):
    """A new browser client on the app, once the pair is processed and shown."""
    before = set(app.server.get_clients())
    page = browser()
    # At a fixed pixel ratio: viser lowers a page's resolution while its frames are slow (a
    # loaded machine), and two pages would then draw the same pictures differently.
    page.goto(f"{app.url}/?fixedDpr=1")
    wait_until(lambda: set(app.server.get_clients()) - before, what="the websocket client")
    assert app.wait_idle(120)
    page.get_by_text("Ready · computed", exact=False).first.wait_for(timeout=60_000)
    client_id = next(iter(set(app.server.get_clients()) - before))
    client = app.server.get_clients()[client_id]

    def framed() -> bool:
        box = page.locator("canvas").last.bounding_box()
        return abs(client.camera.aspect - box["width"] / box["height"]) < 1e-3 and app.viewport.framed(client)

    wait_until(framed, what="the camera to fit the canvas")
    return page, client


def open_stage(page, stage: str, shows: str, advanced: bool = False) -> None:
    """Expand a stage's folder of the Tune tab, and its advanced folder when asked (they
    start collapsed), until the control labelled ``shows`` is visible in it."""
    if advanced:
        open_folder(page, stage, f"{stage} (advanced)")
        open_folder(page, f"{stage} (advanced)", shows)
    else:
        open_folder(page, stage, shows)


def open_folder(page, title: str, shows: str, attempts: int = 3) -> None:
    """Click the visible folder titled ``title`` until the text ``shows`` inside it is
    visible: a click that lands while the panel re-renders can be lost, and is repeated."""
    content = page.get_by_text(shows, exact=True).locator("visible=true").first
    for _ in range(attempts):
        if content.is_visible():
            return
        page.get_by_text(title, exact=True).locator("visible=true").first.click()
        try:
            content.wait_for(state="visible", timeout=10_000)
            return
        except PlaywrightTimeoutError:
            continue
    raise AssertionError(f"{shows!r} did not show after {attempts} clicks on the folder {title!r}")


def labelled_input(page, label: str, kind: str = "NumberInput"):
    """The input box of a control found from its label text (viser's text and number inputs
    are not tied to their labels); ``kind`` is ``"NumberInput"`` (sliders, numbers) or
    ``"TextInput"``."""
    row = page.get_by_text(label, exact=True).locator(f"xpath=ancestor::div[.//input[contains(@class, '{kind}')]][1]")
    return row.locator(f"input.mantine-{kind}-input").first


def number_input(page, label: str):
    """The number box of a slider or number control."""
    return labelled_input(page, label, "NumberInput")


def set_number(page, label: str, value: float) -> None:
    box = number_input(page, label)
    box.fill(str(value))
    box.press("Enter")


def image_box(app, client, image: str) -> tuple[int, int, int, int]:
    """Canvas pixel box ``(x0, y0, x1, y1)`` of the reference or target image."""
    height, width = app.session.work.pair.shape
    corners = [app.viewport.screen_point(client, image, x, y) for x, y in ((0, 0), (width, height))]
    (x0, y0), (x1, y1) = corners
    return int(np.ceil(x0)) + 2, int(np.ceil(y0)) + 2, int(x1) - 2, int(y1) - 2


def canvas_pixels(page) -> np.ndarray:
    page.bring_to_front()  # a page in the background does not redraw its canvas
    shot = page.locator("canvas").last.screenshot()
    return cv2.imdecode(np.frombuffer(shot, np.uint8), cv2.IMREAD_COLOR).astype(np.int16)


def crop(pixels: np.ndarray, box) -> np.ndarray:
    x0, y0, x1, y1 = box
    return pixels[y0:y1, x0:x1]


def changed_pixels(page, box, before: np.ndarray) -> np.ndarray | None:
    """The canvas pixels in ``box`` if they differ visibly from ``before``, else None."""
    now = crop(canvas_pixels(page), box)
    return now if np.abs(now - before).mean() > 1.0 else None


def inner_pixel(labels: np.ndarray, label: int) -> tuple[float, float]:
    """``(x, y)`` of the pixel deepest inside an object."""
    distance = scipy.ndimage.distance_transform_edt(labels == label)
    row, col = np.unravel_index(int(np.argmax(distance)), distance.shape)
    return col + 0.5, row + 0.5


# ----------------------------------------------------------------------------- tests


def test_demo_shows_and_a_uniformity_change_reruns_only_downstream(browser, tmp_path):
    from inspector.app import LIVE_UNTIL
    from radcons.params import STAGES

    with running(tmp_path) as app:
        page, client = open_page(browser, app)
        assert app.session.work.label == "built-in demo"
        assert app.displayed.final and app.displayed.view == LIVE_UNTIL
        box = image_box(app, client, "target")
        before = crop(canvas_pixels(page), box)
        assert before.std() > 5, "the target image is not on the canvas"
        calls = Counter(app.pipeline.calls)
        picture = app.displayed.pictures[1]

        page.get_by_role("tab", name="Tune").click()

        open_stage(page, "uniformity", "zeta")
        set_number(page, "zeta", 0.35)
        wait_until(lambda: app.session.params.uniformity.zeta == 0.35, what="zeta to reach the server")
        wait_for_shown_params(app, 120)
        assert app.wait_idle(120)
        assert app.displayed.params.uniformity.zeta == 0.35 and app.displayed.final

        after = wait_until(lambda: changed_pixels(page, box, before), what="the displayed target to change")
        assert np.abs(after - before).mean() > 1.0
        assert not np.array_equal(app.displayed.pictures[1], picture)
        delta = app.pipeline.calls - calls
        assert delta["rectify"] == delta["objects"] == delta["association"] == 0
        live = STAGES[STAGES.index("uniformity") : STAGES.index(LIVE_UNTIL) + 1]
        assert all(delta[stage] >= 1 for stage in live)
        assert delta["smoothness"] == 0  # runs on request only (test_inspector_units)


def test_clicking_an_object_shows_its_details(browser, tmp_path):
    with running(tmp_path) as app:
        page, client = open_page(browser, app)
        run = app.session.run
        ref_id = max(run.association.objects, key=lambda o: int((run.objects.reference == o.ref_id).sum())).ref_id
        x, y = inner_pixel(run.objects.reference, ref_id)
        u, v = app.viewport.screen_point(client, "reference", x, y)
        page.locator("canvas").last.click(position={"x": u, "y": v})
        wait_until(lambda: app.session.selected == ref_id, what="the click to select the object")
        page.get_by_role("heading", name=f"Object {ref_id}").wait_for(timeout=30_000)
        assert page.get_by_text("reference | target (current stage)").is_visible()
        assert app.objects.choice.value == str(ref_id)
        # Clicking the associated object in the target selects the same object.
        app.select_object(None)
        tgt_id = run.association.by_ref()[ref_id].tgt_id
        if tgt_id > 0:
            x, y = inner_pixel(run.objects.target, tgt_id)
            u, v = app.viewport.screen_point(client, "target", x, y)
            page.locator("canvas").last.click(position={"x": u, "y": v})
            wait_until(lambda: app.session.selected is not None, what="a click in the target to select")
            assert run.association.by_ref()[app.session.selected].tgt_id == tgt_id


def _write_bad_inputs(tmp_path: Path) -> tuple[Path, Path]:
    import tifffile

    root = tmp_path / "data"
    broken = root / "broken"
    broken.mkdir(parents=True)
    (broken / "pair.toml").write_text('reference = "left.png"\ntarget = "missing.png"\n')
    cv2.imwrite(str(broken / "left.png"), np.arange(64 * 64, dtype=np.uint16).reshape(64, 64))
    cube = tmp_path / "cube.tif"  # 17 bands: more than an image may have
    tifffile.imwrite(cube, np.zeros((32, 32, 17), np.uint8), photometric="minisblack", planarconfig="contig")
    return root, cube


def _write_colour_pair(tmp_path: Path) -> tuple[Path, Path]:
    """An RGB pair whose target is the reference shifted 3 px to the left."""
    colour = np.random.default_rng(0).integers(0, 255, (64, 80, 3), dtype=np.uint8)
    files = tmp_path / "left_rgb.png", tmp_path / "right_rgb.png"
    cv2.imwrite(str(files[0]), colour)
    cv2.imwrite(str(files[1]), np.roll(colour, -3, axis=1))
    return files


def _upload(page, button: str, path: Path) -> None:
    with page.expect_file_chooser() as chooser:
        page.get_by_role("button", name=button).click()
    chooser.value.set_files(str(path))


def test_bad_inputs_are_refused_and_the_previous_pair_stays(browser, tmp_path):
    root, cube = _write_bad_inputs(tmp_path)
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    (root / "link").symlink_to(outside, target_is_directory=True)
    with running(tmp_path, data_roots=[root]) as app:
        page, _ = open_page(browser, app)
        work, generation = app.session.work, app.displayed.generation

        # An upload that is not an image radcons reads (17 bands).
        page.get_by_text("Upload two images").click()
        _upload(page, "Reference image", cube)
        page.get_by_text("Upload refused: cube.tif").wait_for(timeout=30_000)
        assert page.get_by_text("17 bands", exact=False).first.is_visible()

        # A pair folder whose manifest names a missing file.
        page.get_by_label("Pair").click()
        page.get_by_role("option", name="data/broken").click()
        page.get_by_text("Could not open data/broken").wait_for(timeout=30_000)
        assert page.get_by_text("missing.png", exact=False).first.is_visible()
        wait_until(lambda: page.get_by_label("Pair").input_value() == "built-in demo", what="the dropdown to revert")

        # Folders outside the allowed roots: absolute, through "..", through a symbolic link.
        refusals = page.get_by_text("outside the folders", exact=False)
        for count, attempt in enumerate(("/etc", str(root / ".." / "elsewhere"), str(root / "link")), start=1):
            labelled_input(page, "Folder", "TextInput").fill(attempt)
            page.get_by_role("button", name="Open folder").click()
            wait_until(lambda: refusals.count() == count, what=f"{attempt} to be refused")

        assert app.wait_idle(60)
        assert app.session.work is work
        assert app.displayed.generation == generation

        # Two RGB images are read as one grey band each (luminance) and open as a pair.
        reference, target = _write_colour_pair(tmp_path)
        page.get_by_role("tab", name="Data").click()
        _upload(page, "Reference image", reference)
        page.get_by_text("waiting for the other image", exact=False).wait_for(timeout=30_000)
        _upload(page, "Target image", target)
        label = "upload: left_rgb.png + right_rgb.png"
        wait_until(lambda: app.session.work.label == label, what="the RGB pair to open")
        colour = cv2.imread(str(reference), cv2.IMREAD_COLOR)
        grey = cv2.cvtColor(colour, cv2.COLOR_BGR2GRAY)
        np.testing.assert_allclose(app.session.work.full.reference.data, grey, atol=1)
        wait_until(lambda: page.get_by_label("Pair").input_value() == label, what="the dropdown to name the upload")


def test_hammered_slider_ends_on_a_fresh_run_of_the_final_value(browser, tmp_path):
    from inspector.app import LIVE_UNTIL
    from radcons.pipeline import Pipeline

    with running(tmp_path) as app:
        page, _ = open_page(browser, app)
        page.get_by_role("tab", name="Tune").click()
        open_stage(page, "uniformity", "mu")
        thumb = page.get_by_text("mu", exact=True).locator("xpath=ancestor::div[.//*[@role='slider']][1]").get_by_role("slider")
        calls = Counter(app.pipeline.calls)
        presses = 40
        run = app.pipeline.run

        def slow_run(*args, **kwargs):
            """A run that takes longer than the gap between two presses, however fast the
            machine, so that changes arrive while one is computed."""
            time.sleep(0.1)
            return run(*args, **kwargs)

        app.pipeline.run = slow_run
        # Forty arrow-key presses on the slider, 20 ms apart, sent from inside the page.
        thumb.evaluate(
            """async (thumb, presses) => {
                thumb.focus();
                for (let i = 0; i < presses; i++) {
                    thumb.dispatchEvent(new KeyboardEvent("keydown", {key: "ArrowRight", code: "ArrowRight", bubbles: true}));
                    await new Promise((resolve) => setTimeout(resolve, 20));
                }
            }""",
            presses,
        )
        final = float(thumb.get_attribute("aria-valuenow"))
        assert final == pytest.approx(0.1 + 0.01 * presses)
        wait_until(lambda: abs(app.session.params.uniformity.mu - final) < 1e-9, what="the last value to reach the server")
        wait_for_shown_params(app, 180)
        assert app.wait_idle(180)
        displayed = app.displayed
        assert displayed.params == app.session.params and displayed.final
        fresh = Pipeline().run(app.session.work.pair, app.session.params, until=LIVE_UNTIL)
        for shown, expected in zip(displayed.images, fresh.images(displayed.view)):
            np.testing.assert_allclose(shown, expected, rtol=1e-5, atol=1e-3)
        ran = (app.pipeline.calls - calls)["uniformity"]
        assert 1 <= ran < presses, "rapid changes were not coalesced"


def test_two_clients_see_the_same_state(browser, tmp_path):
    with running(tmp_path) as app:
        first, first_client = open_page(browser, app)
        second, second_client = open_page(browser, app)
        clients = (first_client, second_client)
        for page in (first, second):
            page.get_by_role("tab", name="Tune").click()
            open_stage(page, "uniformity", "zeta")

        def settled() -> list | None:
            """The target's box on both canvases once both cameras are framed and the two
            boxes agree: each page's canvas settling may lay the pictures out anew and frame
            every camera again, and the other page answers a moment later."""
            if not all(app.viewport.framed(client) for client in clients):
                return None
            found = [image_box(app, client, "target") for client in clients]
            return found if found[0] == found[1] else None

        boxes = wait_until(settled, what="both cameras framed on the same picture box")
        before = crop(canvas_pixels(second), boxes[1])
        set_number(first, "zeta", 0.5)
        wait_until(lambda: number_input(second, "zeta").input_value() == "0.5", what="the second client's zeta")
        assert app.wait_idle(120)

        def same() -> bool:
            """Both cameras framed as when ``before`` was taken, and the two canvases agree
            (up to the antialiased outlines, drawn at sub-pixel offsets that differ between
            pages) and no longer show the old target."""
            if settled() != boxes:
                return False
            views = [crop(canvas_pixels(page), box) for page, box in zip((first, second), boxes)]
            differing = (np.abs(views[0] - views[1]).max(axis=2) > 24).mean()
            return differing < 0.03 and np.abs(views[1] - before).mean() > 1.0

        wait_until(same, what="both canvases to show the new target")
        # Notifications are per client: an error caused by the first is not shown to the second.
        first.get_by_role("tab", name="Data").click()
        labelled_input(first, "Folder", "TextInput").fill("/etc")
        first.get_by_role("button", name="Open folder").click()
        first.get_by_text("outside the folders", exact=False).first.wait_for(timeout=30_000)
        assert second.get_by_text("outside the folders", exact=False).count() == 0


def test_record_to_rerun_and_export_parameters(browser, tmp_path):
    from rerun.chunk import RrdReader

    from demo_data_gen import generate
    from inspector.app import LIVE_UNTIL
    from radcons.io import save_pair
    from radcons.params import Params

    folder = tmp_path / "pair"
    save_pair(generate(size=SIZE, seed=5, scenario="mixed"), folder)
    with running(tmp_path, pairs=[folder]) as app:
        page, _ = open_page(browser, app)
        page.get_by_role("tab", name="Tune").click()
        open_stage(page, "uniformity", "zeta")
        set_number(page, "zeta", 0.45)
        wait_until(lambda: len(app.session.history) == 2, what="a second tuning step")
        assert app.wait_idle(120)
        page.get_by_role("tab", name="Export").click()
        page.get_by_role("button", name="Record to rerun").click()
        page.get_by_text("Recording written", exact=False).first.wait_for(timeout=120_000)
        page.get_by_role("button", name="Export parameters").click()
        page.get_by_text("Parameters exported", exact=False).first.wait_for(timeout=30_000)
        recording, exported, params = app.last_recording, app.last_export, app.session.params

    assert recording is not None and recording.parent == tmp_path / "recordings" and recording.suffix == ".rrd"
    reader = RrdReader(str(recording))
    entities = {str(e) for e in reader.store().schema().entity_paths()}
    assert any("summary" in e for e in entities), entities
    steps = set()
    for chunk in reader.stream():
        batch = chunk.to_record_batch()
        if "tuning_step" in batch.schema.names:
            steps.update(v for v in batch.column("tuning_step").to_pylist() if v is not None)
    assert steps == {0, 1}, "both settings tried should be on the tuning_step timeline"

    assert exported is not None and exported.is_file()
    assert Params.load(exported) == params
    out = tmp_path / "out"
    result = subprocess.run(
        [sys.executable, "-m", "radcons.cli", "process", str(folder), "--params", str(exported), "--out", str(out), "--until", LIVE_UNTIL, "--quiet"],
        capture_output=True, text=True, timeout=600,
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["params"] == params.to_dict()
    assert summary["params"]["uniformity"]["zeta"] == 0.45


@contextmanager
def other_site(tmp_path: Path):
    """A page served from another origin (another port of 127.0.0.1)."""
    import functools
    import http.server
    import threading

    folder = tmp_path / "site"
    folder.mkdir()
    (folder / "index.html").write_text("<!doctype html><title>another site</title><p>another site</p>")
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(folder))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/index.html"
    finally:
        server.shutdown()
        server.server_close()


#: Opens a websocket to the inspector from inside a page: "open" or "refused".
OPEN_WEBSOCKET = """([url, protocol]) => new Promise((resolve) => {
    const socket = new WebSocket(url, [protocol]);
    socket.onopen = () => { socket.close(); resolve("open"); };
    socket.onerror = () => resolve("refused");
})"""


def test_other_sites_cannot_connect_and_bad_values_are_explained_in_the_page(browser, tmp_path):
    import viser

    with running(tmp_path) as app, other_site(tmp_path) as elsewhere:
        page, _ = open_page(browser, app)  # the inspector's own page connects
        socket_url, protocol = f"ws://127.0.0.1:{app.port}", f"viser-v{viser.__version__}"
        assert page.evaluate(OPEN_WEBSOCKET, [socket_url, protocol]) == "open"
        foreign = browser()
        foreign.goto(elsewhere)
        clients = set(app.server.get_clients())
        assert foreign.evaluate(OPEN_WEBSOCKET, [socket_url, protocol]) == "refused"
        assert set(app.server.get_clients()) <= clients

        # A value the command line refuses is refused here too, with its message.
        params, generation = app.session.params, app.displayed.generation
        page.bring_to_front()
        page.get_by_role("tab", name="Tune").click()
        open_stage(page, "objects", "max_size", advanced=True)
        set_number(page, "max_size", 100000)
        page.get_by_text("Invalid objects parameter").wait_for(timeout=30_000)
        assert page.get_by_text(f"longer than the image's smaller side ({SIZE} px)", exact=False).first.is_visible()
        wait_until(lambda: number_input(page, "max_size").input_value() == str(params.objects.max_size), what="the control to be set back")
        assert app.wait_idle(60)
        assert app.session.params is params and app.displayed.generation == generation
