"""Rerun recordings of every stage of a run, for side-by-side review, disparity review and reports.

* :func:`log_run` logs a finished :class:`radcons.pipeline.Run` (and optionally a
  :class:`radcons.evaluate.compare.Comparison`) to any rerun ``RecordingStream``, without
  recomputing anything; the inspector uses it with ``tuning_step`` for each setting.
* :func:`save_recording` writes one run to an ``.rrd`` file, atomically, with
  :func:`default_blueprint`.
* :func:`view_recording` serves an ``.rrd`` in the rerun web viewer on 127.0.0.1.

The entity tree, timelines and layout are described in :mod:`radcons.record.layout`;
images whose longest side exceeds :data:`PREVIEW_MAX_SIDE` pixels are logged as reduced
previews unless ``full_resolution`` is asked (:mod:`radcons.record.raster`).

Names are imported on first use, so that ``radcons view`` starts without loading rerun's
SDK or the pipeline.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = ["log_run", "save_recording", "view_recording", "default_blueprint", "check_recording", "PREVIEW_MAX_SIDE"]

_HOME = {
    "log_run": "radcons.record.log",
    "save_recording": "radcons.record.files",
    "view_recording": "radcons.record.viewer",
    "check_recording": "radcons.record.viewer",
    "default_blueprint": "radcons.record.layout",
    "PREVIEW_MAX_SIDE": "radcons.record.raster",
}


def __getattr__(name: str) -> Any:
    if name not in _HOME:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(_HOME[name]), name)


def __dir__() -> list[str]:
    return sorted(__all__)
