"""Inspector latencies: startup, a slider change on a 1024 px pair, clicks while smoothness runs, SIGTERM, real pairs.

Five measurements, each the median of ``--repeat`` trials, with a real server and headless
Chromium (Debian's ``/usr/bin/chromium`` through Playwright):

1. **Startup to first image** on the built-in demo pair: ``radcons inspect`` is started as a
   subprocess; the clock runs from its launch to (a) the address line on stdout (server
   listening; it gives a page opened at once up to 3 s to load before it shows the demo
   pair, builds the panels and runs the stages) and (b) the demo pair visible on that
   page: the reference image area of the canvas no longer blank, read inside the page
   after the frames it draws, at most every 40 ms (:data:`CANVAS_PROBE`; the page's
   clock is the machine's wall clock, as the launch time). Screenshots, polled before,
   take 1-2 s each while the page renders its panels and so came late by up to that
   much. Each launch is stopped with Ctrl+C (SIGINT), and one not obeyed within 30 s is
   counted. Reference: the page alone, opened
   on an idle server that has everything computed, from ``goto`` to the image shown, the
   floor of (b) less the launch. ``--compare-startup OTHER`` launches another checkout
   (e.g. ``git worktree add /tmp/old <commit>``) in turn with this one, for a comparison
   free of the machine's drift (the same virtual environment runs both).
2. **Slider change to updated images** on a 1024 x 1024 demo pair (tuned at full
   resolution, ``paper`` preset, whose uniformity stage is on), for uniformity
   ``zeta``. *Server*: from the parameter request (the GUI callback) to the new images
   queued for the browsers (compute + 8-bit mapping + overlay drawing + JPEG/PNG
   encoding), read from :attr:`InspectorApp.requested_at` and
   :attr:`InspectorApp.shown_log`, with the uniformity stage on screen (shown as soon as
   it is computed) and with the last live stage on screen (the end of a live run).
   *Browser*: from the Playwright input to the canvas pixels of the target changing, read
   inside the page after each frame it draws (:data:`CANVAS_PROBE`); each input comes 1 s
   after the previous run ended, once the page has drawn what that run sent (typed at
   once, it waited 0.1-0.3 s behind that drawing). Reference: the library alone,
   ``Pipeline.run(until="uniformity")`` with the same change, in the same process.
3. **Clicks while smoothness runs** (512 px demo pair, "Run smoothness now"): a mouse
   click on the "Export parameters" button until its notification shows, and on an object
   in the canvas until the object's heading shows, timed inside the page (a
   MutationObserver, ``performance.now()``), while the smoothness stage computes and, as
   the reference, while idle. The server's part of it (from the callback to the answer
   queued for the page) is timed in the server. Notifications are closed before each
   click: the page shows five at most and queues the next until one closes (after 6 s),
   which made later exports look 0.5-2 s slow.
4. **SIGTERM to exit** of ``radcons inspect`` given a 1024 px pair as two files: the signal
   sent as soon as the server listens (it is starting) and 6 s later (its first run
   computes), timed from the signal to the process gone. Reference: a Python process
   that imported viser and sleeps, ended by SIGTERM's default action.
5. **First result and objects re-tune on real pairs** (:data:`REAL_PAIRS` under
   ``--data``: Kahramanmaras pre-event image 1 + post-event image 2, Gizeh), each trial
   a fresh inspector given the two files (``radcons`` preset, RPC rectification at full
   resolution) with a page open on it at 1600 x 1000: from the inspector's construction
   (which reads the files) to the first final run's pictures queued for the browsers;
   then, once every worker is idle (the review measured) and 1 s more (the page draws
   what the review sent: about 0.9 CPU-s of the browser, which a rule changed at once
   competed with), from an objects rule changed
   (``tree_texture`` x 1.1, which keeps the rectification and the census matching) to
   that run's pictures queued. The library alone is ``bench_first_result.py``; the
   first trial also pays the imports and numba's compilation.

Usage::

    python benchmarks/bench_inspector.py [--repeat 5] [--only startup slider clicks stop realpairs]
                                         [--compare-startup OTHER_CHECKOUT] [--data DIR]
"""

