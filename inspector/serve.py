"""``radcons inspect``: the inspector run until Ctrl+C or SIGTERM.

Both signals stop it within a second whatever it is doing: the handler raises
:class:`KeyboardInterrupt` in the main thread (also while the server starts), the app is
stopped leaving :data:`STOP_GRACE` seconds to a run or a recording under way, and the
process exits with status 0, at once (:func:`_exit_now`) when a run still computes on its
daemon thread (recordings are written whole or not at all).
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from typing import Any

from inspector.address import listen_port

__all__ = ["serve", "BROWSER_GRACE", "STOP_GRACE"]

#: Seconds ``radcons inspect`` gives a browser opened at launch to load the page before it
#: shows the first pair, builds the panels and processes it
#: (:meth:`inspector.app.InspectorApp.start`).
BROWSER_GRACE = 3.0
#: Seconds left to a run or a recording under way to end once told to stop.
STOP_GRACE = 0.3


def serve(args: argparse.Namespace) -> int:
    """Run the inspector until interrupted (``radcons inspect``).

    Parameters
    ----------
    args : argparse.Namespace
        ``pairs`` (list of Path), ``host``, ``port`` (int or None), ``data_root`` (list of
        Path), ``record_dir`` (Path), ``rerun_web`` (bool), ``band`` (int or None),
        ``rectified`` (bool or None) and ``memory_limit`` (a size such as ``"8G"``, or None).

    Returns
    -------
    int
        Exit status (0 after Ctrl+C or SIGTERM, which stop it within :data:`STOP_GRACE`
        seconds and a little more).

    Raises
    ------
    InputError
        A pair that cannot be read or an address that cannot be listened on, before
        anything listens.
    """
    from radcons.preflight import parse_size

    memory_limit = parse_size(args.memory_limit) if args.memory_limit is not None else None
    listen_port(args.host, args.port)  # a bad address is said before the app is imported (1.5 s)
    from inspector.app import InspectorApp

    app = InspectorApp(
        pairs=list(args.pairs), data_roots=list(args.data_root), record_dir=args.record_dir,
        host=args.host, port=args.port, rerun_web=args.rerun_web, band=args.band, rectified=args.rectified,
        memory_limit=memory_limit,
    )
    stop = threading.Event()

    def interrupted(signum: int, frame: Any) -> None:
        # The event stops the app even when the KeyboardInterrupt is lost (Python drops
        # one raised while a finalizer runs, or under a library's bare ``except:``):
        # a start it did not interrupt goes on, and stop.wait() then returns at once.
        stop.set()
        raise KeyboardInterrupt

    handlers = {}
    if threading.current_thread() is threading.main_thread():
        handlers = {signum: signal.signal(signum, interrupted) for signum in (signal.SIGINT, signal.SIGTERM)}
    try:  # Ctrl+C while starting (the page may already show the pair) stops as well
        app.start(browser_grace=BROWSER_GRACE, on_listening=lambda url: print(f"radcons inspector: {url} (listening on {args.host}:{app.port})", flush=True))
        if app.live is not None:
            print(f"rerun web viewer: {app.live.url}", flush=True)
        stop.wait()
    except KeyboardInterrupt:
        pass
    finally:
        ended = app.stop(STOP_GRACE)
        for signum, handler in handlers.items():
            signal.signal(signum, handler)
    if not ended:  # a stage still computes on a daemon thread: leave without waiting for it
        _exit_now(0)
    return 0


def _exit_now(status: int) -> None:
    """End the process at once (the clean-up is done).

    A stage computing in C (OpenCV, numpy) cannot be interrupted from Python; the
    interpreter's exit waits for it to give the GIL back (0.5-1.5 s measured on a 1024 px
    pair) and OpenCV's thread pool may then abort the process ("terminate called without
    an active exception", status -6). ``os._exit`` skips both.
    """
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)
