"""Session state of the inspector: the pair being tuned, its parameters, runs and history.

One :class:`Session` is shared by every connected browser (viser shares its GUI between
clients), so two analysts looking at the same server see the same pair, parameters and
results. Tuning runs on a *work pair*: the full pair when it is small, a downsampled
preview (longest side ``preview_side``) or a full-resolution region of a large pair.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field, replace
from typing import Any

import cv2
import numpy as np

from radcons.errors import InputError
from radcons.io import Pair

__all__ = ["WorkPair", "HistoryEntry", "Session", "preview_pair", "region_pair", "centred_region", "MODES"]

#: Ways of tuning a pair: the whole pair downsampled, the whole pair, or a region of it.
MODES: tuple[str, ...] = ("preview", "full", "region")


@dataclass(frozen=True)
class WorkPair:
    """The pair the pipeline runs on, and how it was made from the loaded pair.

    Attributes
    ----------
    label : str
        Name of the loaded pair (as in the dropdown).
    full : Pair
        The pair as loaded.
    pair : Pair
        The pair tuned on (``full`` itself, a preview or a region).
    mode : str
        One of :data:`MODES`.
    factor : int
        Downsampling factor of ``pair`` relative to ``full`` (1 for full and region).
    region : (int, int, int, int) or None
        ``(x, y, width, height)`` of a region in ``full`` pixels.
    scene : inspector.scene_preview.SceneSource or None
        The scene when the pair is too large to load whole: ``full`` is then the pair
        read from it (a decimated preview or a region) and pixels count in the scene's.
    """

    label: str
    full: Pair
    pair: Pair
    mode: str = "full"
    factor: int = 1
    region: tuple[int, int, int, int] | None = None
    scene: Any = None

    @property
    def shape(self) -> tuple[int, int]:
        """Rows and columns of the pair as a whole (the scene's for a scene)."""
        return tuple(self.scene.shape) if self.scene is not None else self.full.shape

    @property
    def describe(self) -> str:
        """One line for the status panel."""
        height, width = self.shape
        if self.mode == "preview" and self.scene is not None:
            h, w = self.pair.shape
            return f"preview {w}x{h} of a scene (1/{self.factor} of {width}x{height}, read decimated)"
        if self.mode == "preview" and self.factor > 1:
            h, w = self.pair.shape
            return f"preview {w}x{h} (1/{self.factor} of {width}x{height})"
        if self.mode == "region" and self.region is not None:
            x, y, w, h = self.region
            return f"region {w}x{h} at ({x}, {y}) of {width}x{height}"
        return f"full resolution {width}x{height}"


@dataclass(frozen=True)
class HistoryEntry:
    """One parameter setting that was computed and shown (a ``tuning_step``).

    Attributes
    ----------
    step : int
    params : radcons.params.Params
    timings : dict
        Seconds per stage.
    until : str
        Last stage the run reached.
    run : radcons.pipeline.Run or None
        The run itself, kept for the newest entries only (older ones are recomputed when
        a recording asks for them).
    """

    step: int
    params: Any
    timings: dict[str, float]
    until: str
    run: Any = field(default=None, repr=False, compare=False)


def _shrink_image(image: np.ndarray, factor: int) -> np.ndarray:
    """Area-average ``image`` by ``factor`` over its valid pixels; a block with fewer than
    half of its pixels valid becomes NaN."""
    height, width = image.shape
    size = (width // factor, height // factor)
    valid = np.isfinite(image)
    if valid.all():
        return cv2.resize(image.astype(np.float32), size, interpolation=cv2.INTER_AREA)
    weight = cv2.resize(valid.astype(np.float32), size, interpolation=cv2.INTER_AREA)
    total = cv2.resize(np.where(valid, image, 0).astype(np.float32), size, interpolation=cv2.INTER_AREA)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(weight > 0.5, total / weight, np.nan).astype(np.float32)


def _take(array: np.ndarray | None, factor: int, shape: tuple[int, int]) -> np.ndarray | None:
    """Subsample a label raster or mask (nearest) by ``factor`` to ``shape``."""
    if array is None:
        return None
    return np.ascontiguousarray(array[factor // 2 :: factor, factor // 2 :: factor][: shape[0], : shape[1]])


def preview_pair(pair: Pair, max_side: int) -> tuple[Pair, int]:
    """Downsample a pair by an integer factor so that its longest side is at most ``max_side``.

    Images are area-averaged as float32 (NaN marks nodata), label rasters and the change
    mask are subsampled, and the ground-truth disparity is subsampled and divided by the
    factor (it is measured in pixels).

    Returns
    -------
    pair : Pair
        The preview (``pair`` itself when it is small enough).
    factor : int
    """
    if max_side < 16:
        raise InputError(f"preview side must be at least 16 px, got {max_side}")
    factor = max(1, int(np.ceil(max(pair.shape) / max_side)))
    if factor == 1:
        return pair, 1
    images = []
    for raster in (pair.reference, pair.target):
        data = raster.data.astype(np.float32)
        data[~raster.valid_mask()] = np.nan
        images.append(_shrink_image(data, factor))
    shape = images[0].shape
    preview = replace(
        pair,
        reference=replace(pair.reference, data=images[0], nodata=None, path=None),
        target=replace(pair.target, data=images[1], nodata=None, path=None),
        disparity=None if pair.disparity is None else _take(pair.disparity, factor, shape) / factor,
        reference_objects=_take(pair.reference_objects, factor, shape),
        target_objects=_take(pair.target_objects, factor, images[1].shape),
        change_mask=_take(pair.change_mask, factor, shape),
        name=f"{pair.name} (1/{factor})",
    )
    return preview, factor


def region_pair(pair: Pair, box: tuple[int, int, int, int]) -> Pair:
    """Cut the same region ``(x, y, width, height)`` from both images and their ground truth.

    The disparity stays valid (rows and columns shift equally in both images); matches
    that leave the region are lost at its borders.
    """
    x, y, width, height = (int(v) for v in box)
    rows, cols = pair.shape
    if width < 16 or height < 16 or x < 0 or y < 0 or x + width > cols or y + height > rows:
        raise InputError(f"region {box} does not fit in the {cols}x{rows} pair")
    window = (slice(y, y + height), slice(x, x + width))

    def cut(array: np.ndarray | None) -> np.ndarray | None:
        return None if array is None else np.ascontiguousarray(array[window])

    return replace(
        pair.with_images(cut(pair.reference.data), cut(pair.target.data)),
        disparity=cut(pair.disparity),
        reference_objects=cut(pair.reference_objects),
        target_objects=cut(pair.target_objects),
        change_mask=cut(pair.change_mask),
        name=f"{pair.name} [{x}:{x + width}, {y}:{y + height}]",
    )


def centred_region(shape: tuple[int, int], centre: tuple[float, float], side: int) -> tuple[int, int, int, int]:
    """A square ``side`` px region centred on ``(x, y)``, moved inside an image of ``shape``."""
    rows, cols = shape
    width, height = min(side, cols), min(side, rows)
    x = int(np.clip(round(centre[0] - width / 2), 0, cols - width))
    y = int(np.clip(round(centre[1] - height / 2), 0, rows - height))
    return x, y, width, height


@dataclass
class Session:
    """Everything the inspector shows, guarded by one lock.

    Attributes
    ----------
    work : WorkPair or None
        The pair being tuned.
    params : radcons.params.Params
        The parameters of the newest request.
    run : radcons.pipeline.Run or None
        The run shown (the newest one that finished).
    run_generation : int
        Worker generation of ``run``.
    history : list of HistoryEntry
        The parameter settings shown on the current pair, oldest first (at most
        ``max_history``; the newest ``keep_runs`` keep their run).
    selected : int or None
        Reference id of the selected object.
    review : Any
        The latest :class:`inspector.review.Review` of ``run`` (None until computed).
    cache : dict
        Per-pair results that do not depend on the parameters (baselines, the original
        pair's dense disparity), cleared when the work pair changes.
    view : str
        The image stage or ``"baseline:<name>"`` chosen for the viewport.
    smoothness_live : bool
        Every run goes on to the smoothness stage (else only when asked for).
    smoothness_asked : bool
        The next run goes on to the smoothness stage ("Run smoothness now").
    fast_previews : bool
        On a downsampled preview or a region, the smoothness stage runs in its fast mode.
    """

    params: Any
    work: WorkPair | None = None
    run: Any = None
    run_generation: int = 0
    history: list[HistoryEntry] = field(default_factory=list)
    selected: int | None = None
    review: Any = None
    cache: dict[str, Any] = field(default_factory=dict)
    view: str = ""
    smoothness_live: bool = False
    smoothness_asked: bool = False
    fast_previews: bool = True
    lock: threading.RLock = field(default_factory=threading.RLock, repr=False)
    max_history: int = 64
    keep_runs: int = 8

    def set_work(self, work: WorkPair) -> None:
        """Switch to another work pair: forget the run, history, selection and caches."""
        with self.lock:
            self.work = work
            self.run = None
            self.review = None
            self.history = []
            self.selected = None
            self.cache = {}

    def add_history(self, run: Any, until: str) -> int:
        """Record a shown run's setting unless it repeats the previous one; return its step.

        The newest :attr:`keep_runs` entries keep their run.
        """
        with self.lock:
            if self.history and self.history[-1].params == run.params and self.history[-1].until == until:
                return self.history[-1].step
            step = self.history[-1].step + 1 if self.history else 0
            self.history.append(HistoryEntry(step, run.params, dict(run.timings), until, run))
            del self.history[: max(0, len(self.history) - self.max_history)]
            for index in range(max(0, len(self.history) - self.keep_runs)):
                if self.history[index].run is not None:
                    self.history[index] = replace(self.history[index], run=None)
            return step
