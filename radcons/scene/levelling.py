"""Row levelling of a scene pair: the target's vertical offset taken out window by window.

The in-memory route levels a rectified pair's target as it loads it
(:func:`radcons.geometry.level_rows`); a scene is never read whole, so here the plane of
vertical offset (:mod:`radcons.stages.rectify.row_levelling`) is fitted on the SIFT matches of
full-resolution windows spread over the scene (:func:`measure_scene_offset`), and the
target is wrapped in a :class:`LevelledImage` that resamples each window it reads. The
same pair thus gets the same target whichever mode processes it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from radcons.pipeline import to_output_dtype
from radcons.scene.source import SceneImage, ScenePair, Window
from radcons.stages.rectify.row_levelling import (
    INLIER_PX,
    RowOffset,
    fit_row_offset,
    level_target,
    row_matches,
)

__all__ = ["LevelledImage", "measure_scene_offset", "level_scene_rows"]

#: Side of the windows the plane is measured on, px (full resolution).
SAMPLE_SIDE = 1024
#: At most this many windows a side (a 3 x 3 grid on a large scene).
SAMPLES_PER_SIDE = 3
#: Rows read beyond a window on each side, besides the plane's own offset: bicubic footprint.
_MARGIN = 3


@dataclass(frozen=True)
class LevelledImage(SceneImage):
    """A scene image whose reads are resampled so that ``image'(x, y) = image(x, y - dy(x, y))``.

    Attributes
    ----------
    plane : (float, float, float)
        ``(a, b, c)`` of ``dy = a x + b y + c``, px of the whole image
        (:class:`radcons.stages.rectify.row_levelling.RowOffset`).
    labels : bool
        A label raster: nearest neighbour instead of bicubic.
    """

    plane: tuple[float, float, float] = (0.0, 0.0, 0.0)
    labels: bool = False

    def read(self, window: Window) -> np.ndarray:
        """The levelled window in the file's dtype."""
        r0, r1, c0, c1 = window
        a, b, c = self.plane
        reach = math.ceil(max(abs(a * x + b * y + c) for x in (c0, c1) for y in (r0, r1))) + _MARGIN
        top, bottom = max(0, r0 - reach), min(self.shape[0], r1 + reach)
        data = SceneImage.read(self, (top, bottom, c0, c1))
        local = (a, b, a * c0 + b * top + c)  # the plane in the read block's coordinates
        if self.labels:
            levelled = level_target(data.astype(np.float32), local, nearest=True)
        else:
            image = self.to_float(data)
            levelled = level_target(image, local, np.isfinite(image))
        return to_output_dtype(levelled, self.dtype, self.nodata)[r0 - top : r0 - top + (r1 - r0)]

    def read_decimated(self, factor: int, *, labels: bool = False) -> np.ndarray:
        """The decimated image, levelled by the plane on the decimated grid (previews, statistics)."""
        small = SceneImage.read_decimated(self, factor, labels=labels)
        if factor == 1:
            return small
        a, b, c = self.plane
        levelled = level_target(small.astype(np.float32), (a, b, c / factor), nearest=labels or self.labels)
        return to_output_dtype(levelled, small.dtype, None)


def _sample_windows(shape: tuple[int, int]) -> list[Window]:
    """Up to :data:`SAMPLES_PER_SIDE` squared windows of :data:`SAMPLE_SIDE` px spread over the scene."""
    def starts(length: int) -> list[int]:
        side = min(SAMPLE_SIDE, length)
        count = min(SAMPLES_PER_SIDE, max(1, length // side))
        return sorted({int(round(v)) for v in np.linspace(0, length - side, count)})

    rows, cols = shape
    return [
        (r, min(rows, r + SAMPLE_SIDE), c, min(cols, c + SAMPLE_SIDE)) for r in starts(rows) for c in starts(cols)
    ]


def measure_scene_offset(pair: ScenePair) -> RowOffset:
    """The plane of the target's vertical offset, fitted on the matches of windows spread over the scene."""
    points, offsets = [], []
    for window in _sample_windows(pair.shape):
        ref_xy, dy = row_matches(pair.reference.read_float(window), pair.target.read_float(window))
        points.append(ref_xy + (window[2], window[0]))
        offsets.append(dy)
    return fit_row_offset(np.concatenate(points), np.concatenate(offsets), pair.shape, INLIER_PX)


def level_scene_rows(pair: ScenePair) -> ScenePair:
    """The scene pair with its target (and target labels) levelled when the offset calls for it.

    The rule of :func:`radcons.geometry.level_rows`
    (:attr:`radcons.stages.rectify.row_levelling.RowOffset.applied`). What was measured and
    done goes to the pair's metadata (``rows``), and so to the written manifest and the
    summary.
    """
    offset = measure_scene_offset(pair)
    metadata = {**(pair.metadata or {}), "rows": offset.describe()}
    if not offset.applied:
        return replace(pair, metadata=metadata)
    labels = pair.target_objects
    if labels is not None:
        labels = LevelledImage(**asdict(labels), plane=offset.plane, labels=True)
    target = LevelledImage(**asdict(pair.target), plane=offset.plane)
    return replace(pair, target=target, target_objects=labels, metadata=metadata)
