"""One whole-scene run at a time, on a thread of its own: "Apply to full resolution".

:class:`SceneJob` runs :func:`radcons.scene.run_scene` with tuned parameters in a daemon
thread, so that the inspector stays responsive; the run's progress callback keeps
:attr:`SceneJob.state` up to date and tells the caller (``on_change``), and raises
:class:`SceneCancelled` once :meth:`SceneJob.cancel` was asked, which stops the run and
leaves the output folder as it was.
"""

from __future__ import annotations

import os
import tempfile
import threading
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable, Sequence

from radcons.errors import RadconsError

__all__ = ["SceneJob", "SceneState", "SceneCancelled"]

#: Scheduling niceness of the run's thread (and the Dask threads it starts): the GUI goes first.
NICE = 10


class SceneCancelled(Exception):
    """Raised from the progress callback to stop a run that was asked to cancel."""


@dataclass(frozen=True)
class SceneState:
    """Where the current (or last) scene run stands.

    Attributes
    ----------
    phase : str
        ``"idle"``, ``"running"``, ``"cancelling"``, ``"done"``, ``"cancelled"`` or ``"failed"``.
    step : str
        Last step reported by :func:`radcons.scene.run_scene` (``"tiles"``, ...).
    done, total : int
        Progress within ``step``.
    dashboard : str or None
        Address of the Dask dashboard (None when the cluster serves none).
    out : Path or None
        The output folder.
    message : str
        The result in words (the folder written, or the error).
    summary : dict or None
        The run's summary when it finished.
    """

    phase: str = "idle"
    step: str = ""
    done: int = 0
    total: int = 0
    dashboard: str | None = None
    out: Path | None = None
    message: str = ""
    summary: dict[str, Any] | None = None

    @property
    def active(self) -> bool:
        """True while a run is under way."""
        return self.phase in ("running", "cancelling")


class SceneJob:
    """Runs one scene at a time in the background.

    Parameters
    ----------
    on_change : callable
        ``on_change(state)`` after every change of :attr:`state` (on the run's thread).
    """

    def __init__(self, on_change: Callable[[SceneState], None]) -> None:
        self.on_change = on_change
        self.state = SceneState()
        self._lock = threading.Lock()
        self._cancel = threading.Event()
        self._thread: threading.Thread | None = None

    @property
    def busy(self) -> bool:
        """True while a run's thread is alive."""
        return self._thread is not None and self._thread.is_alive()

    def start(self, pair: Sequence[Path] | Any, out: Path, params: Any, options: Any, reading: dict[str, Any]) -> bool:
        """Start a run unless one is under way; True when started.

        Parameters
        ----------
        pair : sequence of Path, radcons.scene.ScenePair or radcons.io.Pair
            A pair folder or two image files; an opened scene pair whose rows were
            levelled already (:attr:`inspector.scene_preview.SceneSource.levelled`, its
            ``rows`` metadata set), which the run takes as it is instead of measuring
            the offset again; or an in-memory pair (written to a temporary folder first,
            so that the scene code reads it by windows like any file).
        out : Path
            Output pair folder (replaced whole at the end, or left as it was).
        params : radcons.params.Params
        options : radcons.scene.SceneOptions
        reading : dict
            ``band`` and ``rectified`` for :func:`radcons.scene.open_scene_pair`.
        """
        with self._lock:
            if self.busy:
                return False
            self._cancel.clear()
            self._set(SceneState("running", "starting", out=out))
            self._thread = threading.Thread(
                target=self._run, args=(pair, out, params, options, reading), name="inspector-scene", daemon=True
            )
            self._thread.start()
        return True

    def cancel(self) -> bool:
        """Ask the run to stop at its next progress report; True when one was running."""
        if not self.busy:
            return False
        self._cancel.set()
        self._set(replace(self.state, phase="cancelling"))
        return True

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for the run's thread; True when none is running any more."""
        if self._thread is not None:
            self._thread.join(timeout)
        return not self.busy

    def _set(self, state: SceneState) -> None:
        self.state = state
        self.on_change(state)

    def _progress(self, step: str, done: Any, total: int) -> None:
        """``run_scene``'s progress callback: record it, or raise to cancel."""
        if self._cancel.is_set():
            raise SceneCancelled
        if step == "dashboard":
            self._set(replace(self.state, dashboard=done))
            return
        self._set(replace(self.state, step=step, done=int(done), total=int(total)))

    def _run(self, pair: Any, out: Path, params: Any, options: Any, reading: dict[str, Any]) -> None:
        if hasattr(os, "setpriority"):
            try:
                os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), NICE)
            except OSError:
                pass  # not permitted here: run at the normal priority
        try:
            with tempfile.TemporaryDirectory(prefix="radcons-scene-") as scratch:
                result = self._run_scene(pair, Path(scratch), out, params, options, reading)
        except SceneCancelled:
            self._set(replace(self.state, phase="cancelled", message=f"Cancelled; {out} was left as it was."))
        except Exception as exc:  # noqa: BLE001 - shown to the user
            from inspector.context import failure_reason

            reason = failure_reason(exc, print_trace=not isinstance(exc, RadconsError))
            self._set(replace(self.state, phase="failed", message=reason))
        else:
            summary = result.summary
            message = (
                f"Wrote {result.manifest.parent} ({summary['tiles']} tiles of {summary['tile']} px, "
                f"{summary['timings_s']['total']:.1f} s)"
            )
            self._set(replace(self.state, phase="done", message=message, summary=summary))

    def _run_scene(self, pair: Any, scratch: Path, out: Path, params: Any, options: Any, reading: dict[str, Any]) -> Any:
        from radcons.io import Pair, save_pair
        from radcons.scene import ScenePair, open_scene_pair, run_scene

        if isinstance(pair, ScenePair):
            measured = "rows" in (pair.metadata or {})
            return run_scene(pair, out, params, replace(options, level_rows=options.level_rows and not measured),
                             progress=self._progress)
        if isinstance(pair, Pair):
            args: Sequence[Path] = [save_pair(pair, scratch / "pair", image_suffix=".tif")]
        else:
            args = pair
        scene = open_scene_pair(args, band=reading.get("band"), rectified=reading.get("rectified"))
        return run_scene(scene, out, params, options, progress=self._progress)
