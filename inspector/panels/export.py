"""The Export tab: a rerun recording of the tuning session, the parameters as TOML, and
the optional live rerun viewer that follows every run.

A recording holds every setting tried on the current pair (:attr:`Session.history`, older
runs recomputed) and the review of the shown run; it is written on its own thread. The
parameter file is what ``radcons process --params`` reads; it is also sent to the browser.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

from inspector.context import Context, failure_reason
from inspector.panels.base import Panel
from inspector.review import Review, object_pairs

__all__ = ["ExportPanel"]


class ExportPanel(Panel):
    """Writes recordings and parameter files.

    Parameters
    ----------
    context : Context
    record_dir : path-like
        Where recordings and parameter files are written.

    Attributes
    ----------
    last_recording, last_export : Path or None
        The files written last.
    live : inspector.recording.LiveViewer or None
        The live rerun viewer (:meth:`start_live_viewer`).
    """

    def __init__(self, context: Context, record_dir: str | Path) -> None:
        super().__init__(context)
        self.record_dir = Path(record_dir)
        self.last_recording: Path | None = None
        self.last_export: Path | None = None
        self.live: Any = None
        self._thread: threading.Thread | None = None

    def build(self, gui: Any) -> None:
        """Add the record and export buttons and where their files went."""
        self.record_button = gui.add_button("Record to rerun", hint="Write the current run and every setting tried to an .rrd")
        self.record_button.on_click(self.on_record)
        self.export_button = gui.add_button("Export parameters", hint="Write the TOML that `radcons process --params` reads")
        self.export_button.on_click(self.on_export)
        self.info = gui.add_markdown("")

    def start_live_viewer(self) -> None:
        """Serve a rerun web viewer on 127.0.0.1 that follows every finished run."""
        from inspector.recording import LiveViewer

        self.live = LiveViewer()
        self.info.content = self._info_text()

    def on_published(self, run: Any, final: bool, step: int | None) -> None:
        """Send a finished run to the live viewer."""
        if final and self.live is not None:
            self.live.log(run, step)

    @property
    def busy(self) -> bool:
        """True while a recording is being written."""
        return self._thread is not None and self._thread.is_alive()

    def wait(self, timeout: float) -> None:
        """Wait up to ``timeout`` s for a recording being written."""
        if self._thread is not None:
            self._thread.join(timeout)

    def stop(self, timeout: float = 30.0) -> bool:
        """Let a recording finish (``timeout`` s at most) and stop the live viewer; True
        unless a recording is still being written."""
        self.wait(timeout)
        if self.live is not None:
            self.live.stop()
        return not self.busy

    # ------------------------------------------------------------------ recording

    def on_record(self, event: Any) -> None:
        """Write a recording on a thread of its own (one at a time)."""
        if self.busy:
            self.context.notify(event.client, "Recording", "A recording is being written already.", error=False)
            return
        self._thread = threading.Thread(target=self._record, args=(event.client,), name="inspector-record", daemon=True)
        self._thread.start()

    def _record(self, client: Any) -> None:
        from radcons.pipeline import Pipeline

        session = self.context.session
        with session.lock:
            work, run, history, review = session.work, session.run, list(session.history), session.review
        if work is None or run is None:
            self.context.notify(client, "Nothing to record", "No run has finished yet.")
            return
        try:
            from inspector.recording import write_recording

            pipeline = Pipeline()
            runs = [
                (entry.step, entry.run if entry.run is not None else pipeline.run(work.pair, entry.params, until=entry.until))
                for entry in history[:-1]
            ]
            runs.append((history[-1].step if history else 0, run))
            path = write_recording(self.record_dir, work.full.name, runs, self._comparison(run, review))
        except Exception as exc:  # noqa: BLE001 - reported to the user
            self.context.notify(client, "Recording failed", failure_reason(exc))
            return
        self.last_recording = path
        self.info.content = self._info_text()
        self.context.notify(client, "Recording written", f"{path} ({len(runs)} tuning steps)", error=False)

    @staticmethod
    def _comparison(run: Any, review: Review | None) -> Any:
        """A :class:`radcons.evaluate.compare.Comparison` of the review, for the recorder."""
        if review is None:
            return None
        from radcons.evaluate.compare import Comparison
        from radcons.evaluate.matching import matcher_params

        methods = [m for m in review.others if m.name != review.current.name] + [review.current]
        matcher = matcher_params(review.matcher)
        return Comparison(run.pair.name, tuple(methods), object_pairs(run), review.disparity_range, matcher, 1.0, review.truth is not None)

    # ------------------------------------------------------------------ parameters

    def on_export(self, event: Any) -> None:
        """Write the session's parameters as TOML and send the file to the browser."""
        from inspector.recording import file_stem

        session = self.context.session
        with session.lock:
            params, work = session.params, session.work
        name = file_stem(work.full.name if work is not None else "radcons")
        stamp = time.strftime("%Y%m%d-%H%M%S")
        path = self.record_dir / f"{name}-params-{stamp}.toml"
        counter = 1
        while path.exists():
            path = self.record_dir / f"{name}-params-{stamp}-{counter}.toml"
            counter += 1
        try:
            params.save(path)
        except OSError as exc:
            self.context.notify(event.client, "Export failed", str(exc))
            return
        self.last_export = path
        self.info.content = self._info_text()
        self.context.notify(event.client, "Parameters exported", f"{path} — use it with `radcons process --params`", error=False)
        if event.client is not None:
            event.client.send_file_download(path.name, path.read_bytes(), save_immediately=True)

    def _info_text(self) -> str:
        lines = []
        if self.live is not None:
            lines.append(f"Live rerun viewer: [{self.live.url}]({self.live.url})")
        if self.last_recording is not None:
            lines.append(f"Recording: `{self.last_recording}`  \nopen with `radcons view {self.last_recording}`")
        if self.last_export is not None:
            lines.append(f"Parameters: `{self.last_export}`  \nuse with `radcons process PAIR --params {self.last_export} --out OUT`")
        return "\n\n".join(lines)