from __future__ import annotations

import argparse
import collections
import os
import select
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

CHROMIUM_ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]


def median(values):
    return statistics.median(values) if values else float("nan")


#: Installs a promise that resolves with the in-page milliseconds from now until the text
#: given as argument is added to the page (a MutationObserver on the whole page that looks
#: at added nodes and changed text only, so that older copies of the text do not count).
WATCH = """(text) => {
    const start = performance.now();
    const holds = (node) => {
        const element = node.nodeType === Node.TEXT_NODE ? node.parentElement : node;
        return element !== null && element.textContent.includes(text);
    };
    window.__answered = new Promise((resolve) => {
        const observer = new MutationObserver((records) => {
            for (const record of records) {
                const nodes = record.type === "characterData" ? [record.target] : [...record.addedNodes];
                if (nodes.some(holds)) { observer.disconnect(); resolve(performance.now() - start); return; }
            }
        });
        observer.observe(document.body, {subtree: true, childList: true, characterData: true});
    });
}"""


def dismiss_notifications(page) -> None:
    """Close the notifications on the page: the page shows at most a few at once and
    queues the next ones until one closes, which would delay an answer being timed."""
    count = "document.querySelectorAll('.mantine-Notification-root').length"
    page.evaluate("document.querySelectorAll('.mantine-Notification-closeButton').forEach((b) => b.click())")
    wait(lambda: page.evaluate(count) == 0, timeout=10.0)


def answered_after_click(page, x: float, y: float, text: str, timeout: float = 60.0) -> float:
    """Seconds from a mouse click at page point ``(x, y)`` until ``text`` shows (in-page
    clock), on a page without notifications."""
    dismiss_notifications(page)
    page.evaluate(WATCH, text)
    page.mouse.click(x, y)
    elapsed = page.evaluate(
        "(limit) => Promise.race([window.__answered, new Promise((r) => setTimeout(() => r(-1), limit))])",
        timeout * 1000,
    )
    if elapsed < 0:
        raise TimeoutError(f"no answer {text!r} within {timeout} s")
    return elapsed / 1000.0


def open_stage(page, stage: str) -> None:
    """Expand a stage's folder of the Tune tab (they start collapsed; the inputs in it are
    used once they show)."""
    page.get_by_text(stage, exact=True).first.click()


def wait(predicate, timeout=300.0, step=0.02):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(step)
    raise TimeoutError("benchmark condition not reached")


def image_box(app, client, image):
    height, width = app.displayed.images[0].shape
    (x0, y0), (x1, y1) = (app.viewport.screen_point(client, image, x, y) for x, y in ((0, 0), (width, height)))
    return int(x0) + 2, int(y0) + 2, int(x1) - 2, int(y1) - 2


def open_page(context, app, probe: bool = False):
    """Open the app's page (with :data:`CANVAS_PROBE` when ``probe``) and wait until it
    shows a computed run framed in its canvas."""
    before = set(app.server.get_clients())
    page = context.new_page()
    if probe:
        page.add_init_script(CANVAS_PROBE)
    page.goto(app.url)
    wait(lambda: set(app.server.get_clients()) - before)
    client = app.server.get_clients()[next(iter(set(app.server.get_clients()) - before))]
    page.get_by_text("Ready · computed", exact=False).first.wait_for(timeout=300_000)
    wait(lambda: app.viewport.framed(client) and abs(client.camera.aspect - _aspect(page)) < 1e-3)
    return page, client


def _aspect(page):
    box = page.locator("canvas").last.bounding_box()
    return box["width"] / box["height"]


# ----------------------------------------------------------------------------- 1


