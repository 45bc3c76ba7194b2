"""The inspector server: a viser app to load pairs, inspect objects and tune every stage live.

``radcons inspect [PAIR ...]`` runs it (:func:`inspector.serve.serve`); tests and scripts
use :class:`InspectorApp` directly::

    app = InspectorApp(pairs=[folder], port=0)
    app.start()            # listening; the first pair is loaded and being processed
    ...
    app.stop()

The app only wires: one controller per panel (:mod:`inspector.panels`) owns its controls
and callbacks; they share a :class:`~inspector.context.Context` (the server, the session,
the workers, the status line) and the :class:`~inspector.runner.Runner` of the pipeline,
and :meth:`InspectorApp._connect` says which panel follows which of the others' signals.

Files are read only inside the pairs and data roots given at start
(:class:`~inspector.paths.AllowedRoots`); uploads go to a private temporary folder and are
read with the same readers as any input.
"""

from __future__ import annotations

import collections
import threading
import time
from concurrent.futures import Future
from pathlib import Path
from typing import Any, Callable, Sequence

from inspector.address import listen_port
from inspector.context import Context
from inspector.layout import build_layout
from inspector.origin import install_origin_check
from inspector.panels.data import MAX_UPLOAD_MIB, DataPanel
from inspector.panels.disparity import DisparityPanel
from inspector.panels.export import ExportPanel
from inspector.panels.objects import ObjectsPanel
from inspector.panels.scene import ScenePanel
from inspector.panels.tuning import TuningPanel
from inspector.panels.view import Displayed, ViewPanel
from inspector.paths import pair_sources
from inspector.runner import LIVE_UNTIL, Runner
from inspector.state import Session
from inspector.viewport import Viewport
from radcons.errors import InputError
from radcons.io import Pair

__all__ = ["InspectorApp", "Displayed", "LIVE_UNTIL", "MAX_UPLOAD_MIB"]


