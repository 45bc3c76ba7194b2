"""The Dask cluster a scene run uses: a local one by default, or an existing scheduler.

Tasks are retried once: a task that fails twice (or whose worker dies twice) stops the run,
and the error names what the task was doing (:class:`SceneCluster.map` and
:meth:`SceneCluster.as_completed` take a description of each task for that).

A local worker runs ``threads`` tasks at a time and its native thread pools (OpenCV's,
BLAS', OpenMP's, numba's) get as many threads, so that N workers use N x ``threads``
cores and adding workers scales the run instead of sharing cores OpenCV already took.

A local cluster listens on the loopback interface only, its dashboard included (served
by bokeh, a dependency for that reason), so nothing on the network reaches it.
"""

from __future__ import annotations

import logging
import os
from typing import Any, Callable, Iterator, Sequence

from distributed.diagnostics.plugin import WorkerPlugin

from radcons.errors import ParamsError, StageError

__all__ = ["SceneCluster", "worker_count", "NativeThreads"]

#: Times a task is tried in all.
ATTEMPTS = 2
#: Least memory of one local worker (its libraries and one 1024 px tile with its halo).
MIN_WORKER_MEMORY = 768 << 20
#: Interface a local cluster's dashboard listens on.
LOOPBACK = "127.0.0.1"
#: Environment variables that size the native thread pools of a worker process at start.
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")