#: Page script (installed before the page's own) to read the viewport canvas inside the
#: page, right after the page draws a frame (an animation-frame callback: a WebGL canvas
#: can be read then without ``preserveDrawingBuffer``, which slowed the page's input
#: handling by 0.27 s), at most every 40 ms; times are the page's clock
#: (``performance.timeOrigin + performance.now()``, ms since the epoch, the machine's wall
#: clock):
#:
#: - ``window.__imageShownAt``: when a window inside the reference image (x 15-40 %,
#:   y 30-70 % of the canvas) first holds an image (grey standard deviation over 8);
#: - ``window.__sampleBox(x, y, width, height)`` (CSS px in the canvas) samples that box
#:   at the next frame (``window.__sampled()``); ``window.__watchChange()`` then sets
#:   ``window.__changedAt`` at the first frame where it differs (mean absolute grey change
#:   over 0.5 on a 64 x 64 sampling). Watching starts once the input has reached the
#:   server, so that reading the canvas does not delay the input.
CANVAS_PROBE = """(() => {
    const probe = document.createElement("canvas");
    probe.width = probe.height = 64;
    const clock = () => performance.timeOrigin + performance.now();
    const viewport = () => {
        const canvases = document.querySelectorAll("canvas");
        const source = canvases[canvases.length - 1];
        return source === undefined || source === probe || source.width < 16 ? null : source;
    };
    // Grey values of a box of the canvas (fractions of its size), sampled at 64 x 64.
    const grey = (source, fx, fy, fw, fh) => {
        const [w, h] = [source.width, source.height];
        const context = probe.getContext("2d", {willReadFrequently: true});
        context.drawImage(source, fx * w, fy * h, fw * w, fh * h, 0, 0, 64, 64);
        const data = context.getImageData(0, 0, 64, 64).data;
        const out = new Float32Array(4096);
        for (let i = 0; i < 4096; i++) out[i] = (data[4 * i] + data[4 * i + 1] + data[4 * i + 2]) / 3;
        return out;
    };
    // Checks run right after the page's own animation-frame callbacks (where it draws
    // the WebGL canvas, whose pixels can be read until the frame is shown), at most
    // one per `every` ms.
    const checks = new Set();
    let last = 0;
    const every = 40;
    const requestFrame = window.requestAnimationFrame.bind(window);
    window.requestAnimationFrame = (callback) => requestFrame((time) => {
        callback(time);
        if (checks.size === 0 || performance.now() - last < every) return;
        last = performance.now();
        const source = viewport();
        if (source !== null) for (const check of [...checks]) check(source);
    });
    window.__imageShownAt = null;
    checks.add(function shown(source) {
        const values = grey(source, 0.15, 0.3, 0.25, 0.4);
        let sum = 0, squares = 0;
        for (const v of values) { sum += v; squares += v * v; }
        const mean = sum / 4096;
        if (squares / 4096 - mean * mean > 64) { window.__imageShownAt = clock(); checks.delete(shown); }
    });
    let watched = null;
    window.__changedAt = null;
    window.__sampleBox = (x, y, width, height) => {
        const box = viewport().getBoundingClientRect();
        watched = {part: [x / box.width, y / box.height, width / box.width, height / box.height], before: null};
        window.__changedAt = null;
        checks.add(function sample(source) { watched.before = grey(source, ...watched.part); checks.delete(sample); });
    };
    window.__sampled = () => watched !== null && watched.before !== null;
    window.__watchChange = () => checks.add(function changed(source) {
        const now = grey(source, ...watched.part);
        let change = 0;
        for (let i = 0; i < 4096; i++) change += Math.abs(now[i] - watched.before[i]);
        if (change / 4096 > 0.5) { window.__changedAt = clock(); checks.delete(changed); }
    });
})();"""


