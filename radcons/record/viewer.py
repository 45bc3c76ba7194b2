"""Serving a recording in the rerun web viewer on this machine (127.0.0.1 only)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from urllib.parse import quote

from radcons.errors import InputError, RadconsError

__all__ = ["view_recording", "viewer_command", "check_recording"]

HOST = "127.0.0.1"
#: First bytes of every rerun recording file.
RRD_MAGIC = b"RRF"
#: Seconds to wait for the viewer to listen, and for each signal to stop it.
START_TIMEOUT = 60.0
STOP_GRACE = 5.0


def check_recording(path: str | Path) -> Path:
    """Return ``path`` if it is a whole, readable rerun recording file, else raise InputError."""
    path = Path(path)
    if not path.exists():
        raise InputError("recording not found", path)
    if not path.is_file():
        raise InputError("not a file (expected a .rrd recording)", path)
    try:
        with path.open("rb") as handle:
            head = handle.read(len(RRD_MAGIC))
    except OSError as exc:
        raise InputError(f"unreadable ({exc.strerror or exc})", path) from exc
    if head != RRD_MAGIC:
        raise InputError("not a rerun recording (.rrd)", path)
    _check_readable(path)
    return path


def _check_readable(path: Path) -> None:
    """Read every chunk of a recording (rerun's own reader, no image decoded), so that a
    truncated or corrupt file is refused rather than served as an empty or partial one.

    Raises
    ------
    InputError
        The reader fails on the file (a frame cut short, a checksum that does not match,
        no recording in it).
    """
    import warnings

    from rerun.chunk import RrdReader

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a file without its footer reads as a stream
            reader = RrdReader(path)
            for _ in reader.stream():
                pass
    except (RuntimeError, ValueError, OSError) as exc:
        detail = str(exc).replace(f" at {path}", "").splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"a corrupt or truncated rerun recording ({detail})", path) from exc


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind((HOST, 0))
        return int(sock.getsockname()[1])


def _check_port(port: int) -> None:
    if isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535:
        raise RadconsError(f"port must be an integer in 1..65535, got {port!r}")
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((HOST, port))
        except OSError as exc:
            raise RadconsError(f"port {port} on {HOST} is not available ({exc.strerror or exc})") from exc


def _listening(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.settimeout(0.5)
        return sock.connect_ex((HOST, port)) == 0


def viewer_command(path: Path, port: int, grpc_port: int) -> list[str]:
    """The ``rerun`` command serving ``path`` to the web viewer on ``port``.

    ``--serve-web`` hosts the viewer without opening a browser (``--web-viewer`` would).
    """
    return [
        sys.executable, "-m", "rerun_cli", str(path),
        "--serve-web", "--web-viewer-port", str(port),
        "--port", str(grpc_port), "--bind", HOST, "--hide-welcome-screen",
    ]  # fmt: skip


def _start(command: list[str], in_main: bool) -> subprocess.Popen:
    """Start ``command`` in its own process group, able to receive SIGINT.

    A process started with SIGINT ignored (a background job of a script) passes that on;
    the ``rerun`` wrapper then could not be asked to stop its binary, so the disposition
    is made the default one for the start.
    """
    ignored = in_main and signal.getsignal(signal.SIGINT) == signal.SIG_IGN
    if ignored:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        return subprocess.Popen(command, stdin=subprocess.DEVNULL, start_new_session=True)
    finally:
        if ignored:
            signal.signal(signal.SIGINT, signal.SIG_IGN)


def _group_gone(process: subprocess.Popen, timeout: float) -> bool:
    """Wait until no process of ``process``'s group is left (reaping ``process``)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        process.poll()
        try:
            os.killpg(process.pid, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.05)
    return False


def _stop_group(process: subprocess.Popen) -> None:
    """Stop the viewer's whole process group: the ``rerun`` wrapper and the binary it runs.

    SIGINT first: the wrapper then kills and reaps the binary itself, so no orphan is left;
    SIGTERM and SIGKILL follow for whatever still runs after a grace period.
    """
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            break
        if _group_gone(process, STOP_GRACE):
            break
    process.wait()


def view_recording(path: str | Path, port: int = 9090) -> int:
    """Serve a recording in the rerun web viewer on ``127.0.0.1:port`` until stopped.

    Prints the viewer's address once it answers (no browser is opened) and blocks until
    Ctrl-C or SIGTERM, then stops every process it started: the ``rerun`` command runs in
    its own process group (it is a wrapper that starts the viewer binary as a child), and
    the group is stopped as a whole.

    Parameters
    ----------
    path : str or Path
        A ``.rrd`` recording.
    port : int
        Port of the web viewer; its data (gRPC) port is any free one.

    Returns
    -------
    int
        0 when stopped by Ctrl-C or SIGTERM, else the viewer's own non-zero exit status.

    Raises
    ------
    InputError
        ``path`` is missing or not a rerun recording.
    RadconsError
        ``port`` is invalid or taken, or the viewer did not start listening.
    """
    path = check_recording(path)
    _check_port(port)
    grpc_port = _free_port()
    stop = threading.Event()
    in_main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, lambda *_: stop.set()) if in_main else None
    process = _start(viewer_command(path, port, grpc_port), in_main)
    try:
        deadline = time.monotonic() + START_TIMEOUT
        while not _listening(port):
            if process.poll() is not None:
                raise RadconsError(f"the rerun viewer exited with status {process.returncode} before serving", path)
            if stop.is_set():
                return 0
            if time.monotonic() > deadline:
                raise RadconsError(f"the rerun viewer did not listen on port {port} within {START_TIMEOUT:.0f} s", path)
            time.sleep(0.1)
        data = quote(f"rerun+http://{HOST}:{grpc_port}/proxy", safe="")
        print(f"rerun web viewer: http://{HOST}:{port}/?url={data}  (Ctrl-C to stop)", flush=True)
        while not stop.wait(0.2):
            if process.poll() is not None:
                return process.returncode or 1
        return 0
    except KeyboardInterrupt:
        return 0
    finally:
        _stop_group(process)
        if in_main:
            signal.signal(signal.SIGTERM, previous)
