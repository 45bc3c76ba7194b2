"""The Data tab: which pair is tuned, and at which resolution.

A pair comes from the dropdown (pairs given on the command line and found under the data
roots), a folder typed in, two uploaded images or the demo generator. Files are read only
inside the allowed roots (:class:`~inspector.paths.AllowedRoots`); uploads go to a private
temporary folder and are read with the same readers as any input. Pairs are opened on
the compute thread (:meth:`inspector.runner.Runner.request_load`); one that fails to open
leaves the previous pair in place.

A large pair is tuned on a downsampled preview, at full resolution, or on a
full-resolution region (:data:`inspector.state.MODES`). A scene-sized pair (one whose
in-memory run would pass the memory budget) is never loaded whole: its preview is a
decimated read and its regions windowed reads (:mod:`inspector.scene_preview`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

from inspector.context import Context, failure_reason
from inspector.describe import bands_text, geometry_text, light_text, noise_text, rectification_text
from inspector.panels.base import Panel
from inspector.paths import AllowedRoots, PairSource
from inspector.runner import Runner
from inspector.scene_preview import SceneSource, read_preview, read_region, scene_source
from inspector.state import MODES, WorkPair, centred_region, preview_pair, region_pair
from inspector.uploads import UPLOAD_TYPES, Uploads
from radcons.errors import InputError, RadconsError
from radcons.io import Pair, load_pair, load_pair_files
from radcons.io.raster import SUPPORTED_TEXT

__all__ = ["DataPanel", "LoadRequest", "DEMO_LABEL", "MAX_UPLOAD_MIB", "SCENARIOS"]

#: Dropdown entry of the demo pair generated on the fly.
DEMO_LABEL = "built-in demo"
#: Largest accepted upload, per image, in MiB.
MAX_UPLOAD_MIB = 64
#: Demo generator scenarios (what differs between the two images).
SCENARIOS: tuple[str, ...] = ("mixed", "multi-temporal", "multi-sensor", "none")


@dataclass(frozen=True)
class LoadRequest:
    """A pair to open.

    Attributes
    ----------
    label : str
        Its name in the dropdown and the status line.
    loader : callable
        Reads or makes the pair, or says where a scene-sized one is (on the compute thread).
    mode : str
        One of :data:`inspector.state.MODES`.
    client : viser.ClientHandle or None
        Who asked (told when it fails).
    centre : (float, float) or None
        Centre of a region, in pixels of the pair.
    work : WorkPair or None
        The work pair when it is already made (the first pair, shown before the panels).
    """

    label: str
    loader: Callable[[], Pair | SceneSource]
    mode: str
    client: Any
    centre: tuple[float, float] | None = None
    work: WorkPair | None = None


def _pair_labels(sources: Sequence[PairSource]) -> list[str]:
    """Dropdown labels of the sources, made unique (and never the demo's)."""
    labels: list[str] = []
    for source in sources:
        label = source.label
        while label in labels or label == DEMO_LABEL:
            label += "'"
        labels.append(label)
    return labels


def _demo_loader(size: int, seed: int, scenario: str) -> Callable[[], Pair]:
    def load() -> Pair:
        from demo_data_gen import generate

        return generate(size=int(size), seed=int(seed), scenario=scenario)

    return load


class DataPanel(Panel):
    """Opens pairs: the Data tab's controls and the loading of the work pair.

    Parameters
    ----------
    context : Context
    runner : Runner
        Opens the pairs on the compute thread.
    roots : AllowedRoots
        What may be read.
    sources : sequence of PairSource
        The pairs offered in the dropdown; the first is opened at start when it was given
        on the command line.
    preview_side : int
        Longest side of the preview a large pair is tuned on (and of a region).
    demo : dict
        ``size``, ``seed`` and ``scenario`` of the built-in demo pair.
    max_upload_bytes : int
        Largest accepted upload per image.
    reading : dict, optional
        ``band`` and ``rectified`` as ``radcons process`` takes them (``--band``,
        ``--rectified`` / ``--unrectified``), for every pair read from files.
    scene_pixels : int, optional
        Pixels per image above which a pair read from files is a scene (tuned on a
        decimated read); None: the memory budget decides.
    memory_limit : int, optional
        The memory budget, bytes (default: that of ``radcons process``).
    """

    def __init__(
        self,
        context: Context,
        runner: Runner,
        roots: AllowedRoots,
        sources: Sequence[PairSource],
        preview_side: int,
        demo: dict[str, Any],
        max_upload_bytes: int,
        reading: dict[str, Any] | None = None,
        scene_pixels: int | None = None,
        memory_limit: int | None = None,
    ) -> None:
        super().__init__(context)
        self.scene_pixels = scene_pixels
        self.memory_limit = memory_limit
        self.reading = {"band": None, "rectified": None, **(reading or {})}
        self.runner = runner
        self.roots = roots
        self.sources = list(sources)
        self.labels = _pair_labels(self.sources)
        self.preview_side = preview_side
        self.demo = dict(demo)
        self._uploads = Uploads(max_upload_bytes)
        #: Pairs opened from a folder typed in, uploads and generated demos: label -> loader.
        self._opened: dict[str, Callable[[], Pair | SceneSource]] = {}
        self._current_label = DEMO_LABEL

    def build(self, gui: Any) -> None:
        """Add the pair choice, the folder input, uploads, the demo generator and the
        resolution choice."""
        self.pair_info = gui.add_markdown("")
        self.geometry_info = gui.add_markdown("")
        self.noise_info = gui.add_markdown("")
        self.pair = gui.add_dropdown(
            "Pair", (DEMO_LABEL, *self.labels), initial_value=DEMO_LABEL,
            hint="Pairs given on the command line and found under --data-root",
        )
        self.pair.on_update(self.on_pair_choice)
        self.folder = gui.add_text("Folder", "", hint="A pair folder (with pair.toml) inside the allowed folders")
        self.open_folder = gui.add_button("Open folder")
        self.open_folder.on_click(self.on_open_folder)
        with gui.add_folder("Upload two images", expand_by_default=False):
            gui.add_markdown(
                f"{SUPPORTED_TEXT} up to {self._uploads.max_bytes // 2**20} MiB each; reference (left) "
                "first. Colour and multiband images are read as one grey band."
            )
            self.upload_reference = gui.add_upload_button("Reference image", mime_type=UPLOAD_TYPES)
            self.upload_reference.on_upload(lambda event: self.on_upload("reference", event))
            self.upload_target = gui.add_upload_button("Target image", mime_type=UPLOAD_TYPES)
            self.upload_target.on_upload(lambda event: self.on_upload("target", event))
            self.upload_info = gui.add_markdown("")
        with gui.add_folder("Demo generator", expand_by_default=False):
            self.scenario = gui.add_dropdown("Scenario", SCENARIOS, initial_value="mixed")
            self.seed = gui.add_number("Seed", 0, min=0, step=1)
            self.demo_size = gui.add_number("Size", 512, min=64, max=4096, step=64)
            self.generate = gui.add_button("Generate demo pair")
            self.generate.on_click(self.on_generate)
        with gui.add_folder("Resolution"):
            self.work_mode = gui.add_dropdown(
                "Tune on", MODES, initial_value="preview",
                hint="preview: the whole pair downsampled; full: every pixel; region: a full-resolution window (Shift+click the image to move it)",
            )
            self.work_mode.on_update(self.on_work_mode)
            self.apply_full = gui.add_button("Tune at full resolution")
            self.apply_full.on_click(self.on_apply_full)

    # ------------------------------------------------------------------ the first pair

    def first_pair(self) -> tuple[str, Pair | SceneSource | None]:
        """The label of the pair opened at start, and the pair when it was given on the
        command line (read now: a bad one raises :class:`InputError`); None for the
        built-in demo pair (see :meth:`demo_loader`)."""
        if self.sources and self.sources[0].given:
            return self.labels[0], self._source_loader(self.sources[0])()
        return DEMO_LABEL, None

    def demo_loader(self) -> Callable[[], Pair]:
        """Generates the built-in demo pair."""
        return _demo_loader(**self.demo)

    def open_first(self, work: WorkPair) -> None:
        """Open the first pair, already made into ``work`` (and shown) at start."""
        loaded = work.scene if work.scene is not None else work.full
        self._request(LoadRequest(work.label, lambda: loaded, work.mode, None, work=work))

    def work_pair(
        self, label: str, pair: Pair | SceneSource, mode: str, centre: tuple[float, float] | None = None
    ) -> WorkPair:
        """The work pair of ``pair`` for tuning ``mode`` (a region centred on ``centre``)."""
        if mode not in MODES:
            raise InputError(f"unknown tuning mode {mode!r}")
        if isinstance(pair, SceneSource):
            return self._scene_work_pair(label, pair, mode, centre)
        if mode == "preview":
            work, factor = preview_pair(pair, self.preview_side)
            return WorkPair(label, pair, work, "preview", factor)
        if mode == "region":
            if centre is None:
                centre = (pair.shape[1] / 2, pair.shape[0] / 2)
            box = centred_region(pair.shape, centre, self.preview_side)
            return WorkPair(label, pair, region_pair(pair, box), "region", 1, box)
        return WorkPair(label, pair, pair, "full", 1)

    def _scene_work_pair(
        self, label: str, scene: SceneSource, mode: str, centre: tuple[float, float] | None
    ) -> WorkPair:
        """A decimated preview or a full-resolution region read from a scene; never the whole."""
        rows, cols = scene.shape
        if mode == "full":
            raise InputError(
                f"{label} is a scene of {cols}x{rows} px, too large to tune whole: tune on the preview or a "
                "region, then process it whole with Apply to full resolution (Export tab)"
            )
        if mode == "region":
            box = centred_region(scene.shape, centre or (cols / 2, rows / 2), self.preview_side)
            region = read_region(scene, box)
            return WorkPair(label, region, region, "region", 1, box, scene=scene)
        preview, factor = read_preview(scene, self.preview_side)
        return WorkPair(label, preview, preview, "preview", factor, scene=scene)

    # ------------------------------------------------------------------ loading

    def _read_folder(self, folder: str | Path) -> Pair | SceneSource:
        """Read a pair folder inside the allowed roots, its geometry decided (a scene-sized
        one: only its headers)."""
        from radcons.geometry import settle_geometry

        checked = self.roots.check(folder)
        scene = scene_source([checked], self.scene_pixels, self.reading, self.memory_limit)
        return scene if scene is not None else settle_geometry(load_pair(checked, **self.reading))

    def _read_files(self, reference: Path, target: Path, name: str | None = None) -> Pair | SceneSource:
        """Read two image files as a pair, its geometry decided (files already checked; a
        scene-sized pair: only their headers)."""
        from radcons.geometry import settle_geometry

        scene = scene_source([reference, target], self.scene_pixels, self.reading, self.memory_limit)
        if scene is not None:
            return scene
        return settle_geometry(load_pair_files(reference, target, name=name, **self.reading))

    def _source_loader(self, source: PairSource) -> Callable[[], Pair | SceneSource]:
        if source.folder is not None:
            folder = source.folder
            return lambda: self._read_folder(folder)
        reference, target = source.files
        return lambda: self._read_files(self.roots.check(reference), self.roots.check(target))

    def _request(self, request: LoadRequest) -> None:
        self.runner.request_load(lambda: self._load(request))

    def _load(self, request: LoadRequest) -> None:
        """Open a requested pair (on the compute thread); on failure notify and keep the
        previous one."""
        self.context.set_status(f"Loading {request.label}…", 0.0)
        try:
            work = request.work or self.work_pair(request.label, request.loader(), request.mode, request.centre)
        except Exception as exc:  # noqa: BLE001 - any failure keeps the previous pair
            self.context.notify(request.client, f"Could not open {request.label}", failure_reason(exc))
            self.set_quietly(self.pair, self._current_label)
            if self.context.session.work is not None:
                self.set_quietly(self.work_mode, self.context.session.work.mode)
            self.context.set_status("Kept the previous pair.", 100.0)
            return
        self.context.session.set_work(work)
        self._current_label = request.label
        self._offer(request.label, request.loader)
        self.set_quietly(self.pair, request.label)
        self.set_quietly(self.work_mode, work.mode)
        self._show_pair_info(work)
        self.context.pair_loaded.emit()

    def _offer(self, label: str, loader: Callable[[], Pair | SceneSource]) -> None:
        """Add a pair opened otherwise than from the dropdown to it, so that the dropdown
        always names the pair loaded and can open it again."""
        if label in self.pair.options:
            return
        self._opened[label] = loader
        with self.quietly():
            self.pair.options = (*self.pair.options, label)

    def _show_pair_info(self, work: WorkPair) -> None:
        pair = work.full
        truth = [name for name, value in (("disparity", pair.disparity), ("objects", pair.reference_objects), ("change mask", pair.change_mask)) if value is not None]
        rows, cols = work.shape
        dtype = work.scene.dtype if work.scene is not None else pair.reference.data.dtype
        lines = [
            f"**{work.label}** — {cols}x{rows} px, {dtype}",
            f"Tuning on: {work.describe}",
            f"Ground truth: {', '.join(truth) if truth else 'none'}",
        ]
        shown = [f"{key}: {pair.metadata[key]}" for key in ("sensor", "date", "scenario") if key in pair.metadata]
        if shown:
            lines.append(" · ".join(shown))
        lines.append(bands_text(pair))
        lines.append(f"Geometry: {geometry_text(pair)}")
        self.pair_info.content = "  \n".join(lines)
        self.geometry_info.content = ""
        self.noise_info.content = ""
        large = max(work.shape) > self.preview_side
        self.apply_full.disabled = not large or work.scene is not None
        self.work_mode.disabled = not large

    def _reload(self, mode: str, client: Any, centre: tuple[float, float] | None = None) -> None:
        """Open the current pair again, tuned in ``mode``."""
        work = self.context.session.work
        if work is None:
            return
        loaded = work.scene if work.scene is not None else work.full
        self._request(LoadRequest(work.label, lambda: loaded, mode, client, centre))

    # ------------------------------------------------------------------ callbacks

    def on_pair_choice(self, event: Any) -> None:
        """A pair was chosen in the dropdown."""
        if self.quiet:
            return
        label = self.pair.value
        if label == self._current_label:
            return
        if label == DEMO_LABEL:
            loader = self.demo_loader()
        elif label in self._opened:
            loader = self._opened[label]
        else:
            loader = self._source_loader(self.sources[self.labels.index(label)])
        self._request(LoadRequest(label, loader, "preview", event.client))

    def on_open_folder(self, event: Any) -> None:
        """Open the pair folder typed in (inside the allowed roots)."""
        text = self.folder.value.strip()
        if not text:
            self.context.notify(event.client, "No folder", "Type the path of a pair folder first.")
            return

        def load() -> Pair:
            return self._read_folder(text)

        self._request(LoadRequest(Path(text).name or text, load, "preview", event.client))

    def on_upload(self, role: str, event: Any) -> None:
        """Check an uploaded ``"reference"`` or ``"target"`` image; open the pair once both
        are in."""
        uploaded = event.target.value
        try:
            pair = self._uploads.receive(role, uploaded.name, uploaded.content)
        except RadconsError as exc:
            self.context.notify(event.client, f"Upload refused: {Path(uploaded.name or '').name or role}", exc.reason)
            self.upload_info.content = self._uploads.describe()
            return
        self.upload_info.content = self._uploads.describe()
        if pair is None:
            return
        label = f"upload: {pair.names[0]} + {pair.names[1]}"
        while label in self.pair.options:
            label += "'"

        def load() -> Pair:
            return self._read_files(pair.reference, pair.target, name=Path(pair.names[0]).stem)

        self._request(LoadRequest(label, load, "preview", event.client))

    @property
    def uploads(self) -> dict[str, Path]:
        """Uploaded images waiting for the other one: role -> file."""
        return self._uploads.waiting

    def on_generate(self, event: Any) -> None:
        """Generate a demo pair with the generator's settings."""
        size, seed, scenario = int(self.demo_size.value), int(self.seed.value), self.scenario.value
        label = f"demo {scenario} {size}px seed {seed}"
        self._request(LoadRequest(label, _demo_loader(size, seed, scenario), "preview", event.client))

    def on_work_mode(self, event: Any) -> None:
        """Tune the current pair on a preview, at full resolution or on a region."""
        if self.quiet:
            return
        self._reload(self.work_mode.value, event.client)

    def on_apply_full(self, event: Any) -> None:
        """Tune the current pair at full resolution."""
        self.set_quietly(self.work_mode, "full")
        self._reload("full", event.client)

    def open_region(self, centre: tuple[float, float], client: Any) -> None:
        """Tune on the full-resolution region centred on ``centre`` (pixels of the pair)."""
        self.set_quietly(self.work_mode, "region")
        self._reload("region", client, centre)

    def show_run(self, run: Any, final: bool) -> None:
        """Show how a run's epipolar resampling went (nothing for a rectified pair) and, once
        the run is whole, the noise notice of its images (:func:`radcons.summary.run_noise_notice`)
        and whether its light was corrected across the scene (:func:`light_text`)."""
        work = self.context.session.work
        if work is None or run.pair is not work.pair:
            return
        self.geometry_info.content = rectification_text(run.rectification, work.factor)
        if final:
            self.noise_info.content = "\n\n".join(text for text in (noise_text(run), light_text(run)) if text)

    def stop(self) -> None:
        """Delete the uploaded files."""
        self._uploads.remove()
