"""The inspector server: a viser app to load pairs, inspect objects and tune every stage live.

``radcons inspect [PAIR ...]`` calls :func:`serve`; tests and scripts use
:class:`InspectorApp` directly::

    app = InspectorApp(pairs=[folder], port=0)
    app.start()            # listening; the first pair is loaded and being processed
    ...
    app.stop()

Threads: viser runs the GUI callbacks; three :class:`~inspector.worker.LatestWorker`
threads do the work, each keeping only its newest request: *compute* (load a pair, run
the pipeline, show the result), *render* (redraw after a view or selection change) and
*review* (dense matching and object measurements). Every pipeline request carries a
generation number; a result whose request was superseded is never shown.

Files are read only inside the pairs and data roots given at start
(:class:`~inspector.paths.AllowedRoots`); uploads go to a private temporary folder and are
read with the same readers as any input.
"""

from __future__ import annotations

import argparse
import collections
import shutil
import signal
import tempfile
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from inspector import objects as object_panel
from inspector import render
from inspector.layout import Layout, build_layout
from inspector.paths import PairSource, pair_sources
from inspector.review import Review, object_pairs, resolve_view, review_run, view_images
from inspector.state import MODES, Session, WorkPair, centred_region, preview_pair, region_pair
from inspector.views import Viewport
from inspector.worker import Job, LatestWorker
from radcons.errors import InputError, ParamsError, RadconsError
from radcons.io import Pair, is_image_file, load_pair, load_pair_files, read_raster

__all__ = ["InspectorApp", "Displayed", "serve", "DEMO_LABEL", "LIVE_UNTIL", "MAX_UPLOAD_MIB"]

#: Dropdown entry of the demo pair generated on the fly.
DEMO_LABEL = "built-in demo"
#: Last stage run after every change unless the smoothness stage is asked for: union group
#: sparse denoising takes minutes on a 1024 px pair, too slow to follow a slider. (The stage
#: before ``smoothness``; spelled out so that importing this module, which ``radcons inspect``
#: does before its server listens, does not import the stages.)
LIVE_UNTIL = "sharpness"
#: Seconds without a new run before dense matching starts (it would slow a slider down).
REVIEW_DELAY = 0.3
#: Seconds ``radcons inspect`` gives a browser opened at launch to load the page before
#: it shows the first pair, builds the panels and processes it (:meth:`InspectorApp.start`).
BROWSER_GRACE = 3.0
#: Largest accepted upload, per image, in MiB.
MAX_UPLOAD_MIB = 64
_UPLOAD_SUFFIXES = (".png", ".tif", ".tiff")


@dataclass(frozen=True)
class Displayed:
    """What the viewport shows now (for tests and benchmarks).

    Attributes
    ----------
    generation : int
        Compute request whose run is shown (0 before the first run).
    params : radcons.params.Params or None
        Parameters of the run shown.
    view : str
        Stage or baseline shown.
    images : (ndarray, ndarray)
        The float ``(reference, target)`` images of that view.
    pictures : (ndarray, ndarray)
        The 8-bit grey pictures sent to the browser (one grey-value range for both).
    final : bool
        True when the whole pipeline had run (not only up to the shown stage).
    shown_at : float
        ``time.perf_counter()`` after the pictures were queued for the browsers.
    """

    generation: int
    params: Any
    view: str
    images: tuple[np.ndarray, np.ndarray]
    pictures: tuple[np.ndarray, np.ndarray]
    final: bool
    shown_at: float


