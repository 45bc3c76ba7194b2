"""Rerun recordings from the inspector: an ``.rrd`` of the tuning session, and a live viewer.

Both use the project's recorder (:mod:`radcons.record`): the same entities, timelines and
blueprint as ``radcons process --rrd``. Every parameter setting that was computed and
shown is one step of the ``tuning_step`` timeline.
"""

from __future__ import annotations

import os
import queue
import re
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.parse
import uuid
from pathlib import Path
from typing import Any, Sequence

__all__ = ["write_recording", "LiveViewer", "free_port", "file_stem"]


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port that was free on ``host`` a moment ago."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind((host, 0))
        return int(probe.getsockname()[1])


def file_stem(text: str) -> str:
    """``text`` made safe as part of a file name (letters, digits, ``.``, ``_``, ``-``)."""
    return re.sub(r"[^A-Za-z0-9._-]+", "-", text).strip("-")[:60] or "pair"


def write_recording(
    record_dir: str | Path,
    name: str,
    runs: Sequence[tuple[int, Any]],
    comparison: Any = None,
) -> Path:
    """Write one ``.rrd`` holding each ``(tuning_step, run)``, with the recorder's blueprint.

    Parameters
    ----------
    record_dir : path-like
        Folder of the recordings (created if needed).
    name : str
        Pair name, used in the file name.
    runs : sequence of (int, Run)
        The settings tried, oldest first; the last one is the current run.
    comparison : radcons.evaluate.compare.Comparison, optional
        Measurements of the last run next to the original and the baselines.

    Returns
    -------
    Path
        The written file (``<name>-<date>-<time>.rrd``). It is written to a hidden
        partial file beside it and renamed once complete: a write that fails or is
        interrupted leaves no ``.rrd`` (and no partial file, except after ``kill -9``,
        which the next recording into the folder removes).
    """
    from radcons.record import default_blueprint, log_run
    from radcons.record.files import recording_file

    folder = Path(record_dir)
    folder.mkdir(parents=True, exist_ok=True)
    stamp = time.strftime("%Y%m%d-%H%M%S")
    path = folder / f"{file_stem(name)}-{stamp}.rrd"
    counter = 1
    while path.exists():
        path = folder / f"{file_stem(name)}-{stamp}-{counter}.rrd"
        counter += 1
    _remove_stale_parts(folder)
    methods = [m.name for m in comparison.methods] if comparison is not None else []
    with recording_file(path, f"{name} (tuning)", default_blueprint(methods, tuning=len(runs) > 1)) as recording:
        for index, (step, run) in enumerate(runs):
            last = index == len(runs) - 1
            log_run(run, recording, comparison=comparison if last else None, tuning_step=step)
    return path


def _remove_stale_parts(folder: Path) -> None:
    """Remove the partial recordings (``.<name>.<random>.<pid>.part``) of processes no longer running
    (killed while writing); those of a running inspector are left alone."""
    for part in folder.glob(".*.rrd.*.part"):
        pid = part.name.rsplit(".", 2)[-2]
        if pid.isdigit() and not _running(int(pid)):
            part.unlink(missing_ok=True)


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class LiveViewer:
    """A rerun web viewer on 127.0.0.1 that receives every run as a new tuning step.

    The ``rerun`` command is started in its own process group with ``--serve-web`` bound
    to ``host`` (its gRPC proxy and the web viewer, each on a free port), and a recording
    stream connects to it. Runs are logged on a background thread.

    Parameters
    ----------
    host : str
        Address of the viewer and its data port (keep the default: local only).
    start_timeout : float
        Seconds to wait for the viewer to listen.

    Attributes
    ----------
    url : str
        Address of the web viewer.
    """

    def __init__(self, host: str = "127.0.0.1", start_timeout: float = 60.0) -> None:
        import rerun as rr

        from radcons.record import default_blueprint
        from radcons.record.files import APPLICATION_ID

        grpc_port, web_port = free_port(host), free_port(host)
        command = [
            sys.executable, "-m", "rerun_cli", "--serve-web", "--web-viewer-port", str(web_port),
            "--port", str(grpc_port), "--bind", host, "--hide-welcome-screen",
        ]  # fmt: skip
        self._process = subprocess.Popen(
            command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
        )
        deadline = time.monotonic() + start_timeout
        while not (_listening(host, grpc_port) and _listening(host, web_port)):
            if self._process.poll() is not None or time.monotonic() > deadline:
                self._stop_process()
                raise RuntimeError("the rerun web viewer did not start")
            time.sleep(0.1)
        self.stream_url = f"rerun+http://{host}:{grpc_port}/proxy"
        self.url = f"http://{host}:{web_port}/?url={urllib.parse.quote(self.stream_url, safe='')}"
        self.recording = rr.RecordingStream(APPLICATION_ID, recording_id=str(uuid.uuid4()))
        self.recording.set_log_tick_enabled(False)
        self.recording.set_log_time_enabled(False)
        self.recording.connect_grpc(self.stream_url, default_blueprint=default_blueprint(tuning=True))
        self._queue: queue.Queue[tuple[Any, int] | None] = queue.Queue()
        self._thread = threading.Thread(target=self._loop, name="inspector-rerun-live", daemon=True)
        self._thread.start()

    def log(self, run: Any, step: int) -> None:
        """Queue a run for the viewer (logged on a background thread)."""
        self._queue.put((run, step))

    def _loop(self) -> None:
        from radcons.record import log_run

        while True:
            item = self._queue.get()
            if item is None:
                return
            run, step = item
            try:
                log_run(run, self.recording, tuning_step=step)
            except Exception as exc:  # noqa: BLE001 - the viewer is an extra; report and go on
                print(f"radcons inspector: live rerun logging failed: {exc}", file=sys.stderr)

    def stop(self) -> None:
        """Stop logging, close the stream and stop the viewer's process group."""
        self._queue.put(None)
        self._thread.join(5.0)
        self.recording.disconnect()
        self._stop_process()

    def _stop_process(self) -> None:
        """SIGINT to the viewer's group (the ``rerun`` wrapper stops its binary), then
        SIGTERM and SIGKILL for whatever is left after a grace period."""
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
            try:
                os.killpg(self._process.pid, sig)
            except ProcessLookupError:
                break
            try:
                self._process.wait(5.0)
                os.killpg(self._process.pid, 0)
            except ProcessLookupError:
                break
            except subprocess.TimeoutExpired:
                continue
            time.sleep(0.5)
        self._process.wait()


def _listening(host: str, port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.settimeout(0.5)
        return probe.connect_ex((host, port)) == 0