def _image_shown_at(context, url: str) -> float:
    """Open ``url`` in a new page; the wall-clock time (s) at which its image showed."""
    page = context.new_page()
    page.add_init_script(CANVAS_PROBE)
    page.goto(url)
    page.wait_for_function("window.__imageShownAt !== null", timeout=300_000, polling=100)
    shown = page.evaluate("window.__imageShownAt") / 1000.0
    page.close()
    return shown


def _launch(context, checkout: Path) -> tuple[float, float, bool]:
    """Start ``radcons inspect`` from ``checkout``, open its page, stop it with Ctrl+C.

    Returns seconds from the launch to the server listening and to the demo pair shown,
    and whether the process obeyed Ctrl+C within 30 s (it is killed otherwise).
    """
    from inspector.recording import free_port

    port = free_port()
    start = time.time()
    process = subprocess.Popen(
        [sys.executable, "-m", "radcons.cli", "inspect", "--port", str(port), "--record-dir", tempfile.mkdtemp()],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True, cwd=checkout,
    )
    try:
        while True:
            ready, _, _ = select.select([process.stdout], [], [], 120)
            line = process.stdout.readline() if ready else ""
            if not line:
                raise RuntimeError("radcons inspect ended before listening")
            if line.startswith("radcons inspector:"):
                listening = time.time() - start
                break
        visible = _image_shown_at(context, f"http://127.0.0.1:{port}") - start
    finally:
        os.killpg(process.pid, signal.SIGINT)
        try:
            process.wait(30)
            stopped = True
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
            stopped = False
    return listening, visible, stopped


def startup(context, repeat: int, other: Path | None = None) -> dict[str, float]:
    """Launches of this checkout (and, interleaved, of ``other``), then the page alone."""
    from inspector.app import InspectorApp

    here = Path(__file__).resolve().parents[1]
    runs: dict[str, list[tuple[float, float, bool]]] = {"this": [], "other": []}
    for index in range(repeat):
        order = [("this", here)] + ([("other", other)] if other is not None else [])
        for name, checkout in order if index % 2 == 0 else order[::-1]:
            runs[name].append(_launch(context, checkout))
    loaded = []
    app = InspectorApp(port=0, record_dir=tempfile.mkdtemp()).start()
    try:
        app.wait_idle(300)
        for _ in range(repeat):
            time.sleep(1.0)
            start = time.time()
            loaded.append(_image_shown_at(context, app.url) - start)
            app.wait_idle(300)
    finally:
        app.stop()
    figures = {"page": median(loaded)}
    for name, trials in runs.items():
        if trials:
            figures[f"{name} listening"] = median([t[0] for t in trials])
            figures[f"{name} visible"] = median([t[1] for t in trials])
            figures[f"{name} unstopped"] = sum(not t[2] for t in trials)
    return figures


# ----------------------------------------------------------------------------- 2