@dataclass(frozen=True)
class _LoadRequest:
    label: str
    loader: Callable[[], Pair]
    mode: str
    client: Any
    centre: tuple[float, float] | None = None
    #: The work pair when it is already made (the first pair, shown before the panels).
    work: WorkPair | None = None


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
    port : int
        Port; viser takes the next free one when it is busy (see :attr:`port`); 0 picks a
        free one.
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
        port: int = 8080,
        *,
        rerun_web: bool = False,
        preview_side: int = 1024,
        display_side: int = 2048,
        demo_size: int = 512,
        demo_seed: int = 0,
        demo_scenario: str = "mixed",
        max_upload_mib: int = MAX_UPLOAD_MIB,
        preset: str | None = None,
    ) -> None:
        self.roots, self.sources = pair_sources(pairs, data_roots)
        self.record_dir = Path(record_dir)
        self.host = host
        self.requested_port = port
        self.rerun_web = rerun_web
        self.preview_side = preview_side
        self.display_side = display_side
        self.demo = {"size": demo_size, "seed": demo_seed, "scenario": demo_scenario}
        self.max_upload_bytes = max_upload_mib * 2**20
        self.preset = preset
        self.session: Session | None = None
        self.pipeline: Any = None
        self.displayed: Displayed | None = None
        self.requested_at: dict[int, float] = {}
        self.shown_log: collections.deque[Displayed] = collections.deque(maxlen=200)
        self.server: Any = None
        self.layout: Layout | None = None
        self.viewport: Viewport | None = None
        self.live: Any = None
        self.last_recording: Path | None = None
        self.last_export: Path | None = None
        self._labels = self._pair_labels(self.sources)
        self._current_label = DEMO_LABEL
        self._pending_load: _LoadRequest | None = None
        self._load_lock = threading.Lock()
        self._view_lock = threading.RLock()
        self._syncing = False
        self._uploads: dict[str, Path] = {}
        self._upload_names: dict[str, str] = {}
        self._upload_dir = Path(tempfile.mkdtemp(prefix="radcons-uploads-"))
        self._record_thread: threading.Thread | None = None
        self._smoothness_requested = False
        self._baselines: list[str] = []
        self._geometry: tuple[int, tuple[int, int]] | None = None
        self._overlay_cache: tuple[Any, ...] | None = None
        self._compute = LatestWorker("inspector-compute", nice=5)
        self._render = LatestWorker("inspector-render")
        self._review = LatestWorker("inspector-review", nice=10)

    # ================================================================== lifecycle

    @property
    def port(self) -> int:
        """The port the server really listens on."""
        return int(self.server.get_port())

    @property
    def url(self) -> str:
        """Address of the page."""
        host = "127.0.0.1" if self.host in ("0.0.0.0", "") else self.host
        return f"http://{host}:{self.port}"

    def start(
        self, on_listening: Callable[[str], None] | None = None, browser_grace: float = 0.0
    ) -> "InspectorApp":
        """Start the server, show the first pair and start processing it.

        A pair given on the command line is read before the server starts, so a bad one
        raises :class:`InputError` here; the demo pair is generated in a thread while a
        browser loads the page. The server listens (and
        ``on_listening(url)`` is called) before the stages are imported; the first pair
        is shown (:meth:`_first_paint`) before the panels are built, and processed by the
        compute worker.

        Parameters
        ----------
        on_listening : callable, optional
            Called with the page address once the server listens.
        browser_grace : float
            At most this many seconds are left to a browser to load the page before the
            panels are built and the first pair is processed
            (:meth:`_let_first_page_load`); 0 starts at once.
        """
        import viser

        first = self.sources[0] if self.sources and self.sources[0].given else None
        pending: Future[Pair] = Future()
        if first is not None:
            label = self._labels[0]
            pending.set_result(self._source_loader(first)())
        else:
            label = DEMO_LABEL
        port = self.requested_port or _free_port(self.host)
        self.server = viser.ViserServer(host=self.host, port=port, verbose=False)
        self.viewport = Viewport(self.server)
        self.server.on_client_connect(self._on_connect)
        if on_listening is not None:
            on_listening(self.url)
        if not pending.done():  # the demo pair is generated while a browser loads the page
            pool = ThreadPoolExecutor(1, thread_name_prefix="inspector-demo")
            pending = pool.submit(self._demo_loader(**self.demo))
            pool.shutdown(wait=False)
        if browser_grace > 0:
            self._let_first_page_load(browser_grace)
        pair = pending.result()
        work = self._make_work(label, pair, "preview", None)
        self._first_paint(work)

        from radcons.baselines import BASELINES
        from radcons.params import DEFAULT_PRESET, PRESETS, STAGES, SWITCHABLE, Params
        from radcons.pipeline import IMAGE_STAGES, Pipeline

        params = Params.from_preset(self.preset or DEFAULT_PRESET)
        self.session = Session(params=params)
        self.pipeline = Pipeline(params)
        self._baselines = list(BASELINES)
        views = [*IMAGE_STAGES, *(f"baseline:{name}" for name in self._baselines)]
        with self.server.atomic():  # the page applies the panels in one update
            self.layout = build_layout(
                self.server, params, PRESETS, STAGES, SWITCHABLE, views, LIVE_UNTIL,
                self._on_param_change, self._on_stage_reset, self.max_upload_bytes // 2**20,
            )
            self.layout.pair.options = (DEMO_LABEL, *self._labels)
        self._wire()
        if self.rerun_web:
            from inspector.recording import LiveViewer

            self.live = LiveViewer()
            self.layout.export_info.content = f"Live rerun viewer: [{self.live.url}]({self.live.url})"
        self._request_load(_LoadRequest(label, lambda: pair, "preview", None, work=work))
        return self

    def stop(self) -> None:
        """Stop the workers and the server, free the port, delete uploaded files."""
        for worker in (self._compute, self._render, self._review):
            worker.stop()
        if self.viewport is not None:
            self.viewport.stop()
        if self._record_thread is not None:
            self._record_thread.join(30.0)
        if self.live is not None:
            self.live.stop()
        if self.server is not None:
            self.server.stop()
        shutil.rmtree(self._upload_dir, ignore_errors=True)

    def wait_idle(self, timeout: float = 60.0) -> bool:
        """Block until no worker has anything to do (or ``timeout`` s); True when idle.

        Workers hand work to each other (a run asks for a review, a review for a redraw),
        so all are checked again until none is busy.
        """
        deadline = time.monotonic() + timeout
        workers = (self._compute, self._render, self._review)
        while time.monotonic() < deadline:
            for worker in workers:
                worker.wait_idle(max(0.0, deadline - time.monotonic()))
            thread = self._record_thread
            if thread is not None:
                thread.join(max(0.0, deadline - time.monotonic()))
            if not any(worker.busy for worker in workers) and not (thread is not None and thread.is_alive()):
                return True
        return False

    # ================================================================== wiring

    def _wire(self) -> None:
        layout = self.layout
        layout.pair.on_update(self._on_pair_choice)
        layout.open_folder.on_click(self._on_open_folder)
        layout.upload_reference.on_upload(lambda event: self._on_upload("reference", event))
        layout.upload_target.on_upload(lambda event: self._on_upload("target", event))
        layout.generate.on_click(self._on_generate)
        layout.work_mode.on_update(self._on_work_mode)
        layout.apply_full.on_click(self._on_apply_full)
        layout.reset_all.on_click(self._on_reset_all)
        layout.preset.on_update(self._on_preset)
        layout.run_smoothness.on_click(self._on_run_smoothness)
        layout.smoothness_mode.on_update(lambda event: self._request_run())
        layout.fast_smoothness.on_update(lambda event: self._request_run())
        layout.view.on_update(self._on_view_change)
        layout.compare.on_update(self._on_compare_change)
        layout.swipe.on_update(lambda event: self._request_render())
        for checkbox in layout.overlays.values():
            checkbox.on_update(lambda event: self._request_overlays())
        layout.height_scale.on_update(lambda event: self._request_cloud())
        layout.object_choice.on_update(self._on_object_choice)
        layout.auto_review.on_update(lambda event: self._request_review() if layout.auto_review.value else None)
        layout.review_now.on_click(lambda event: self._request_review())
        layout.record.on_click(self._on_record)
        layout.export.on_click(self._on_export)
        self.server.scene.on_click()(self._on_scene_click)
        self.server.scene.on_click(modifier="shift")(self._on_scene_shift_click)

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

    def _first_paint(self, work: WorkPair) -> None:
        """Show the first pair as it is, before the panels exist.

        The page draws the images while the server imports the stages and builds the
        panels; :meth:`_refresh_view` replaces them once the pair is loaded.
        """
        images = (work.pair.reference.as_float32(), work.pair.target.as_float32())
        pictures = self._pictures(images)
        clear = np.zeros((*pictures[0].shape, 4), np.uint8)
        titles = ("reference · original · computing…", "target · original · computing…")
        self.viewport.show(pictures[0], pictures[1], (clear, clear), titles, images[0].shape)

    def _pictures(self, images: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """The 8-bit display pictures of two float images, mapped with one range and
        shrunk to at most :attr:`display_side` (:mod:`inspector.render`)."""
        value_range = render.display_range(*images)
        factor = render.downsample_factor(images[0].shape, self.display_side)
        reference, target = (render.to_display(render.resize_for_display(image, factor), value_range) for image in images)
        return reference, target

    def _on_connect(self, client: Any) -> None:
        self.viewport.follow_canvas(client)

    # ================================================================== notifications

    def _notify(self, client: Any, title: str, body: str, error: bool = True) -> None:
        """Show a notification to ``client`` (or to every client when None)."""
        clients = [client] if client is not None else list(self.server.get_clients().values())
        for handle in clients:
            handle.add_notification(
                title, body, color="red" if error else "blue", with_close_button=True,
                auto_close_seconds=None if error else 6.0,
            )

    def _set_status(self, text: str, progress: float | None = None) -> None:
        work = self.session.work
        head = f"**{work.label}** · {work.describe}" if work is not None else "**radcons inspector**"
        self.layout.status.content = f"{head}  \n{text}"
        if progress is not None:
            self.layout.progress.value = float(np.clip(progress, 0.0, 100.0))

    # ================================================================== loading

    @staticmethod
    def _pair_labels(sources: Sequence[PairSource]) -> list[str]:
        labels: list[str] = []
        for source in sources:
            label = source.label
            while label in labels or label == DEMO_LABEL:
                label += "'"
            labels.append(label)
        return labels

    def _source_loader(self, source: PairSource) -> Callable[[], Pair]:
        if source.folder is not None:
            folder = source.folder
            return lambda: load_pair(self.roots.check(folder))
        reference, target = source.files
        return lambda: load_pair_files(self.roots.check(reference), self.roots.check(target))

    @staticmethod
    def _demo_loader(size: int, seed: int, scenario: str) -> Callable[[], Pair]:
        def load() -> Pair:
            from demo_data_gen import generate

            return generate(size=int(size), seed=int(seed), scenario=scenario)

        return load

    def _request_load(self, request: _LoadRequest) -> None:
        with self._load_lock:
            self._pending_load = request
        self._submit_compute("load")

    def _request_run(self) -> int:
        return self._submit_compute("run")

    def _submit_compute(self, label: str) -> int:
        """Queue a compute job; :attr:`requested_at` keeps when (for latency measurements)."""
        now = time.perf_counter()
        generation = self._compute.submit(self._compute_job, fail=self._compute_failed, label=label)
        self.requested_at[generation] = now
        for old in [g for g in self.requested_at if g < generation - 200]:
            del self.requested_at[old]
        return generation

    def _make_work(self, label: str, pair: Pair, mode: str, centre: tuple[float, float] | None) -> WorkPair:
        if mode not in MODES:
            raise InputError(f"unknown tuning mode {mode!r}")
        if mode == "preview":
            work, factor = preview_pair(pair, self.preview_side)
            return WorkPair(label, pair, work, "preview", factor)
        if mode == "region":
            if centre is None:
                centre = (pair.shape[1] / 2, pair.shape[0] / 2)
            box = centred_region(pair.shape, centre, self.preview_side)
            return WorkPair(label, pair, region_pair(pair, box), "region", 1, box)
        return WorkPair(label, pair, pair, "full", 1)

    def _do_load(self, request: _LoadRequest) -> bool:
        """Load a requested pair; on failure notify and keep the previous one."""
        self._set_status(f"Loading {request.label}…", 0.0)
        try:
            work = request.work or self._make_work(request.label, request.loader(), request.mode, request.centre)
        except Exception as exc:  # noqa: BLE001 - any failure keeps the previous pair
            reason = str(exc) if isinstance(exc, RadconsError) else f"{type(exc).__name__}: {exc}"
            self._notify(request.client, f"Could not open {request.label}", reason)
            self._sync_control(self.layout.pair, self._current_label)
            self._set_status("Kept the previous pair.", 100.0)
            return False
        self.session.set_work(work)
        self._current_label = request.label
        self._sync_control(self.layout.pair, request.label if request.label in self.layout.pair.options else self._current_label)
        self._sync_control(self.layout.work_mode, work.mode)
        self._show_pair_info(work)
        self._refresh_view()
        self._refresh_objects()
        return True

    def _show_pair_info(self, work: WorkPair) -> None:
        pair = work.full
        truth = [name for name, value in (("disparity", pair.disparity), ("objects", pair.reference_objects), ("change mask", pair.change_mask)) if value is not None]
        lines = [
            f"**{work.label}** — {pair.shape[1]}x{pair.shape[0]} px, {pair.reference.data.dtype}",
            f"Tuning on: {work.describe}",
            f"Ground truth: {', '.join(truth) if truth else 'none'}",
        ]
        shown = [f"{key}: {pair.metadata[key]}" for key in ("sensor", "date", "scenario") if key in pair.metadata]
        if shown:
            lines.append(" · ".join(shown))
        self.layout.pair_info.content = "  \n".join(lines)
        large = max(pair.shape) > self.preview_side
        self.layout.apply_full.disabled = not large
        self.layout.work_mode.disabled = not large

    def _sync_control(self, handle: Any, value: Any) -> None:
        """Set a control from Python without triggering its callback."""
        self._syncing = True
        try:
            handle.value = value
        finally:
            self._syncing = False

    def _on_pair_choice(self, event: Any) -> None:
        if self._syncing:
            return
        label = self.layout.pair.value
        if label == self._current_label:
            return
        if label == DEMO_LABEL:
            loader = self._demo_loader(**self.demo)
        else:
            loader = self._source_loader(self.sources[self._labels.index(label)])
        self._request_load(_LoadRequest(label, loader, "preview", event.client))

    def _on_open_folder(self, event: Any) -> None:
        text = self.layout.folder.value.strip()
        if not text:
            self._notify(event.client, "No folder", "Type the path of a pair folder first.")
            return

        def load() -> Pair:
            return load_pair(self.roots.check(text))

        self._request_load(_LoadRequest(Path(text).name or text, load, "preview", event.client))

    def _on_upload(self, role: str, event: Any) -> None:
        uploaded = event.target.value
        name = Path(uploaded.name or "").name
        suffix = Path(name).suffix.lower()
        try:
            if len(uploaded.content) > self.max_upload_bytes:
                raise InputError(f"{len(uploaded.content) / 2**20:.1f} MiB is over the {self.max_upload_bytes // 2**20} MiB limit", name)
            if suffix not in _UPLOAD_SUFFIXES or not is_image_file(Path(name)):
                raise InputError(f"unsupported file type {suffix or '(none)'!r} (PNG or TIFF)", name)
            path = self._upload_dir / f"{role}{suffix}"
            for old in self._upload_dir.glob(f"{role}.*"):
                old.unlink()
            path.write_bytes(uploaded.content)
            read_raster(path)
        except RadconsError as exc:
            self._uploads.pop(role, None)
            for old in self._upload_dir.glob(f"{role}.*"):
                old.unlink()
            self._notify(event.client, f"Upload refused: {name or role}", exc.reason)
            self._show_uploads()
            return
        self._uploads[role] = path
        self._upload_names[role] = name
        self._show_uploads()
        if len(self._uploads) == 2:
            reference, target = self._uploads["reference"], self._uploads["target"]
            names = dict(self._upload_names)
            label = f"upload: {names['reference']} + {names['target']}"
            self._uploads = {}

            def load() -> Pair:
                return load_pair_files(reference, target, name=Path(names["reference"]).stem)

            self._request_load(_LoadRequest(label, load, "preview", event.client))

    def _show_uploads(self) -> None:
        names = self._upload_names
        parts = [f"{role}: {names.get(role, '?')}" for role in ("reference", "target") if role in self._uploads]
        self.layout.upload_info.content = ("Received " + ", ".join(parts) + "; waiting for the other image.") if parts else ""

    def _on_generate(self, event: Any) -> None:
        layout = self.layout
        size, seed, scenario = int(layout.demo_size.value), int(layout.seed.value), layout.scenario.value
        label = f"demo {scenario} {size}px seed {seed}"
        self._request_load(_LoadRequest(label, self._demo_loader(size, seed, scenario), "preview", event.client))

    def _reload_work(self, mode: str, client: Any, centre: tuple[float, float] | None = None) -> None:
        work = self.session.work
        if work is None:
            return
        full = work.full
        self._request_load(_LoadRequest(work.label, lambda: full, mode, client, centre))

    def _on_work_mode(self, event: Any) -> None:
        if self._syncing:
            return
        self._reload_work(self.layout.work_mode.value, event.client)

    def _on_apply_full(self, event: Any) -> None:
        self._sync_control(self.layout.work_mode, "full")
        self._reload_work("full", event.client)

    # ================================================================== tuning

    def _on_param_change(self, stage: str, changes: dict[str, Any], client: Any) -> None:
        with self.session.lock:
            try:
                params = self.session.params.with_stage(stage, **changes)
            except ParamsError as exc:
                current = self.session.params
                self.layout.stages[stage].show(current.stage(stage), current.enabled(stage) if self.layout.stages[stage].enabled is not None else None)
                self._notify(client, f"Invalid {stage} parameter", exc.reason)
                return
            if params == self.session.params:
                return
            self.session.params = params
        self._request_run()

    def _on_stage_reset(self, stage: str, client: Any) -> None:
        """Give a stage its preset's values back (and switch it as the preset does)."""
        from radcons.params import SWITCHABLE, Params

        with self.session.lock:
            preset = Params.from_preset(self.session.params.preset)
            params = replace(self.session.params, **{_attr(stage): preset.stage(stage)})
            if stage in SWITCHABLE:
                params = params.with_stage(stage, enabled=preset.enabled(stage))
            self.session.params = params
            self._show_params(params)
        self._request_run()

    def _on_preset(self, event: Any) -> None:
        if self._syncing:
            return
        self._use_preset(self.layout.preset.value)

    def _on_reset_all(self, event: Any) -> None:
        self._use_preset(self.session.params.preset)

    def _use_preset(self, name: str) -> None:
        """Set every stage to the values of preset ``name``."""
        from radcons.params import Params

        with self.session.lock:
            self.session.params = Params.from_preset(name)
            self._show_params(self.session.params)
        self._sync_control(self.layout.preset, name)
        for controls in self.layout.stages.values():
            controls.defaults = self.session.params.stage(controls.stage)
        self._request_run()

    def _show_params(self, params: Any) -> None:
        for stage, controls in self.layout.stages.items():
            controls.show(params.stage(stage), params.enabled(stage) if controls.enabled is not None else None)

    def _progress(self, stage: str, index: int, total: int) -> None:
        self._set_status(f"Running **{stage}** ({index + 1}/{total})…", 100.0 * index / max(total, 1))

    def _on_run_smoothness(self, event: Any) -> None:
        with self.session.lock:
            self._smoothness_requested = True
        self._request_run()

    def _last_stage(self) -> str:
        """The stage a run goes to: the last one, or :data:`LIVE_UNTIL` unless asked."""
        from radcons.params import STAGES

        with self.session.lock:
            asked, self._smoothness_requested = self._smoothness_requested, False
        if asked or self.layout.smoothness_mode.value == "after each change":
            return STAGES[-1]
        return LIVE_UNTIL

    def _compute_job(self, job: Job) -> None:
        """Load a pending pair (if any), then run the pipeline and show the result.

        The run goes first to the stage on screen (shown at once), then on to the last
        stage of the run (:meth:`_last_stage`), unless a newer request came meanwhile.
        """
        with self._load_lock:
            load, self._pending_load = self._pending_load, None
        if load is not None:
            self._do_load(load)
        from radcons.params import STAGES

        last = self._last_stage()
        with self.session.lock:
            work, params, shown = self.session.work, self.session.params, self.session.run
        if work is None:
            return
        params = self._run_params(params, work)
        if shown is not None and shown.pair is work.pair and shown.params == params and last in shown.results:
            return  # nothing changed (e.g. a pair that failed to load)
        view = self.layout.view.value
        order = list(STAGES)
        first = view if view in order and order.index(view) < order.index(last) else last
        if first != last and order.index(first) < order.index("association"):
            first = "association"  # the overlays need the objects and their association
        run = self.pipeline.run(work.pair, params, until=first, progress=self._progress)
        if not self._compute.is_current(job):
            return
        self._publish(run, job, first == last)
        if first != last:
            run = self.pipeline.run(work.pair, params, until=last, progress=self._progress)
            if self._compute.is_current(job):
                self._publish(run, job, True)

    def _run_params(self, params: Any, work: WorkPair) -> Any:
        """The parameters a run uses: ``params``, with the smoothness stage in its fast
        mode (:func:`radcons.stages.smoothness.preview_params`) while tuning on a
        downsampled preview or a region, if "fast on previews" is ticked."""
        if not (self.layout.fast_smoothness.value and (work.factor > 1 or work.mode == "region")):
            return params
        from radcons.stages.smoothness import preview_params

        return replace(params, smoothness=preview_params(params.smoothness))

    def _compute_failed(self, job: Job, exc: BaseException) -> None:
        reason = str(exc) if isinstance(exc, RadconsError) else f"{type(exc).__name__}: {exc}"
        if not isinstance(exc, RadconsError):
            import traceback

            traceback.print_exception(exc)
        self._set_status(f"Processing failed: {reason}", 100.0)
        self._notify(None, "Processing failed", reason)

    def _publish(self, run: Any, job: Job, final: bool) -> None:
        """Make ``run`` the shown run and redraw everything that depends on it."""
        with self.session.lock:
            if self.session.work is None or self.session.work.pair is not run.pair:
                return
            self.session.run = run
            self.session.run_generation = job.generation
            self.session.review = None
            step = self.session.add_history(run, _last_of(run)) if final else None
        self._refresh_view(final=final)
        self._refresh_objects()
        self._show_timings(run, final)
        if final:
            if self.layout.auto_review.value or self.layout.compare.value == "3D scene":
                self._request_review()
            if self.live is not None:
                self.live.log(run, step)

    def _show_timings(self, run: Any, final: bool) -> None:
        cells = [
            f"{name} {'cached' if run.cached.get(name) else f'{seconds:.2f} s'}"
            for name, seconds in run.timings.items()
        ]
        self.layout.timings.content = "<sub>" + " · ".join(cells) + "</sub>"
        if final:
            self._set_status(f"Ready · computed in {run.total_time:.2f} s", 100.0)

    # ================================================================== views

    def _on_view_change(self, event: Any) -> None:
        self._request_render()
        if self.layout.auto_review.value or self.layout.compare.value == "3D scene":
            self._request_review()

    def _on_compare_change(self, event: Any) -> None:
        mode = self.layout.compare.value
        self.viewport.set_mode(mode)
        self._request_render()
        if mode == "3D scene":
            review = self.session.review
            if review is None or review.stage != self.layout.view.value:
                self._request_review()
            else:
                self._request_cloud()

    def _request_render(self) -> None:
        self._render.submit(lambda job: self._refresh_view(), fail=self._render_failed, label="render")

    def _request_overlays(self) -> None:
        self._render.submit(lambda job: self._refresh_overlays(), fail=self._render_failed, label="overlays")

    def _render_failed(self, job: Job, exc: BaseException) -> None:
        reason = str(exc) if isinstance(exc, RadconsError) else f"{type(exc).__name__}: {exc}"
        if not isinstance(exc, RadconsError):
            import traceback

            traceback.print_exception(exc)
        self._notify(None, "Display failed", reason)

    def _refresh_view(self, final: bool = True) -> None:
        """Draw the shown view of the current run (or the bare pair) into the viewport.

        Both images are mapped to 8 bits with one range (:func:`render.display_range`) and
        sent as greyscale JPEG; the overlays come from :meth:`_overlays` (cached).
        """
        with self._view_lock:
            with self.session.lock:
                work, run, selected = self.session.work, self.session.run, self.session.selected
                generation, cache = self.session.run_generation, self.session.cache
            if work is None:
                return
            view = self.layout.view.value
            if run is None:
                from radcons.pipeline import pair_images

                images, shown = pair_images(work.pair), "original"
                caption = " · computing…"
            else:
                images = view_images(run, view, cache)
                shown = resolve_view(run, view)
                caption = "" if final else " · running later stages…"
                if shown != view:
                    caption = f" · {view} not run (Tune ▸ {view})" if final else caption
            shape = images[0].shape
            factor = render.downsample_factor(shape, self.display_side)
            pictures = self._pictures(images)
            self._geometry = (factor, pictures[0].shape)
            overlays = self._overlays(run, work, factor, pictures[0].shape, selected)
            titles = (f"reference · {shown}{caption}", f"target · {shown}{caption}")
            self.viewport.show(pictures[0], pictures[1], overlays, titles, shape, float(self.layout.swipe.value))
            self.displayed = Displayed(
                generation, run.params if run is not None else None, shown, images, pictures,
                final and run is not None, time.perf_counter(),
            )
            self.shown_log.append(self.displayed)

    def _refresh_overlays(self) -> None:
        """Redraw only the overlay layers (selection or overlay checkboxes changed)."""
        with self._view_lock:
            with self.session.lock:
                work, run, selected = self.session.work, self.session.run, self.session.selected
            if work is None or self._geometry is None:
                return
            factor, shape = self._geometry
            self.viewport.show_overlays(self._overlays(run, work, factor, shape, selected), float(self.layout.swipe.value))

    def _overlays(self, run: Any, work: WorkPair, factor: int, shape: tuple[int, int], selected: int | None) -> tuple[np.ndarray, np.ndarray]:
        """The RGBA overlay layers of both images, as the overlay checkboxes ask.

        They depend on the objects and the association only, not on the images, so the
        last layers are reused while those (compared by identity) and the options stay
        the same: a radiometric parameter change does not redraw or resend them.
        """
        on = tuple((label, box.value) for label, box in self.layout.overlays.items())
        pair = run.working_pair if run is not None else work.pair
        sources = (pair, run.objects if run is not None else None, run.association if run is not None else None)
        key = (on, selected, factor, tuple(shape))
        cached = self._overlay_cache
        if cached is not None and cached[0] == key and all(a is b for a, b in zip(cached[1], sources)):
            return cached[2]
        layers = self._draw_overlays(dict(on), *sources, factor, shape, selected)
        self._overlay_cache = (key, sources, layers)
        return layers

    @staticmethod
    def _draw_overlays(
        on: dict[str, bool], pair: Pair, objects: Any, assoc: Any, factor: int, shape: tuple[int, int], selected: int | None
    ) -> tuple[np.ndarray, np.ndarray]:
        scale = max(shape) / 360.0  # image pixels per screen pixel, roughly
        change = None
        if on["Change mask"] and pair.change_mask is not None:
            change = render.resize_for_display(pair.change_mask, factor, labels=True)[: shape[0], : shape[1]]
        colours: dict[str, dict[int, tuple[int, int, int]]] = {"reference": {}, "target": {}}
        names: dict[str, dict[int, str] | None] = {"reference": None, "target": {}}
        if assoc is not None:
            for index, obj in enumerate(assoc.objects):
                colour = render.pair_colour(index)
                colours["reference"][obj.ref_id] = colour
                colours["target"][obj.tgt_id] = colour
                names["target"][obj.tgt_id] = str(obj.ref_id)
        selected_tgt = None
        if assoc is not None and selected is not None:
            match = assoc.by_ref().get(selected)
            selected_tgt = match.tgt_id if match is not None else None
        layers = []
        for image, index in (("reference", 0), ("target", 1)):
            labels = None
            if objects is not None and (on["Object outlines"] or on["Object ids"] or selected is not None):
                source = objects.reference if index == 0 else objects.target
                labels = render.resize_for_display(source, factor, labels=True)[: shape[0], : shape[1]]
            points = invariant = None
            if assoc is not None and len(assoc.matches):
                xy = assoc.matches.ref_xy if index == 0 else assoc.matches.tgt_xy
                if on["SIFT matches"]:
                    points = xy / factor
                if on["Invariant points"]:
                    chosen = [o.invariant_indices for o in assoc.objects if o.invariant_indices.size]
                    if chosen:
                        invariant = xy[np.concatenate(chosen)] / factor
            layers.append(
                render.draw_overlay(
                    shape,
                    labels=labels,
                    outlines=on["Object outlines"],
                    colours=colours[image],
                    names=names[image] if on["Object ids"] else {},
                    selected=selected if index == 0 else selected_tgt,
                    points=points,
                    invariant=invariant,
                    change=change,
                    scale=scale,
                )
            )
        return layers[0], layers[1]

    # ================================================================== objects

    def _on_scene_click(self, event: Any) -> None:
        hit = self.viewport.pick(event.ray_origin, event.ray_direction)
        if hit is None:
            return
        image, x, y = hit
        ref_id = object_panel.reference_id_at(self.session.run, image, x, y)
        self.select_object(ref_id)

    def _on_scene_shift_click(self, event: Any) -> None:
        hit = self.viewport.pick(event.ray_origin, event.ray_direction)
        work = self.session.work
        if hit is None or work is None:
            return
        _, x, y = hit
        if work.mode == "region" and work.region is not None:
            centre = (work.region[0] + x, work.region[1] + y)
        else:
            centre = (x * work.factor, y * work.factor)
        self._sync_control(self.layout.work_mode, "region")
        self._reload_work("region", event.client, centre)

    def _on_object_choice(self, event: Any) -> None:
        if self._syncing:
            return
        value = self.layout.object_choice.value
        self.select_object(None if value == "none" else int(value))

    def select_object(self, ref_id: int | None) -> None:
        """Select a reference object (None: no selection) and show its details."""
        with self.session.lock:
            self.session.selected = ref_id
        self._sync_control(self.layout.object_choice, "none" if ref_id is None else str(ref_id))
        self._render.submit(lambda job: (self._refresh_objects(), self._refresh_overlays()), fail=self._render_failed, label="select")

    def _refresh_objects(self) -> None:
        """Redraw the object table, the object dropdown and the selected object's details."""
        with self.session.lock:
            run, review, selected, cache = self.session.run, self.session.review, self.session.selected, self.session.cache
        layout = self.layout
        rows = object_panel.object_rows(run, review)
        options = ("none", *(str(row.ref_id) for row in rows))
        if selected is not None and str(selected) not in options:
            selected = None
            with self.session.lock:
                self.session.selected = None
        if tuple(layout.object_choice.options) != options:
            self._syncing = True
            try:
                layout.object_choice.options = options
            finally:
                self._syncing = False
        self._sync_control(layout.object_choice, "none" if selected is None else str(selected))
        has_truth = run is not None and run.working_pair.disparity is not None
        table = object_panel.table_markdown(rows, selected, has_truth, review is not None) if run is not None else ""
        pictures = (layout.object_crops, layout.object_histograms, layout.object_fit)
        if run is None or selected is None:
            with self.server.atomic():
                layout.object_metrics.content = "Click an object in the images, or choose it above."
                layout.object_table.content = table
                for picture in pictures:
                    picture.visible = False
            return
        view = resolve_view(run, layout.view.value)
        details = object_panel.object_details(run, selected, view, view_images(run, view, cache), review)
        # The heading and metrics first, on their own: the page shows them before it has
        # re-rendered the table and decoded the pictures.
        layout.object_metrics.content = details.metrics
        layout.object_table.content = table
        with self.server.atomic():
            for picture, image in zip(pictures, (details.crops, details.histograms, details.fit)):
                picture.image = image
                picture.visible = True

    # ================================================================== review

    def _request_review(self) -> None:
        self._review.submit(self._review_job, self._deliver_review, self._review_failed, label="review")

    def _review_job(self, job: Job) -> tuple[Any, Review] | None:
        """Measure the shown run (:func:`review_run`), giving way to tuning.

        It starts once no run has been asked for during :data:`REVIEW_DELAY` seconds and
        stops between two methods when a run starts; the run asks for a new review when
        it is done.
        """
        deadline = time.monotonic() + REVIEW_DELAY
        while time.monotonic() < deadline:
            if self._compute.busy or not self._review.is_current(job):
                return None
            time.sleep(0.02)
        with self.session.lock:
            run, cache = self.session.run, self.session.cache
        if run is None:
            return None
        self.layout.review_table.content = "_Matching…_"
        stop = lambda: self._compute.busy or not self._review.is_current(job)  # noqa: E731
        review = review_run(run, self.layout.view.value, cache, self._baselines, stop)
        return None if review is None else (run, review)

    def _deliver_review(self, job: Job, result: tuple[Any, Review] | None) -> None:
        if result is None:
            return
        run, review = result
        with self.session.lock:
            if self.session.run is not run:
                return
            self.session.review = review
        self._show_review(review)
        self._refresh_objects()
        self._request_cloud()

    def _review_failed(self, job: Job, exc: BaseException) -> None:
        reason = str(exc) if isinstance(exc, RadconsError) else f"{type(exc).__name__}: {exc}"
        if not isinstance(exc, RadconsError):
            import traceback

            traceback.print_exception(exc)
        self.layout.review_table.content = f"_Dense matching failed: {reason}_"

    def _show_review(self, review: Review) -> None:
        layout = self.layout
        has_truth = review.truth is not None
        low, high = review.disparity_range
        lines = [
            f"Dense matching (SGBM) of **{review.stage}**, disparities {low:.0f}..{high:.0f} px.",
            "",
            "| method | correct rate | mean object rate | mean C (eq 20) |" if has_truth else "| method | mean C (eq 20) |",
            "|---|---:|---:|---:|" if has_truth else "|---|---:|",
        ]
        methods = [review.current] + [m for m in review.others if m.name != review.current.name]
        for method in methods:
            name = f"**{method.name}** (shown)" if method is review.current else method.name
            similarity = object_panel._num(method.mean_similarity)
            if has_truth:
                lines.append(f"| {name} | {object_panel._num(method.correct_rate)} | {object_panel._num(method.mean_object_rate)} | {similarity} |")
            else:
                lines.append(f"| {name} | {similarity} |")
        if not has_truth:
            lines.append("\n_No ground-truth disparity: correct-matching rates need one._")
        factor = render.downsample_factor(review.current.disparity.shape, 1024)
        disparity = render.resize_for_display(review.current.disparity, factor, labels=True)
        with self.server.atomic():
            layout.review_table.content = "\n".join(lines)
            layout.disparity_image.image = render.colourise(disparity, review.disparity_range)
            if has_truth:
                truth = render.resize_for_display(review.truth, factor, labels=True)
                layout.truth_image.image = render.colourise(truth, review.disparity_range)
                layout.error_image.image = render.error_map(disparity, truth)
            layout.truth_image.visible = has_truth
            layout.error_image.visible = has_truth

    def _request_cloud(self) -> None:
        review = self.session.review
        if review is None:
            return

        def draw(job: Job) -> None:
            displayed = self.displayed
            if displayed is None or displayed.images[0].shape != review.current.disparity.shape:
                return
            colours = render.to_display(displayed.images[0], render.display_range(*displayed.images))
            points, rgb = render.point_cloud(review.current.disparity, colours, height_scale=float(self.layout.height_scale.value))
            self.viewport.show_cloud(points, rgb)

        self._render.submit(draw, fail=self._render_failed, label="cloud")

    # ================================================================== record / export

    def _on_record(self, event: Any) -> None:
        if self._record_thread is not None and self._record_thread.is_alive():
            self._notify(event.client, "Recording", "A recording is being written already.", error=False)
            return
        client = event.client
        self._record_thread = threading.Thread(target=self._record, args=(client,), name="inspector-record", daemon=True)
        self._record_thread.start()

    def _record(self, client: Any) -> None:
        from radcons.pipeline import Pipeline

        with self.session.lock:
            work, run, history, review = self.session.work, self.session.run, list(self.session.history), self.session.review
        if work is None or run is None:
            self._notify(client, "Nothing to record", "No run has finished yet.")
            return
        try:
            from inspector.recording import write_recording

            pipeline = Pipeline()
            runs = [
                (entry.step, entry.run if entry.run is not None else pipeline.run(work.pair, entry.params, until=entry.until))
                for entry in history[:-1]
            ]
            runs.append((history[-1].step if history else 0, run))
            comparison = self._comparison(run, review)
            path = write_recording(self.record_dir, work.full.name, runs, comparison)
        except Exception as exc:  # noqa: BLE001 - reported to the user
            reason = str(exc) if isinstance(exc, RadconsError) else f"{type(exc).__name__}: {exc}"
            self._notify(client, "Recording failed", reason)
            return
        self.last_recording = path
        self.layout.export_info.content = self._export_text()
        self._notify(client, "Recording written", f"{path} ({len(runs)} tuning steps)", error=False)

    @staticmethod
    def _comparison(run: Any, review: Review | None) -> Any:
        """A :class:`radcons.evaluate.compare.Comparison` of the review, for the recorder."""
        if review is None:
            return None
        from radcons.evaluate.compare import Comparison
        from radcons.evaluate.matching import MatcherParams

        methods = [m for m in review.others if m.name != review.current.name] + [review.current]
        return Comparison(run.pair.name, tuple(methods), object_pairs(run), review.disparity_range, MatcherParams(), 1.0, review.truth is not None)

    def _on_export(self, event: Any) -> None:
        with self.session.lock:
            params, work = self.session.params, self.session.work
        name = work.full.name if work is not None else "radcons"
        stamp = time.strftime("%Y%m%d-%H%M%S")
        from inspector.recording import file_stem

        path = self.record_dir / f"{file_stem(name)}-params-{stamp}.toml"
        counter = 1
        while path.exists():
            path = self.record_dir / f"{file_stem(name)}-params-{stamp}-{counter}.toml"
            counter += 1
        try:
            params.save(path)
        except OSError as exc:
            self._notify(event.client, "Export failed", str(exc))
            return
        self.last_export = path
        self.layout.export_info.content = self._export_text()
        self._notify(event.client, "Parameters exported", f"{path} — use it with `radcons process --params`", error=False)
        if event.client is not None:
            event.client.send_file_download(path.name, path.read_bytes(), save_immediately=True)

    def _export_text(self) -> str:
        lines = []
        if self.live is not None:
            lines.append(f"Live rerun viewer: [{self.live.url}]({self.live.url})")
        if self.last_recording is not None:
            lines.append(f"Recording: `{self.last_recording}`  \nopen with `radcons view {self.last_recording}`")
        if self.last_export is not None:
            lines.append(f"Parameters: `{self.last_export}`  \nuse with `radcons process PAIR --params {self.last_export} --out OUT`")
        return "\n\n".join(lines)


def _last_of(run: Any) -> str:
    """The last pipeline stage a run reached."""
    from radcons.params import STAGES

    return [name for name in STAGES if name in run.results][-1]


def _attr(stage: str) -> str:
    """Attribute of :class:`radcons.params.Params` holding a stage's parameters."""
    return "global_norm" if stage == "global" else stage


def _free_port(host: str) -> int:
    from inspector.recording import free_port

    return free_port(host if host not in ("", "0.0.0.0") else "127.0.0.1")


def serve(args: argparse.Namespace) -> int:
    """Run the inspector until interrupted (``radcons inspect``).

    Parameters
    ----------
    args : argparse.Namespace
        ``pairs`` (list of Path), ``host``, ``port``, ``data_root`` (list of Path),
        ``record_dir`` (Path) and ``rerun_web`` (bool).

    Returns
    -------
    int
        Exit status (0 after Ctrl+C or SIGTERM).
    """
    app = InspectorApp(
        pairs=list(args.pairs), data_roots=list(args.data_root), record_dir=args.record_dir,
        host=args.host, port=args.port, rerun_web=args.rerun_web,
    )
    stop = threading.Event()

    def interrupted(signum: int, frame: Any) -> None:
        # The event stops the app even when the KeyboardInterrupt is lost (Python drops
        # one raised while a finalizer runs, or under a library's bare ``except:``):
        # a start it did not interrupt goes on, and stop.wait() then returns at once.
        stop.set()
        if signum == signal.SIGINT:
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
        app.stop()
        for signum, handler in handlers.items():
            signal.signal(signum, handler)
    return 0
