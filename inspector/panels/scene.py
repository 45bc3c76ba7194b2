"""The Export tab's "Whole scene" folder: apply the tuned parameters to the full-resolution pair.

"Apply to full resolution" runs :func:`radcons.scene.run_scene` (tiles on Dask, bounded
memory) on the whole pair being tuned, whatever part of it the tuning saw (a preview, a
region, or the pair itself), with the session's current parameters, in the background
(:class:`inspector.scene_job.SceneJob`): one run at a time, a progress line, the Dask
dashboard's link, a Cancel button, and the folder written or the error at the end. The
output folder must lie inside the folder holding the inspector's own output folder or
inside a data root.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Sequence

from inspector.context import Context
from inspector.panels.base import Panel
from inspector.scene_job import SceneJob, SceneState
from radcons.errors import InputError

__all__ = ["ScenePanel"]


class ScenePanel(Panel):
    """Controls of a whole-scene run and its progress.

    Parameters
    ----------
    context : Context
    record_dir : path-like
        The inspector's output folder; the default output lies beside it.
    output_roots : sequence of path-like
        Further folders an output may be written in (the data roots).
    reading : dict
        ``band`` and ``rectified`` as the Data tab reads pairs.
    processes : bool
        Local Dask workers as processes (False: threads of this process).
    memory_limit : int, optional
        Bytes the run's local cluster may use (default: the budget of ``radcons process``).

    Attributes
    ----------
    job : SceneJob
        The run (its :attr:`~SceneJob.state` says where it stands).
    """

    def __init__(
        self, context: Context, record_dir: str | Path, output_roots: Sequence[str | Path] = (),
        reading: dict[str, Any] | None = None, processes: bool = True, memory_limit: int | None = None,
    ) -> None:
        super().__init__(context)
        self.memory_limit = memory_limit
        self.home = Path(record_dir).resolve().parent
        self.roots = (self.home, *(Path(root).resolve() for root in output_roots))
        self.reading = {"band": None, "rectified": None, **(reading or {})}
        self.processes = processes
        self.job = SceneJob(self._show)
        self._named_for: str | None = None

    def build(self, gui: Any) -> None:
        """Add the output folder, tile size and workers, the Apply and Cancel buttons and
        the progress line."""
        from radcons.scene import DEFAULT_TILE

        with gui.add_folder("Whole scene"):
            gui.add_markdown(
                "Process the whole pair at full resolution with the current parameters, tile by tile on Dask."
            )
            self.out = gui.add_text("Output folder", str(self.home / "consistent"), hint="A new or earlier output folder")
            self.tile = gui.add_number("Tile size", DEFAULT_TILE, min=64, max=16384, step=64, hint="Tile side, px")
            self.workers = gui.add_number("Workers", os.cpu_count() or 1, min=1, max=256, step=1, hint="Local Dask workers")
            self.apply = gui.add_button("Apply to full resolution")
            self.apply.on_click(self.on_apply)
            self.cancel = gui.add_button("Cancel", disabled=True)
            self.cancel.on_click(self.on_cancel)
            self.progress = gui.add_markdown("")

    def on_pair_loaded(self) -> None:
        """Offer an output folder named after the new pair (beside the inspector's output folder)."""
        from inspector.recording import file_stem

        work = self.context.session.work
        if work is None or self.job.state.active or work.label == self._named_for:
            return  # the same pair at another resolution keeps the folder chosen
        self._named_for = work.label
        name = work.scene.name if work.scene is not None else work.full.name
        self.out.value = str(self.home / f"{file_stem(name)}-consistent")

    def output_folder(self, text: str) -> Path:
        """The output folder typed in, resolved, if it lies inside an allowed folder.

        Raises
        ------
        InputError
            Empty, or outside every allowed folder.
        """
        if not text.strip():
            raise InputError("type an output folder first")
        path = Path(text.strip()).expanduser()
        resolved = (path if path.is_absolute() else self.home / path).resolve()
        if not any(resolved == root or root in resolved.parents for root in self.roots):
            allowed = ", ".join(str(root) for root in self.roots)
            raise InputError(f"the output folder must lie inside {allowed}", resolved)
        return resolved

    def _source(self) -> tuple[Any, dict[str, Any]]:
        """What the run reads: the scene as its previews read it (rows levelled once), the loaded pair's files, or the pair itself."""
        work = self.context.session.work
        if work is None:
            raise InputError("no pair is loaded")
        if work.scene is not None:
            return work.scene.levelled, dict(work.scene.reading)
        full = work.full
        reading = {**self.reading, "rectified": full.rectified}
        if full.source is not None:
            return [full.source], reading
        if full.reference.path is not None and full.target.path is not None:
            return [full.reference.path, full.target.path], reading
        return full, reading

    def on_apply(self, event: Any) -> None:
        """Start the whole-scene run (one at a time)."""
        from radcons import preflight
        from radcons.errors import RadconsError
        from radcons.scene import SceneOptions

        if self.job.state.active:
            self.context.notify(event.client, "Scene run", "A scene run is under way already.", error=False)
            return
        try:
            out = self.output_folder(self.out.value)
            options = SceneOptions(
                tile=int(self.tile.value), workers=max(1, int(self.workers.value)),
                memory_limit=self.memory_limit or preflight.memory_budget(), processes=self.processes,
            )
            pair, reading = self._source()
        except RadconsError as exc:
            self.context.notify(event.client, "Cannot apply to full resolution", str(exc))
            return
        with self.context.session.lock:
            params = self.context.session.params
        self.job.start(pair, out, params, options, reading)

    def on_cancel(self, event: Any) -> None:
        """Stop the run at its next progress report; the output folder keeps its content."""
        self.job.cancel()

    def _show(self, state: SceneState) -> None:
        """Show a run's progress, dashboard and result (on the run's thread)."""
        self.apply.disabled = state.active
        self.cancel.disabled = state.phase != "running"
        self.progress.content = progress_text(state)
        if state.phase in ("done", "failed"):
            title = "Scene written" if state.phase == "done" else "Scene run failed"
            self.context.notify(None, title, state.message, error=state.phase == "failed")

    @property
    def busy(self) -> bool:
        """True while a scene run is under way."""
        return self.job.busy

    def stop(self, timeout: float) -> bool:
        """Cancel a run under way and wait ``timeout`` s at most for it; True when none runs."""
        self.job.cancel()
        return self.job.wait(timeout)


def progress_text(state: SceneState) -> str:
    """The progress line of a scene run, in markdown."""
    lines = []
    if state.out is not None and state.phase != "idle":
        lines.append(f"Output: `{state.out}`")
    if state.active:
        where = f"{state.step} {state.done}/{state.total}" if state.total else state.step
        lines.append(f"{'Cancelling' if state.phase == 'cancelling' else 'Running'}: **{where}**")
    if state.phase != "idle" and state.dashboard is not None:
        lines.append(f"Dask dashboard: [{state.dashboard}]({state.dashboard})")
    elif state.active and state.step not in ("starting", ""):
        lines.append("Dask dashboard: none served by the scheduler")
    if state.message:
        lines.append(f"Failed: {state.message}" if state.phase == "failed" else state.message)
    return "  \n".join(lines)
