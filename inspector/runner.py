"""The compute worker's job: load a requested pair, run the pipeline, publish the run.

Every request (a pair to open, a parameter change) goes to the compute
:class:`~inspector.worker.LatestWorker`, which keeps only the newest: rapid changes
coalesce into the last one. Each request carries a generation number; a run whose request
was superseded is never shown. A run goes first to the stage on screen, which is shown at
once, then on to its last stage: :data:`LIVE_UNTIL` while tuning, the smoothness stage
when asked for.
"""

from __future__ import annotations

import threading
import time
from dataclasses import replace
from typing import Any, Callable

from inspector.context import Context, failure_reason
from inspector.state import WorkPair
from inspector.worker import Job

__all__ = ["Runner", "LIVE_UNTIL", "last_stage_reached"]

#: Last stage run after every change unless the smoothness stage is asked for: union group
#: sparse denoising takes minutes on a 1024 px pair, too slow to follow a slider. (The stage
#: before ``smoothness``; spelled out so that importing this module, which ``radcons inspect``
#: does before its server listens, does not import the stages.)
LIVE_UNTIL = "sharpness"


def last_stage_reached(run: Any) -> str:
    """The last pipeline stage a run reached."""
    from radcons.params import STAGES

    return [name for name in STAGES if name in run.results][-1]


class Runner:
    """Runs the pipeline on the compute worker for every request, newest first.

    Parameters
    ----------
    context : Context
        Its session gives the work pair, the parameters and the run choices; the result
        is announced on :attr:`Context.run_published`.

    Attributes
    ----------
    pipeline : radcons.pipeline.Pipeline or None
        Runs the stages, reusing what an earlier run computed (set by the app once the
        stages are imported).
    requested_at : dict
        ``generation -> time.perf_counter()`` when each recent request was made (for
        latency measurements).
    """

    def __init__(self, context: Context) -> None:
        self.context = context
        self.pipeline: Any = None
        self.requested_at: dict[int, float] = {}
        self._pending_load: Callable[[], Any] | None = None
        self._load_lock = threading.Lock()

    def request_load(self, load: Callable[[], Any]) -> int:
        """Ask for a pair to be opened: ``load()`` runs on the compute thread, then a run.

        A newer load request replaces one not yet started. Returns the generation number.
        """
        with self._load_lock:
            self._pending_load = load
        return self._submit("load")

    def request_run(self) -> int:
        """Ask for a run with the session's parameters; returns its generation number."""
        return self._submit("run")

    def _submit(self, label: str) -> int:
        """Queue a compute job; :attr:`requested_at` keeps when (for latency measurements)."""
        now = time.perf_counter()
        generation = self.context.compute.submit(self._run, fail=self._failed, label=label)
        self.requested_at[generation] = now
        for old in [g for g in self.requested_at if g < generation - 200]:
            del self.requested_at[old]
        return generation

    def _run(self, job: Job) -> None:
        """Load a pending pair (if any), then run the pipeline and publish the result.

        The run goes first to the stage on screen (published at once), then on to the
        last stage of the run (:meth:`_last_stage`), unless a newer request came meanwhile.
        """
        with self._load_lock:
            load, self._pending_load = self._pending_load, None
        if load is not None:
            load()
        from radcons.params import STAGES

        session = self.context.session
        last = self._last_stage()
        with session.lock:
            work, params, shown, view = session.work, session.params, session.run, session.view
        if work is None:
            return
        params = self._run_params(params, work)
        if shown is not None and shown.pair is work.pair and shown.params == params and last in shown.results:
            return  # nothing changed (e.g. a pair that failed to load)
        order = list(STAGES)
        first = view if view in order and order.index(view) < order.index(last) else last
        if first != last and order.index(first) < order.index("association"):
            first = "association"  # the overlays need the objects and their association
        run = self.pipeline.run(work.pair, params, until=first, progress=self._progress)
        if not self.context.compute.is_current(job):
            return
        self._publish(run, job, first == last)
        if first != last:
            run = self.pipeline.run(work.pair, params, until=last, progress=self._progress)
            if self.context.compute.is_current(job):
                self._publish(run, job, True)

    def _last_stage(self) -> str:
        """The stage a run goes to: the last one, or :data:`LIVE_UNTIL` unless asked."""
        from radcons.params import STAGES

        session = self.context.session
        with session.lock:
            asked, session.smoothness_asked = session.smoothness_asked, False
            every_run = session.smoothness_live
        return STAGES[-1] if asked or every_run else LIVE_UNTIL

    def _run_params(self, params: Any, work: WorkPair) -> Any:
        """The parameters a run uses: ``params``, with the smoothness stage in its fast
        mode (:func:`radcons.stages.smoothness.run.preview_params`) while tuning on a
        downsampled preview or a region, if the session asks for it."""
        if not (self.context.session.fast_previews and (work.factor > 1 or work.mode == "region")):
            return params
        from radcons.stages.smoothness.run import preview_params

        return replace(params, smoothness=preview_params(params.smoothness))

    def _progress(self, stage: str, index: int, total: int) -> None:
        self.context.set_status(f"Running **{stage}** ({index + 1}/{total})…", 100.0 * index / max(total, 1))

    def _publish(self, run: Any, job: Job, final: bool) -> None:
        """Make ``run`` the shown run and announce it (:attr:`Context.run_published`)."""
        session = self.context.session
        with session.lock:
            if session.work is None or session.work.pair is not run.pair:
                return
            session.run = run
            session.run_generation = job.generation
            session.review = None
            step = session.add_history(run, last_stage_reached(run)) if final else None
        self.context.run_published.emit(run, final, step)

    def _failed(self, job: Job, exc: BaseException) -> None:
        reason = failure_reason(exc, print_trace=True)
        self.context.set_status(f"Processing failed: {reason}", 100.0)
        self.context.notify(None, "Processing failed", reason)