def slider(context, repeat: int, tmp: Path) -> dict[str, float]:
    from demo_data_gen import generate
    from inspector.app import LIVE_UNTIL, InspectorApp
    from radcons.io import save_pair
    from radcons.pipeline import Pipeline

    folder = tmp / "pair1024"
    save_pair(generate(size=1024, seed=0, scenario="mixed"), folder)
    app = InspectorApp(pairs=[folder], port=0, record_dir=tmp / "rec", preset="paper").start()
    results: dict[str, list[float]] = {
        "server uniformity": [], f"server {LIVE_UNTIL}": [], "browser": [], "input": [], "library": [],
    }
    try:
        assert app.wait_idle(600)
        page, client = open_page(context, app, probe=True)
        page.get_by_role("tab", name="Tune").click()
        open_stage(page, "uniformity")
        row = page.get_by_text("zeta", exact=True).locator("xpath=ancestor::div[.//input[contains(@class, 'NumberInput')]][1]")
        box_input = row.locator("input.mantine-NumberInput-input").first
        values = {"uniformity": [0.5, 0.7, 0.4, 0.9, 0.6, 0.3, 0.85, 0.55, 0.45, 0.65], LIVE_UNTIL: [0.52, 0.72, 0.42, 0.92, 0.62, 0.32, 0.87, 0.57, 0.47, 0.67]}
        for view in ("uniformity", LIVE_UNTIL):
            app.view.stage.value = view
            assert app.wait_idle(120)
            for value in values[view][:repeat]:
                if value == app.session.params.uniformity.zeta:
                    continue
                x0, y0, x1, y1 = image_box(app, client, "target")
                page.evaluate("(box) => window.__sampleBox(...box)", [x0, y0, x1 - x0, y1 - y0])
                wait(lambda: page.evaluate("window.__sampled()"), step=0.05)
                time.sleep(1.0)  # the page draws what the last run sent (a user types after seeing it)
                start_clock = time.time()
                start = time.perf_counter()
                box_input.fill(str(value))
                box_input.press("Enter")
                wait(lambda: app.session.params.uniformity.zeta == value)
                generation = app.context.compute.generation
                results["input"].append(app.requested_at[generation] - start)
                if view == "uniformity":
                    page.evaluate("window.__watchChange()")
                wait(lambda: any(d.generation == generation and d.view == view for d in app.shown_log))
                if view == "uniformity":
                    page.wait_for_function("window.__changedAt !== null", timeout=120_000, polling=50)
                    results["browser"].append(page.evaluate("window.__changedAt") / 1000.0 - start_clock)
                shown = next(d for d in app.shown_log if d.generation == generation and d.view == view)
                results[f"server {view}"].append(shown.shown_at - app.requested_at[generation])
                assert app.wait_idle(120)
        pipeline = Pipeline()
        params = app.session.params
        pipeline.run(app.session.work.pair, params, until=LIVE_UNTIL)
        for value in values["uniformity"][:repeat]:
            changed = params.with_stage("uniformity", zeta=value + 0.011)
            start = time.perf_counter()
            pipeline.run(app.session.work.pair, changed, until="uniformity")
            results["library"].append(time.perf_counter() - start)
        page.close()
    finally:
        app.stop()
    return {name: median(values) for name, values in results.items()}


# ----------------------------------------------------------------------------- 3


def _timed_app(**kwargs):
    """An :class:`InspectorApp` (not started) that records how long its server takes to
    answer: from the export button's callback to its notification queued, from the scene
    click's callback to the object details queued (``app.answers``, ``(what, seconds)``).

    The panels' callbacks are wrapped before :meth:`InspectorApp.start` attaches them.
    """
    from inspector.app import InspectorApp

    app = InspectorApp(**kwargs)
    app.answers = []
    clicked_at = None
    on_export, on_scene_click, refresh = app.export.on_export, app.view.on_scene_click, app.objects.refresh

    def timed_export(event):
        start = time.perf_counter()
        on_export(event)
        app.answers.append(("button", time.perf_counter() - start))

    def timed_scene_click(event):
        nonlocal clicked_at
        clicked_at = time.perf_counter()
        on_scene_click(event)

    def timed_refresh():
        nonlocal clicked_at
        refresh()
        if clicked_at is not None:
            app.answers.append(("click", time.perf_counter() - clicked_at))
            clicked_at = None

    app.export.on_export, app.view.on_scene_click, app.objects.refresh = timed_export, timed_scene_click, timed_refresh
    return app


