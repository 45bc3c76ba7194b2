"""Shared fixtures: the real image data folder and small demo pairs."""

from __future__ import annotations

import os
from pathlib import Path

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
