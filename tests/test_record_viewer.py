"""`radcons view FILE`: the rerun web viewer renders a recording in a real browser and stops cleanly."""

from __future__ import annotations

import os
import queue
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from urllib.parse import parse_qs, urlparse

import cv2
import numpy as np
import pytest

from conftest import wait_until
from radcons.io import Pair, Raster
from radcons.params import Params
from radcons.pipeline import Run
from radcons.record import save_recording
from radcons.results import StageImages

RADCONS = Path(sys.executable).with_name("radcons")
#: Console errors of the viewer reaching for rerun.io (examples, fonts) on a machine offline.
OFFLINE_NOISE = ("net::ERR_NAME_NOT_RESOLVED", "net::ERR_INTERNET_DISCONNECTED", "Failed to fetch")

def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def alive(pid: int) -> bool:
    """True while ``pid`` runs (a zombie, dead but not yet reaped, does not count)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state != "Z"


def descendants(pid: int) -> set[int]:
    """Every live process below ``pid`` in the process tree."""
    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parents[int(entry.name)] = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (FileNotFoundError, ProcessLookupError, IndexError):
                continue
    found, frontier = set(), {pid}
    while frontier:
        children = {child for child, parent in parents.items() if parent in frontier} - found
        found |= children
        frontier = children
    return {p for p in found if alive(p)}


def listening(port: int) -> bool:
    with socket.socket() as sock:
        sock.settimeout(0.5)
        return sock.connect_ex(("127.0.0.1", port)) == 0


def small_recording(folder: Path) -> Path:
    rng = np.random.default_rng(0)
    reference = rng.integers(0, 2048, (48, 64)).astype(np.uint16)
    target = rng.integers(0, 2048, (48, 64)).astype(np.uint16)
    pair = Pair(Raster(reference), Raster(target), name="viewer-test")
    images = StageImages(reference.astype(np.float32), target.astype(np.float32), {})
    run = Run(pair=pair, params=Params(), working_pair=pair, results={"original": images}, timings={})
    return save_recording(run, folder / "viewer.rrd")


def _interruptible() -> None:
    """Ctrl-C reaches the child as at a terminal, even when the suite runs as a background job
    (whose commands inherit SIGINT ignored, and ``radcons view`` rightly keeps it so)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def start_view(path: Path, port: int) -> tuple[subprocess.Popen, str]:
    """Run ``radcons view`` as a user would; return the process and the address it prints."""
    process = subprocess.Popen(
        [str(RADCONS), "view", str(path), "--port", str(port)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
        preexec_fn=_interruptible,
    )
    lines: queue.Queue[str] = queue.Queue()
    threading.Thread(target=lambda: [lines.put(line) for line in process.stdout], daemon=True).start()
    deadline = time.monotonic() + 120
    try:
        while True:
            line = lines.get(timeout=max(0.1, deadline - time.monotonic()))
            if line.startswith("rerun web viewer: "):
                return process, line.split()[3]
    except queue.Empty:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
        raise AssertionError("radcons view printed no address within 120 s") from None


def assert_all_stopped(pids: set[int], port: int) -> None:
    deadline = time.monotonic() + 10
    while any(alive(pid) for pid in pids) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert [pid for pid in pids if alive(pid)] == []
    assert not listening(port)


def kill_leftovers(process: subprocess.Popen, pids: set[int]) -> None:
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    for pid in pids:
        if alive(pid):
            os.kill(pid, signal.SIGKILL)


@pytest.mark.slow
def test_ctrl_c_stops_the_viewer_and_the_binary_it_started(tmp_path):
    port = free_port()
    process, url = start_view(small_recording(tmp_path), port)
    started = descendants(process.pid)
    try:
        assert urlparse(url).hostname == "127.0.0.1" and urlparse(url).port == port
        assert len(started) >= 2 and listening(port)  # the rerun wrapper and the viewer binary
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=60) == 0
        assert_all_stopped(started, port)
    finally:
        kill_leftovers(process, started)


@pytest.mark.browser
@pytest.mark.slow
def test_view_renders_in_a_browser_and_stops_every_process(browser, tmp_path):
    port = free_port()
    process, url = start_view(small_recording(tmp_path), port)
    started: set[int] = set()
    try:
        assert urlparse(url).hostname == "127.0.0.1" and urlparse(url).port == port
        started = descendants(process.pid)
        assert len(started) >= 2  # the rerun wrapper and the viewer binary it starts

        data_port = urlparse(parse_qs(urlparse(url).query)["url"][0].removeprefix("rerun+")).port

        page = browser()
        page.set_default_timeout(180_000)  # the wasm viewer draws in software; slow on a busy machine
        page_errors, console_errors, failed_local = [], [], []
        page.on("pageerror", lambda error: page_errors.append(str(error)))
        page.on("console", lambda msg: console_errors.append(msg.text) if msg.type == "error" else None)
        page.on(
            "requestfailed",
            lambda request: failed_local.append(request.url)
            if urlparse(request.url).hostname in ("127.0.0.1", "localhost")
            else None,
        )
        # the viewer reads the recording from the data server that `radcons view` started
        with page.expect_request(lambda r: urlparse(r.url).port == data_port and "ReadMessages" in r.url):
            page.goto(url)
        canvas = page.locator("canvas#the_canvas_id.visible")
        canvas.wait_for(state="visible")
        width, height = canvas.evaluate("c => [c.width, c.height]")
        assert width > 600 and height > 400

        def drawn() -> np.ndarray | None:
            """The page's pixels once the viewer has drawn something, else None."""
            shot = cv2.imdecode(np.frombuffer(page.screenshot(), np.uint8), cv2.IMREAD_GRAYSCALE)
            return shot if shot.std() > 10 else None

        pixels = wait_until(drawn, timeout=180, what="the viewer to draw what it received (a page that is not blank)")
        assert pixels.std() > 10  # something is drawn, not a blank page
        assert page_errors == []
        assert failed_local == []
        assert [e for e in console_errors if not any(noise in e for noise in OFFLINE_NOISE)] == []

        process.send_signal(signal.SIGTERM)
        assert process.wait(timeout=60) == 0
        assert_all_stopped(started, port)
    finally:
        kill_leftovers(process, started)