def responsiveness(context, repeat: int, tmp: Path) -> dict[str, float]:
    app = _timed_app(port=0, demo_size=512, record_dir=tmp / "rec", preset="paper").start()
    results: dict[str, list[float]] = collections.defaultdict(list)
    running = lambda: "Running **smoothness**" in app.context.status.content  # noqa: E731
    try:
        assert app.wait_idle(300)
        page, client = open_page(context, app)
        origin = page.locator("canvas").last.bounding_box()
        run = app.session.run
        # Objects are clicked in the target image (right): notifications stack at the top
        # left of the canvas, over the reference.
        shared = collections.Counter(o.tgt_id for o in run.association.objects)
        associated = [o for o in run.association.objects if o.tgt_id > 0 and shared[o.tgt_id] == 1]
        objects = sorted(associated, key=lambda o: -int((run.objects.target == o.tgt_id).sum()))[:4]
        targets = []
        for obj in objects:
            distance = cv2.distanceTransform((run.objects.target == obj.tgt_id).astype(np.uint8), cv2.DIST_L2, 3)
            row, col = np.unravel_index(int(np.argmax(distance)), distance.shape)
            u, v = app.viewport.screen_point(client, "target", col + 0.5, row + 0.5)
            targets.append((obj.ref_id, origin["x"] + u, origin["y"] + v))
        page.get_by_role("tab", name="Export").click()

        def button_xy() -> tuple[float, float]:
            """Centre of the export button, now (the panels above it change height)."""
            box = page.get_by_role("button", name="Export parameters").bounding_box()
            return box["x"] + box["width"] / 2, box["y"] + box["height"] / 2

        def trials(suffix: str, busy) -> None:
            for index in range(repeat):
                ref_id, x, y = targets[index % len(targets)]
                if app.session.selected == ref_id:
                    ref_id, x, y = targets[(index + 1) % len(targets)]
                if not busy():
                    return
                app.answers.clear()
                seconds = answered_after_click(page, x, y, f"Object {ref_id}")
                wait(lambda: app.answers)
                if busy():
                    results[f"click {suffix}"].append(seconds)
                    results[f"click {suffix} server"].append(app.answers[0][1])
                app.answers.clear()
                path = app.last_export
                seconds = answered_after_click(page, *button_xy(), "Parameters exported")
                wait(lambda: app.last_export != path and app.answers)
                if busy():
                    results[f"button {suffix}"].append(seconds)
                    results[f"button {suffix} server"].append(app.answers[0][1])

        trials("idle", lambda: True)
        app.tuning.on_run_smoothness(type("Event", (), {"client": None})())
        wait(running)
        trials("busy", running)
        page.close()
        app.wait_idle(900)
    finally:
        app.stop()
    return {name: median(values) for name, values in results.items()} | {"samples": len(results["click busy"])}


# ----------------------------------------------------------------------------- 4


