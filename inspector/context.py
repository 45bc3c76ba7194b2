"""What the inspector's panels share: the server, the session, the workers, the status line,
notifications, and the signals that carry one panel's effects to the others.

Every panel (:mod:`inspector.panels`) holds the one :class:`Context`. A panel changes the
:class:`~inspector.state.Session`, gives work to a worker and announces what happened on a
:class:`Signal`; :class:`inspector.app.InspectorApp` connects the panels that follow each
signal. No panel touches another panel's controls.

Threads: viser runs the GUI callbacks; three :class:`~inspector.worker.LatestWorker`
threads do the work, each keeping only its newest request: *compute* (load a pair, run
the pipeline, publish the run: :class:`inspector.runner.Runner`), *render* (redraw after a
view or selection change) and *review* (dense matching and object measurements).
"""

from __future__ import annotations

import traceback
from typing import Any, Callable

import numpy as np

from inspector.objects import objects_status
from inspector.state import Session
from inspector.viewport import Viewport
from inspector.worker import Job, LatestWorker
from radcons.errors import RadconsError

__all__ = ["Signal", "Context", "failure_reason"]


class Signal:
    """Callbacks run in the order they were connected, with the arguments given to :meth:`emit`.

    Examples
    --------
    >>> shown = Signal()
    >>> shown.connect(lambda final: print("final" if final else "partial"))
    >>> shown.emit(True)
    final
    """

    def __init__(self) -> None:
        self._callbacks: list[Callable[..., Any]] = []

    def connect(self, callback: Callable[..., Any]) -> None:
        """Call ``callback`` on every :meth:`emit` from now on."""
        self._callbacks.append(callback)

    def emit(self, *args: Any) -> None:
        """Call every connected callback with ``args``, on the calling thread."""
        for callback in self._callbacks:
            callback(*args)


def failure_reason(exc: BaseException, *, print_trace: bool = False) -> str:
    """Words for a failure shown to the user.

    Parameters
    ----------
    exc : BaseException
    print_trace : bool
        Print the traceback of an unexpected exception (not a :class:`RadconsError`).

    Returns
    -------
    str
        A :class:`RadconsError`'s own message, else the exception's type and message.
    """
    if isinstance(exc, RadconsError):
        return str(exc)
    if print_trace:
        traceback.print_exception(exc)
    return f"{type(exc).__name__}: {exc}"


class Context:
    """The server, the session and the workers, shared by the panels.

    Attributes
    ----------
    server : viser.ViserServer or None
        Set when the app starts.
    viewport : Viewport or None
        The scene showing the images (set with ``server``).
    session : Session or None
        The pair, parameters and runs shown (set once the stages are imported).
    compute, render, review : LatestWorker
        The three worker threads (see the module docstring).
    status, progress : viser GUI handles or None
        The status line above the tabs (:meth:`build_status`).
    pair_loaded : Signal
        ``()``: a new work pair is in the session (on the compute thread).
    run_published : Signal
        ``(run, final, step)``: ``run`` became the shown run; ``final`` when its whole
        run is done (``step`` is then its tuning step, else None).
    review_ready : Signal
        ``()``: a review of the shown run is in the session.
    view_chosen : Signal
        ``()``: another stage or baseline is to be shown (``session.view``).
    selection_drawn : Signal
        ``()``: the selected object changed and its details are drawn (render thread).
    object_clicked : Signal
        ``(ref_id)``: an object was clicked in the images (None: the background).
    region_asked : Signal
        ``(centre, client)``: tune on a full-resolution region centred on ``centre``,
        ``(x, y)`` in pixels of the loaded pair.
    review_asked : Signal
        ``()``: the shown run is to be reviewed now.
    """

    def __init__(self) -> None:
        self.server: Any = None
        self.viewport: Viewport | None = None
        self.session: Session | None = None
        self.compute = LatestWorker("inspector-compute", nice=5)
        self.render = LatestWorker("inspector-render")
        self.review = LatestWorker("inspector-review", nice=10)
        self.status: Any = None
        self.progress: Any = None
        self.pair_loaded = Signal()
        self.run_published = Signal()
        self.review_ready = Signal()
        self.view_chosen = Signal()
        self.selection_drawn = Signal()
        self.object_clicked = Signal()
        self.region_asked = Signal()
        self.review_asked = Signal()

    @property
    def workers(self) -> tuple[LatestWorker, LatestWorker, LatestWorker]:
        """The compute, review and render workers, each before those it hands work to (a
        run asks for a review, a review for a redraw): stopped in this order, none hands a
        job to a worker already stopped."""
        return self.compute, self.review, self.render

    def build_status(self, gui: Any) -> None:
        """Add the status line (a text and a progress bar) to ``gui``."""
        self.status = gui.add_markdown("**radcons inspector** — starting…")
        self.progress = gui.add_progress_bar(0.0, animated=False)

    def set_status(self, text: str, progress: float | None = None) -> None:
        """Show ``text`` under the name of the pair being tuned, then how the shown run's
        objects were found (:func:`inspector.objects.objects_status`), and the progress (0-100)."""
        work = self.session.work
        head = f"**{work.label}** · {work.describe}" if work is not None else "**radcons inspector**"
        objects = objects_status(self.session.run)
        self.status.content = f"{head}  \n{text}" + (f"  \n<sub>{objects}</sub>" if objects else "")
        if progress is not None:
            self.progress.value = float(np.clip(progress, 0.0, 100.0))

    def notify(self, client: Any, title: str, body: str, error: bool = True) -> None:
        """Show a notification to ``client`` (or to every client when None).

        An error stays until closed; other news closes after 6 s.
        """
        clients = [client] if client is not None else list(self.server.get_clients().values())
        for handle in clients:
            handle.add_notification(
                title, body, color="red" if error else "blue", with_close_button=True,
                auto_close_seconds=None if error else 6.0,
            )

    def display_failed(self, job: Job, exc: BaseException) -> None:
        """Report a failed render job to every client (the render worker's ``fail``)."""
        self.notify(None, "Display failed", failure_reason(exc, print_trace=True))
