"""Shared fixtures: the real image data folder and small demo pairs."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]


def shared_data_dir() -> Path | None:
    """The real image data of ``shared/data`` beside the checkout, or ``$RADCONS_DATA``."""
    candidates = [os.environ.get("RADCONS_DATA"), REPO.parent / "shared" / "data"]
    for candidate in candidates:
        if candidate and Path(candidate).is_dir():
            return Path(candidate)
    return None


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """Path of the real data folder; skips the test where it is absent."""
    folder = shared_data_dir()
    if folder is None:
        pytest.skip("real image data (shared/data beside the checkout, or $RADCONS_DATA) is absent")
    return folder


CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


@pytest.fixture(scope="session")
def compiled_kernels() -> None:
    """Compile the smoothness stage's numba kernels once, before any server starts.

    A fresh checkout has no numba cache; compiling holds the GIL for many seconds, during
    which an in-process server answers nobody. Users meet this once (the cache persists);
    tests that time a browser round trip must not.
    """
    from demo_data_gen import generate
    from radcons.params import Params
    from radcons.pipeline import Pipeline

    Pipeline(Params.from_preset("paper")).run(generate(size=96, seed=0, scenario="mixed"))


@pytest.fixture()
def browser(tmp_path_factory, compiled_kernels):
    """A headless Debian Chromium context driven by Playwright; yields a factory of pages.

    Each call of the yielded function opens a new page (a new browser client).
    """
    if not CHROMIUM.exists():
        pytest.skip("Debian's chromium is not installed (./dev test installs it)")
    from playwright.sync_api import sync_playwright

    profile = tmp_path_factory.mktemp("chromium-profile")
    with sync_playwright() as p:
        context = p.chromium.launch_persistent_context(
            str(profile),
            executable_path=str(CHROMIUM),
            headless=True,
            args=CHROMIUM_ARGS,
            viewport={"width": 1400, "height": 900},
        )
        try:
            yield context.new_page
        finally:
            context.close()


# ----------------------------------------------------------------------------- waiting on state


def wait_until(predicate: Callable[[], Any], timeout: float = 90.0, what: str = "condition", interval: float = 0.05) -> Any:
    """Poll ``predicate()`` until it returns a true value (any numpy array counts) and return it.

    The one way tests wait for what a worker thread, a background job, another process or
    a browser fills in asynchronously: on the state itself, never a fixed sleep.

    Raises
    ------
    AssertionError
        After ``timeout`` s, naming ``what`` was waited for and the last value seen.
    """
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if isinstance(value, np.ndarray) or value:
            return value
        if time.monotonic() >= deadline:
            raise AssertionError(f"timed out after {timeout:g} s waiting for {what} (last value: {value!r:.200})")
        time.sleep(interval)


def wait_for_run(app: Any, timeout: float = 180.0) -> Any:
    """The inspector's shown run (``app.session.run``), once its compute worker published it.

    Fails at once, with the inspector's status line (which says why), when the compute
    worker has finished without a run: the pipeline raised (``Processing failed: ...``), so
    no wait would bring one.
    """
    def settled() -> bool:
        session = app.session
        return session is not None and (session.run is not None or not app.context.compute.busy)

    wait_until(settled, timeout, what="the inspector's compute worker to publish a run")
    run = app.session.run
    if run is None:
        status = app.context.status.content if app.context.status is not None else "(no status line)"
        raise AssertionError(f"the inspector's compute worker finished without a run; its status line says: {status}")
    return run


def wait_for_shown_params(app: Any, timeout: float = 180.0) -> Any:
    """What the inspector shows (``app.displayed``) once it is the final run of the
    session's current parameters, every worker idle.

    A parameter reaches ``app.session.params`` a moment before its run is asked for, so
    ``app.wait_idle()`` right after seeing it may return before that run exists.
    """
    def shown() -> Any:
        displayed = app.displayed
        ready = displayed is not None and displayed.final and displayed.params == app.session.params
        return ready and displayed

    wait_until(shown, timeout, what="a final run of the session's parameters on screen")
    assert app.wait_idle(timeout)
    return app.displayed
