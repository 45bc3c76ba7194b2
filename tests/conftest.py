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
