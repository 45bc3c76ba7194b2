"""The refine stage's local light correction in scene mode (:mod:`radcons.stages.refine.light`).

The tiles' moments lines need the mean and standard deviation of each image over each
tile's window, which are sums: every row block of the scene adds its pixels' count, sum
and sum of squares to the windows it meets (:func:`block_tile_moments`), the reference
times its eq 5 lambda, the target through the background's grey-value mapping, as the
stage sees them in memory. The correction's spread (:func:`radcons.stages.refine.light.
light_spread`) is a second pass of sums over the target (:func:`block_moved_moments`),
against the reference's 1..99 percentile range from its grey-value counts. Pass 2 applies
the blended field to each window (:meth:`radcons.stages.refine.light.LightField.apply`).
"""

from __future__ import annotations

import math

import numpy as np

from radcons.scene.source import SceneImage, Window
from radcons.scene.stats import ImageStats, percentile_of_counts
from radcons.stages.refine.light import LightField, tile_line, tile_windows

__all__ = [
    "mapped_background", "stage_values", "block_tile_moments", "block_moved_moments", "scene_light", "scene_spread",
]

#: Moments of the valid pixels: count, sum, sum of squares.
_MOMENTS = 3


def mapped_background(
    raw: np.ndarray, lut: tuple[np.ndarray, np.ndarray], light: LightField | None = None, origin: tuple[int, int] = (0, 0)
) -> np.ndarray:
    """A window of the target outside the objects as the refine stage maps it: its grey
    values as read through the background's mapping ``lut`` (``np.interp``; float32, NaN
    kept), then ``light``'s correction for the window's place ``origin`` (row, column)."""
    out = np.full(raw.shape, np.nan, np.float32)
    valid = np.isfinite(raw)
    out[valid] = np.interp(raw[valid], *lut)
    return out if light is None else light.apply(out, origin)


def stage_values(values: np.ndarray, scale: float, lut: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
    """An image's values as the refine stage sees them: times ``scale`` (eq 5's lambda), or
    through the background's mapping ``lut`` when given (:func:`mapped_background`)."""
    return values * np.float32(scale) if lut is None else mapped_background(values, lut)


def block_tile_moments(
    window: Window, image: SceneImage, tiles: int, scale: float, lut: tuple[np.ndarray, np.ndarray] | None
) -> np.ndarray:
    """``(tiles, tiles, 3)`` count, sum and sum of squares of one row block's valid values
    (:func:`stage_values`) inside each tile's window of the scene."""
    r0, r1, c0, _ = window
    values = stage_values(image.read_float(window), scale, lut)
    moments = np.zeros((tiles, tiles, _MOMENTS))
    for i, j, y0, y1, x0, x1 in tile_windows(image.shape, tiles):
        top, bottom = max(y0, r0), min(y1, r1)
        if top >= bottom:
            continue
        part = values[top - r0:bottom - r0, x0 - c0:x1 - c0]
        part = part[np.isfinite(part)].astype(np.float64)
        moments[i, j] = part.size, part.sum(), np.dot(part, part)
    return moments


def block_moved_moments(
    window: Window, image: SceneImage, lut: tuple[np.ndarray, np.ndarray] | None, scale: float, field: LightField
) -> np.ndarray:
    """Count, sum and sum of squares of how much ``field`` moves one row block of the target."""
    mapped = stage_values(image.read_float(window), scale, lut)
    moved = field.apply(mapped, (window[0], window[2])) - mapped
    moved = moved[np.isfinite(moved)].astype(np.float64)
    return np.array([moved.size, moved.sum(), np.dot(moved, moved)])


def _mean_std(moments: np.ndarray) -> tuple[int, float, float]:
    count, total, squares = moments
    if count == 0:
        return 0, math.nan, math.nan
    mean = total / count
    return int(count), mean, math.sqrt(max(squares / count - mean * mean, 0.0))


def scene_light(
    reference: np.ndarray, target: np.ndarray, tiles: int, shape: tuple[int, int]
) -> LightField:
    """The tiles' lines from the merged ``(tiles, tiles, 3)`` moments of the reference and the
    target over a scene of ``shape``."""
    gains, offsets = np.ones((tiles, tiles)), np.zeros((tiles, tiles))
    for i in range(tiles):
        for j in range(tiles):
            gains[i, j], offsets[i, j] = tile_line(_mean_std(reference[i, j]), _mean_std(target[i, j]))
    return LightField(gains, offsets, shape)


def scene_spread(moved: np.ndarray, reference: ImageStats, scale: float) -> float:
    """:func:`radcons.stages.refine.light.light_spread` from the summed moments of the
    target's moves and the reference's grey-value counts (its values times ``scale``)."""
    count, _, std = _mean_std(moved)
    low, high = (percentile_of_counts(reference.grid, reference.counts, q) * scale for q in (1, 99))
    return std / (high - low) if count and high > low else 0.0