def _stopped_after(moment: float, folder: Path) -> float:
    """Start ``radcons inspect`` on a 1024 px pair given as two files, send SIGTERM
    ``moment`` s after it listens; seconds from the signal to the process gone."""
    from inspector.recording import free_port

    process = subprocess.Popen(
        [sys.executable, "-m", "radcons.cli", "inspect", "--port", str(free_port()), "--record-dir", str(folder / "rec"),
         str(folder / "left.png"), str(folder / "right.png")],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    try:
        while not process.stdout.readline().startswith("radcons inspector:"):
            if process.poll() is not None:
                raise RuntimeError("radcons inspect ended before listening")
        time.sleep(moment)
        start = time.perf_counter()
        process.send_signal(signal.SIGTERM)
        process.wait(60)
        return time.perf_counter() - start
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


def _bare_process_stop() -> float:
    """Reference: seconds from SIGTERM to the end of a Python process that imported viser
    and sleeps (SIGTERM's default action: no handler, no clean-up)."""
    process = subprocess.Popen(
        [sys.executable, "-c", "import viser, time; print('ready', flush=True); time.sleep(600)"],
        stdout=subprocess.PIPE, text=True,
    )
    process.stdout.readline()
    start = time.perf_counter()
    process.send_signal(signal.SIGTERM)
    process.wait(60)
    return time.perf_counter() - start


def stopping(repeat: int, tmp: Path) -> dict[str, float]:
    """SIGTERM to process exit: while starting (at once after listening) and while the
    first run computes (6 s after: the 3 s left to a browser are over)."""
    from demo_data_gen import generate

    pair = generate(size=1024, seed=0, scenario="mixed")
    cv2.imwrite(str(tmp / "left.png"), pair.reference.data)
    cv2.imwrite(str(tmp / "right.png"), pair.target.data)
    return {
        "reference": median([_bare_process_stop() for _ in range(repeat)]),
        "starting": median([_stopped_after(0.0, tmp) for _ in range(repeat)]),
        "running": median([_stopped_after(6.0, tmp) for _ in range(repeat)]),
    }


# ----------------------------------------------------------------------------- 5

#: Real pairs timed by :func:`real_pairs`: name -> their two files under ``--data``.
REAL_PAIRS = {
    "Kahramanmaras pre1/post2": ("pleiades_kahramanmaras_prepost/pre_event_img1.tif", "pleiades_kahramanmaras_prepost/post_event_img2.tif"),
    "Gizeh": ("pleiades_gizeh/img1.tif", "pleiades_gizeh/img2.tif"),
}


def _real_pair_trial(context, paths: list[Path], tmp: Path) -> tuple[float, float]:
    """Seconds to the first result and to an objects re-tune, one fresh inspector."""
    from inspector.app import InspectorApp

    start = time.perf_counter()
    app = InspectorApp(pairs=paths, port=0, record_dir=tmp / "rec").start()
    try:
        page = context.new_page()
        page.goto(app.url)
        first = wait(lambda: next((d for d in list(app.shown_log) if d.final), None), timeout=900)
        assert app.wait_idle(900)
        time.sleep(1.0)  # the page draws what the review sent (as in 2: a user changes a rule after seeing it)
        objects = app.session.params.objects
        generation = app.context.compute.generation
        tuned = time.perf_counter()
        app.tuning.on_param_change("objects", {"tree_texture": objects.tree_texture * 1.1}, None)
        retuned = wait(lambda: next((d for d in list(app.shown_log) if d.final and d.generation > generation), None), timeout=900)
        assert retuned.params.objects.tree_texture != objects.tree_texture
        page.close()
        return first.shown_at - start, retuned.shown_at - tuned
    finally:
        app.stop()


def real_pairs(context, repeat: int, tmp: Path, data: Path) -> dict[str, list[tuple[float, float]] | None]:
    """Trials of :func:`_real_pair_trial` per pair of :data:`REAL_PAIRS` (None: absent)."""
    results: dict[str, list[tuple[float, float]] | None] = {}
    for name, files in REAL_PAIRS.items():
        paths = [data / file for file in files]
        results[name] = [_real_pair_trial(context, paths, tmp) for _ in range(repeat)] if all(p.is_file() for p in paths) else None
    return results


SECTIONS = ["startup", "slider", "clicks", "stop", "realpairs"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="trials per measurement (median reported)")
    parser.add_argument("--only", nargs="+", choices=SECTIONS, default=SECTIONS, help="measurements to run")
    parser.add_argument(
        "--compare-startup", type=Path, metavar="CHECKOUT",
        help="another checkout of radcons (e.g. a git worktree of an older commit) whose startup is measured interleaved with this one's",
    )
    parser.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[2] / "shared" / "data", help="folder of the real pairs")
    args = parser.parse_args()
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory() as folder, sync_playwright() as playwright:
        tmp = Path(folder)
        context = playwright.chromium.launch_persistent_context(
            str(tmp / "profile"), executable_path="/usr/bin/chromium", headless=True, args=CHROMIUM_ARGS,
            viewport={"width": 1600, "height": 1000},
        )
        try:
            boot = startup(context, args.repeat, args.compare_startup) if "startup" in args.only else None
            change = slider(context, args.repeat, tmp) if "slider" in args.only else None
            clicks = responsiveness(context, args.repeat, tmp) if "clicks" in args.only else None
            stop = stopping(args.repeat, tmp) if "stop" in args.only else None
            real = real_pairs(context, args.repeat, tmp, args.data) if "realpairs" in args.only else None
        finally:
            context.close()

    print(f"\ninspector latencies, median of {args.repeat} (seconds)\n")
    print(f"{'measurement':58s} {'median s':>9s} {'ratio':>8s}  target")
    if boot is not None:
        page = boot["page"]
        print(f"{'page load alone: idle server, all computed -> image shown':58s} {page:9.3f} {1.0:8.2f}  (reference)")
        for name, label in (("this", "startup"), ("other", "other checkout")):
            if f"{name} visible" not in boot:
                continue
            print(f"{label + ': launch -> server listening':58s} {boot[name + ' listening']:9.3f} {boot[name + ' listening'] / page:8.2f}")
            print(f"{label + ': launch -> demo pair visible':58s} {boot[name + ' visible']:9.3f} {boot[name + ' visible'] / page:8.2f}  < 5 s")
            print(f"{label + ': Ctrl+C not obeyed within 30 s (launches)':58s} {boot[name + ' unstopped']:9d}")
    if change is not None:
        lib = change["library"]
        print(f"{'1024 px, library only: Pipeline.run(until=uniformity)':58s} {lib:9.3f} {1.0:8.2f}  (reference)")
        print(f"{'1024 px, zeta -> uniformity images queued (server)':58s} {change['server uniformity']:9.3f} {change['server uniformity'] / lib:8.2f}  < 1 s")
        print(f"{'1024 px, zeta typed -> request on the server (browser input)':58s} {change['input']:9.3f} {'':>8s}")
        print(f"{'1024 px, zeta typed -> uniformity images on the canvas':58s} {change['browser']:9.3f} {change['browser'] / lib:8.2f}  < 1 s")
        live = next(key for key in change if key.startswith("server ") and key != "server uniformity")
        print(f"{'1024 px, zeta -> ' + live[7:] + ' images queued (server, whole live run)':58s} {change[live]:9.3f} {change[live] / lib:8.2f}")
    if clicks is not None:
        for what, label in (("button", "'Export parameters' -> notification"), ("click", "click an object -> its details")):
            idle, busy = clicks[f"{what} idle"], clicks[f"{what} busy"]
            print(f"{'512 px, ' + label + ', idle':58s} {idle:9.3f} {1.0:8.2f}  (reference)")
            print(f"{'512 px, same while smoothness runs':58s} {busy:9.3f} {busy / idle:8.2f}  < 0.2 s ({clicks['samples']} samples)")
            print(f"{'512 px,   server part (callback -> answer queued), idle':58s} {clicks[what + ' idle server']:9.3f}")
            print(f"{'512 px,   server part while smoothness runs':58s} {clicks[what + ' busy server']:9.3f}")
    if stop is not None:
        ref = stop["reference"]
        print(f"{'SIGTERM -> exit, bare Python process (default action)':58s} {ref:9.3f} {1.0:8.2f}  (reference)")
        print(f"{'SIGTERM -> exit, inspector starting (just listening)':58s} {stop['starting']:9.3f} {stop['starting'] / ref:8.2f}  < 1 s")
        print(f"{'SIGTERM -> exit, inspector computing the first run':58s} {stop['running']:9.3f} {stop['running'] / ref:8.2f}  < 1 s")
    if real is not None:
        print(f"\nreal pairs in the inspector, median of {args.repeat} (seconds; targets: first result <= 8 s, re-tune <= 2 s)\n")
        print("| pair | first result (median) | trials | objects re-tune (median) | trials |")
        print("| --- | --- | --- | --- | --- |")
        for name, trials in real.items():
            if trials is None:
                print(f"| {name} | absent under {args.data} | | | |")
                continue
            firsts, retunes = [t[0] for t in trials], [t[1] for t in trials]
            print(
                f"| {name} | {median(firsts):.1f} | {', '.join(f'{v:.1f}' for v in firsts)} "
                f"| {median(retunes):.2f} | {', '.join(f'{v:.2f}' for v in retunes)} |"
            )

if __name__ == "__main__":
    main()