class InspectorApp:
    """The inspector: a viser server, its panels and the workers behind them.

    Parameters
    ----------
    pairs : sequence of path-like
        Pair folders, or image files taken two at a time as (reference, target). The
        first is opened at start; without any, the built-in demo pair is.
    data_roots : sequence of path-like
        Folders whose pair folders (holding ``pair.toml``) are offered and may be opened.
    record_dir : path-like
        Where "Record to rerun" and "Export parameters" write.
    host : str
        Address to listen on (default local only).
    port : int, optional
        Port, which must be free (0: any free port); None: :data:`inspector.address.DEFAULT_PORT`
        or the next free one (see :attr:`port`).
    rerun_web : bool
        Serve a rerun web viewer on 127.0.0.1 that follows every run.
    preview_side : int
        Longest side of the preview a large pair is tuned on.
    display_side : int
        Longest side of the pictures sent to the browser.
    demo_size, demo_seed, demo_scenario
        The built-in demo pair.
    preset : str, optional
        The parameter preset to start from (one of :data:`radcons.params.PRESETS`);
        default :data:`radcons.params.DEFAULT_PRESET`, as the command line.
    max_upload_mib : int
        Largest accepted upload per image.
    band : int, optional
        1-based band of multiband images (default: the grey rule of :mod:`radcons.io.bands`).
    rectified : bool, optional
        Take every pair opened as epipolar-rectified (True) or not (False); None decides
        as ``radcons process`` does (:func:`radcons.geometry.settle_geometry`). A pair
        folder's ``rectified`` key always wins.
    scene_pixels : int, optional
        Pixels per image above which a pair is a scene, tuned on a decimated read and
        never loaded whole; None: when its in-memory run would pass the memory budget
        of ``radcons process`` (:func:`radcons.preflight.needs_scene`).
    scene_processes : bool
        "Apply to full resolution" runs local Dask workers as processes (False: threads).
    memory_limit : int, optional
        The memory budget, bytes (``radcons inspect --memory-limit``): a pair whose
        in-memory run would pass it opens as a scene, and "Apply to full resolution" runs
        within it. None: half the available memory, as ``radcons process``.

    Attributes
    ----------
    context : Context
        What the panels share.
    runner : Runner
        Runs the pipeline on the compute worker.
    data, tuning, view, objects, disparity, export, scene
        The panel controllers (:mod:`inspector.panels`), each with its controls.

    Raises
    ------
    InputError
        A pair or data root that does not exist (checked at construction).
    """

    def __init__(
        self,
        pairs: Sequence[str | Path] = (),
        data_roots: Sequence[str | Path] = (),
        record_dir: str | Path = "recordings",
        host: str = "127.0.0.1",
        port: int | None = None,
        *,
        rerun_web: bool = False,
        preview_side: int = 1024,
        display_side: int = 2048,
        demo_size: int = 512,
        demo_seed: int = 0,
        demo_scenario: str = "mixed",
        max_upload_mib: int = MAX_UPLOAD_MIB,
        preset: str | None = None,
        band: int | None = None,
        rectified: bool | None = None,
        scene_pixels: int | None = None,
        scene_processes: bool = True,
        memory_limit: int | None = None,
    ) -> None:
        roots, sources = pair_sources(pairs, data_roots)
        self.host = host
        self.requested_port = port
        self.rerun_web = rerun_web
        self.preset = preset
        self.context = Context()
        self.runner = Runner(self.context)
        demo = {"size": demo_size, "seed": demo_seed, "scenario": demo_scenario}
        self.data = DataPanel(
            self.context, self.runner, roots, sources, preview_side, demo, max_upload_mib * 2**20,
            reading={"band": band, "rectified": rectified}, scene_pixels=scene_pixels, memory_limit=memory_limit,
        )
        self.tuning = TuningPanel(self.context, self.runner)
        self.view = ViewPanel(self.context, display_side)
        self.objects = ObjectsPanel(self.context)
        self.disparity = DisparityPanel(self.context)
        self.export = ExportPanel(self.context, record_dir)
        self.scene = ScenePanel(
            self.context, record_dir, data_roots, {"band": band, "rectified": rectified}, scene_processes, memory_limit
        )
        self._connect()

    def _connect(self) -> None:
        """Which panel follows which signal (the only ties between the panels)."""
        context = self.context
        context.pair_loaded.connect(self.view.request_render)  # the run starts meanwhile
        context.pair_loaded.connect(self.objects.refresh)
        context.pair_loaded.connect(self.scene.on_pair_loaded)
        context.run_published.connect(lambda run, final, step: self.view.refresh(final=final))
        context.run_published.connect(lambda run, final, step: self.objects.refresh())
        context.run_published.connect(lambda run, final, step: self.tuning.show_timings(run, final))
        context.run_published.connect(self.disparity.on_published)
        context.run_published.connect(self.export.on_published)
        context.run_published.connect(lambda run, final, step: self.data.show_run(run, final))
        context.review_ready.connect(self.objects.refresh)
        context.review_ready.connect(self.view.request_review)
        context.view_chosen.connect(self.disparity.on_view_chosen)
        context.selection_drawn.connect(self.view.refresh_overlays)
        context.object_clicked.connect(self.objects.select)
        context.region_asked.connect(self.data.open_region)
        context.review_asked.connect(self.disparity.request)

    # ================================================================== public state

    @property
    def port(self) -> int:
        """The port the server really listens on."""
        return int(self.server.get_port())

    @property
    def url(self) -> str:
        """Address of the page."""
        host = "127.0.0.1" if self.host in ("0.0.0.0", "") else self.host
        return f"http://{host}:{self.port}"

    @property
    def server(self) -> Any:
        """The viser server (None before :meth:`start`)."""
        return self.context.server

    @property
    def viewport(self) -> Viewport | None:
        """The scene showing the images."""
        return self.context.viewport

    @property
    def session(self) -> Session | None:
        """The pair, parameters, runs and selection shown."""
        return self.context.session

    @property
    def pipeline(self) -> Any:
        """The :class:`radcons.pipeline.Pipeline` that runs every request."""
        return self.runner.pipeline

    @property
    def requested_at(self) -> dict[int, float]:
        """``generation -> time.perf_counter()`` of each recent compute request."""
        return self.runner.requested_at

    @property
    def displayed(self) -> Displayed | None:
        """What the viewport shows now."""
        return self.view.displayed

    @property
    def shown_log(self) -> collections.deque[Displayed]:
        """The last 200 views shown."""
        return self.view.shown_log

    @property
    def live(self) -> Any:
        """The live rerun viewer, when ``rerun_web``."""
        return self.export.live

    @property
    def last_recording(self) -> Path | None:
        """The recording written last."""
        return self.export.last_recording

    @property
    def last_export(self) -> Path | None:
        """The parameter file written last."""
        return self.export.last_export

    def select_object(self, ref_id: int | None) -> None:
        """Select a reference object (None: no selection) and show its details."""
        self.objects.select(ref_id)

    # ================================================================== lifecycle

    def start(
        self, on_listening: Callable[[str], None] | None = None, browser_grace: float = 0.0
    ) -> "InspectorApp":
        """Start the server, show the first pair and start processing it.

        A pair given on the command line is read before the server starts, so a bad one
        raises :class:`InputError` here; the demo pair is generated in a thread while a
        browser loads the page. The server listens (and
        ``on_listening(url)`` is called) before the stages are imported; the first pair
        is shown (:meth:`ViewPanel.first_paint`) before the panels are built, and
        processed by the compute worker.

        Parameters
        ----------
        on_listening : callable, optional
            Called with the page address once the server listens.
        browser_grace : float
            At most this many seconds are left to a browser to load the page before the
            panels are built and the first pair is processed
            (:meth:`_let_first_page_load`); 0 starts at once.

        Raises
        ------
        InputError
            A pair given that cannot be read, or an address that cannot be listened on
            (:func:`inspector.address.listen_port`), before anything listens.

        Notes
        -----
        Websocket handshakes whose ``Origin`` is another site than the page's are refused
        (:func:`inspector.origin.install_origin_check`).
        """
        import viser

        port = listen_port(self.host, self.requested_port)  # a bad address is said at once
        label, pair = self.data.first_pair()
        install_origin_check()
        server = viser.ViserServer(host=self.host, port=port, verbose=False)
        self.context.server = server
        if self.requested_port is not None and server.get_port() != port:  # taken meanwhile
            raise InputError(f"--port {self.requested_port}: in use on {self.host}")
        self.context.viewport = Viewport(server)
        server.on_client_connect(self.context.viewport.follow_canvas)
        if on_listening is not None:
            on_listening(self.url)
        pending: Future[Pair] | None = None
        if pair is None:  # the demo pair is generated while a browser loads the page
            pending = _in_background(self.data.demo_loader(), "inspector-demo")
        if browser_grace > 0:
            self._let_first_page_load(browser_grace)
        if pending is not None:
            pair = pending.result()
        work = self.data.work_pair(label, pair, "preview")
        self.view.first_paint(work)

        from radcons.params import DEFAULT_PRESET, Params
        from radcons.pipeline import Pipeline

        params = Params.from_preset(self.preset or DEFAULT_PRESET)
        self.context.session = Session(params=params, view=LIVE_UNTIL)
        self.runner.pipeline = Pipeline(params)
        with server.atomic():  # the page applies the panels in one update
            build_layout(
                server,
                self.context.build_status,
                {"Data": self.data.build, "Tune": self.tuning.build, "View": self.view.build, "Export": self._build_export},
                {"Objects": self.objects.build, "Disparity": self.disparity.build},
            )
        if self.rerun_web:
            self.export.start_live_viewer()
        self.data.open_first(work)
        return self

    def _build_export(self, gui: Any) -> None:
        """The Export tab: recordings and parameters, then the whole-scene run."""
        self.export.build(gui)
        self.scene.build(gui)

    def _let_first_page_load(self, grace: float) -> None:
        """Wait until a browser has loaded the page (viser counts a client as connected
        once its page has sent its first camera), at most ``grace`` s.

        Loading viser's page takes about 1.5 s of both cores in headless Chromium;
        importing the stages, building the panels and running the stages at the same
        time made the first image appear 7-8 s after launch instead of under 5 s
        (``benchmarks/bench_inspector.py``).
        """
        deadline = time.monotonic() + grace
        while not self.server.get_clients() and time.monotonic() < deadline:
            time.sleep(0.02)

    def stop(self, timeout: float = 30.0) -> bool:
        """Stop the workers and the server, free the port, delete uploaded files.

        Parameters
        ----------
        timeout : float
            Seconds left to a run or a recording under way to end (they run on daemon
            threads: a process that exits stops them; a recording is written whole or
            not at all).

        Returns
        -------
        bool
            True when every worker thread has ended; False when one still computes.
        """
        deadline = time.monotonic() + timeout
        left = lambda: max(0.0, deadline - time.monotonic())  # noqa: E731
        ended = all([worker.stop(left()) for worker in self.context.workers])
        if self.viewport is not None:
            self.viewport.stop()
        ended = self.export.stop(left()) and ended
        ended = self.scene.stop(left()) and ended
        if self.server is not None:
            self.server.stop()
        self.data.stop()
        return ended

    def wait_idle(self, timeout: float = 60.0) -> bool:
        """Block until no worker has anything to do (or ``timeout`` s); True when idle.

        Workers hand work to each other (a run asks for a review, a review for a redraw),
        so all are checked again until none is busy.
        """
        deadline = time.monotonic() + timeout
        workers = self.context.workers
        while time.monotonic() < deadline:
            for worker in workers:
                worker.wait_idle(max(0.0, deadline - time.monotonic()))
            self.export.wait(max(0.0, deadline - time.monotonic()))
            if not any(worker.busy for worker in workers) and not self.export.busy:
                return True
        return False


def _in_background(function: Callable[[], Any], name: str) -> Future[Any]:
    """Run ``function()`` on a daemon thread (one that never holds up the exit, unlike a
    thread pool's); its result or exception in the returned future."""
    future: Future[Any] = Future()

    def run() -> None:
        try:
            future.set_result(function())
        except BaseException as exc:  # noqa: BLE001 - handed to the caller
            future.set_exception(exc)

    threading.Thread(target=run, name=name, daemon=True).start()
    return future
