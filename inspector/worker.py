"""A background worker whose queue holds one request: the newest one wins.

GUI callbacks must return at once, so every computation runs on a worker thread. While a
job runs, further requests do not queue up: each replaces the pending one (rapid slider
moves coalesce into the last value). Every request carries a generation number; a job that
finishes after a newer request arrived is *stale* and its result is dropped, so a view
never goes back to an older setting.
"""

from __future__ import annotations

import os
import threading
import traceback
from dataclasses import dataclass
from typing import Any, Callable

__all__ = ["LatestWorker", "Job"]


@dataclass
class Job:
    """One request to the worker.

    Attributes
    ----------
    generation : int
        Increasing number given at submission.
    compute : callable
        ``compute(job) -> result``, run on the worker thread.
    deliver : callable or None
        ``deliver(job, result)``, run on the worker thread when the job is still the newest.
    fail : callable or None
        ``fail(job, exception)`` for an exception raised by ``compute`` or ``deliver``
        (stale or not: errors are never hidden).
    label : str
        What the job does, for progress displays.
    """

    generation: int
    compute: Callable[["Job"], Any]
    deliver: Callable[["Job", Any], None] | None = None
    fail: Callable[["Job", BaseException], None] | None = None
    label: str = ""


class LatestWorker:
    """Run jobs one at a time on a daemon thread, keeping only the newest pending job.

    Parameters
    ----------
    name : str
        Thread name.
    nice : int
        Scheduling niceness of the thread (Linux; 0 keeps the process's). A positive
        value lets the GUI thread, and a browser on the same machine, go first; threads
        that the jobs start (OpenCV, numba) inherit it.

    Examples
    --------
    >>> worker = LatestWorker("demo")
    >>> generation = worker.submit(lambda job: 2 + 2, lambda job, result: print(result))
    >>> worker.wait_idle(5.0)
    4
    True
    >>> worker.stop()
    """

    def __init__(self, name: str, nice: int = 0) -> None:
        self._condition = threading.Condition()
        self._pending: Job | None = None
        self._running: Job | None = None
        self._generation = 0
        self._stopped = False
        self.completed = 0
        self.dropped = 0
        self._nice = nice
        self._thread = threading.Thread(target=self._loop, name=name, daemon=True)
        self._thread.start()

    @property
    def generation(self) -> int:
        """Generation number of the newest submitted job."""
        with self._condition:
            return self._generation

    @property
    def busy(self) -> bool:
        """True while a job runs or waits."""
        with self._condition:
            return self._running is not None or self._pending is not None

    def is_current(self, job: Job) -> bool:
        """True when no job was submitted after ``job``."""
        with self._condition:
            return job.generation == self._generation

    def submit(
        self,
        compute: Callable[[Job], Any],
        deliver: Callable[[Job, Any], None] | None = None,
        fail: Callable[[Job, BaseException], None] | None = None,
        label: str = "",
    ) -> int:
        """Queue a job, replacing any job still waiting; return its generation number."""
        with self._condition:
            if self._stopped:
                raise RuntimeError("the worker was stopped")
            self._generation += 1
            if self._pending is not None:
                self.dropped += 1
            self._pending = Job(self._generation, compute, deliver, fail, label)
            self._condition.notify_all()
            return self._generation

    def wait_idle(self, timeout: float | None = None) -> bool:
        """Block until no job runs or waits; return False on timeout."""
        with self._condition:
            return self._condition.wait_for(
                lambda: self._pending is None and self._running is None, timeout
            )

    def stop(self, timeout: float = 5.0) -> bool:
        """Drop the pending job, let the running one end (``timeout`` s at most) and stop
        the thread; True when the thread has ended."""
        with self._condition:
            self._stopped = True
            self._pending = None
            self._condition.notify_all()
        if threading.current_thread() is not self._thread:
            self._thread.join(timeout)
        return not self._thread.is_alive()

    def _loop(self) -> None:
        if self._nice and hasattr(os, "setpriority"):
            try:
                os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), self._nice)
            except OSError:
                pass  # not permitted here: run at the normal priority
        while True:
            with self._condition:
                self._condition.wait_for(lambda: self._pending is not None or self._stopped)
                if self._stopped:
                    self._condition.notify_all()
                    return
                job, self._pending = self._pending, None
                self._running = job
            try:
                result = job.compute(job)
                if self.is_current(job):
                    if job.deliver is not None:
                        job.deliver(job, result)
                else:
                    self.dropped += 1
            except BaseException as exc:  # noqa: BLE001 - reported through ``fail``
                if job.fail is not None:
                    try:
                        job.fail(job, exc)
                    except Exception:  # noqa: BLE001 - a failing error handler must not kill the thread
                        traceback.print_exc()
                else:
                    traceback.print_exc()
            finally:
                with self._condition:
                    self._running = None
                    self.completed += 1
                    self._condition.notify_all()