def worker_count() -> int:
    """CPU cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


class NativeThreads(WorkerPlugin):
    """Worker plugin: OpenCV's thread pool set to ``threads`` threads in each worker process.

    (The other pools read :data:`THREAD_VARIABLES` at the worker's start.)
    """

    name = "radcons-native-threads"

    def __init__(self, threads: int) -> None:
        super().__init__()
        self.threads = threads

    def setup(self, worker: Any) -> None:
        """Called by Dask on each worker as it starts."""
        import cv2

        cv2.setNumThreads(self.threads)


class SceneCluster:
    """A Dask client on a local cluster or on the scheduler at ``address``.

    Parameters
    ----------
    address : str, optional
        ``tcp://host:port`` of a running Dask scheduler; None starts a ``LocalCluster``.
    workers : int, optional
        Workers of the local cluster (default: the cores available).
    threads : int
        Tasks each local worker runs at a time, and the threads of its native pools
        (worker processes only: workers that are threads of this process share its pools).
    memory_limit : int
        Bytes for the whole local cluster, shared among its workers (fewer workers when
        each would get less than :data:`MIN_WORKER_MEMORY`).
    processes : bool
        Local workers as processes (default) or threads of this process (tests).
    """

    def __init__(self, address: str | None = None, *, workers: int | None = None, threads: int = 1,
                 memory_limit: int = 0, processes: bool = True) -> None:
        import dask
        from distributed import Client, LocalCluster

        self._cluster = None
        self._environ: dict[str, str | None] = {}
        dask.config.set({"distributed.scheduler.allowed-failures": ATTEMPTS - 1})
        if address is not None:
            try:
                self.client = Client(address, timeout="20s")
            except (OSError, TimeoutError) as exc:
                raise StageError(f"cannot reach the Dask scheduler at {address} ({exc})") from exc
            self.workers = len(self.client.scheduler_info().get("workers", {}))
            return
        self.workers = workers or worker_count()
        if memory_limit:
            if memory_limit < MIN_WORKER_MEMORY:
                raise ParamsError(
                    f"scene mode needs at least {MIN_WORKER_MEMORY / 2**30:.2f} GiB for one worker; "
                    f"the memory limit is {memory_limit / 2**30:.2f} GiB"
                )
            self.workers = max(1, min(self.workers, memory_limit // MIN_WORKER_MEMORY))
        if threads < 1:
            raise ParamsError(f"threads per worker must be at least 1, got {threads}")
        per_worker = memory_limit // self.workers if memory_limit else "auto"
        environ = {**dask.config.get("distributed.nanny.pre-spawn-environ", {}), **dict.fromkeys(THREAD_VARIABLES, threads)}
        self._environ = {name: os.environ.get(name) for name in THREAD_VARIABLES}
        with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}):
            self._cluster = LocalCluster(
                n_workers=self.workers, threads_per_worker=threads, processes=processes, memory_limit=per_worker,
                dashboard_address=f"{LOOPBACK}:0", silence_logs=logging.ERROR,
            )
        self._restore_environ()
        self.client = Client(self._cluster)
        if processes:
            self.client.register_plugin(NativeThreads(threads))

    @property
    def dashboard(self) -> str | None:
        """Address of the Dask dashboard, or None when the scheduler serves none.

        A local cluster's link names the loopback address it listens on (Dask's own link
        names the machine's network address, where nothing answers).
        """
        services = self.client.scheduler_info().get("services", {})
        if "dashboard" not in services:
            return None
        if self._cluster is not None:
            return f"http://{LOOPBACK}:{services['dashboard']}/status"
        return self.client.dashboard_link

    def scatter(self, value: Any) -> Any:
        """Send ``value`` to every worker once; pass the result to tasks instead of the value.

        Each call scatters under a key of its own (``hash=False``): under a key from the
        value's hash, a value equal to one just released (the same quantities sent for a
        second set of tasks) could be forgotten by the scheduler while the release was
        still on its way, failing the tasks that need it with "lost dependencies".
        """
        return self.client.scatter(value, broadcast=True, hash=False)

    def submit(self, func: Callable[..., Any], items: Sequence[Any], *shared: Any) -> list[Any]:
        """Futures of ``func(item, *shared)``, left on the workers.

        Pass them (alone or inside tuples and lists of an item) to later tasks, which
        receive their results; a task that failed twice fails the tasks that use it.
        """
        return [self.client.submit(func, item, *shared, retries=ATTEMPTS - 1, pure=False) for item in items]

    def map(self, func: Callable[..., Any], items: Sequence[Any], *shared: Any, what: str = "task") -> list[Any]:
        """``[func(item, *shared) for item in items]`` on the workers, in order.

        Raises
        ------
        StageError
            A task failed twice; the message names ``what`` and the item.
        """
        return [result for _, result in sorted(self.as_completed(func, items, *shared, what=what), key=lambda x: x[0])]

    def as_completed(
        self, func: Callable[..., Any], items: Sequence[Any], *shared: Any, what: str = "task"
    ) -> Iterator[tuple[int, Any]]:
        """Yield ``(index, func(items[index], *shared))`` as tasks finish.

        Raises
        ------
        StageError
            A task failed twice; the message names ``what`` and the item.
        """
        from distributed import as_completed

        futures = {
            self.client.submit(func, item, *shared, retries=ATTEMPTS - 1, pure=False): index
            for index, item in enumerate(items)
        }
        try:
            for future in as_completed(futures):
                index = futures[future]
                try:
                    result = future.result()
                except Exception as exc:  # noqa: BLE001 - reported with the task it belongs to
                    raise StageError(
                        f"{what} {_describe(items[index])} failed {ATTEMPTS} times: "
                        f"{type(exc).__name__}: {exc}"
                    ) from exc
                future.release()
                yield index, result
        finally:
            self.client.cancel(list(futures))

    def close(self) -> None:
        """Close the client, and the local cluster if this object started it."""
        self.client.close()
        if self._cluster is not None:
            self._cluster.close()
            self._restore_environ()

    def _restore_environ(self) -> None:
        """Put back this process's thread variables.

        Dask's nanny writes ``pre-spawn-environ`` into the spawning process's own
        environment (a spawned worker inherits it), and again when it restarts a worker.
        Left there, the client's numba would see its thread count change after its threads
        started, which numba refuses with a RuntimeError.
        """
        for name, value in self._environ.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value

    def __enter__(self) -> "SceneCluster":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def _describe(item: Any) -> str:
    """A task's item in words: a window, a strip of rows (``(start, stop, ...)``) or its repr."""
    if isinstance(item, tuple) and len(item) == 4 and all(isinstance(v, int) for v in item):
        return f"rows {item[0]}-{item[1]}, columns {item[2]}-{item[3]}"
    if isinstance(item, tuple) and item and isinstance(item[0], tuple):
        return _describe(item[0])
    if isinstance(item, tuple) and len(item) > 2 and isinstance(item[0], int) and isinstance(item[1], int):
        return f"rows {item[0]}-{item[1]}"
    return repr(item)
