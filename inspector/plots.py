"""Pictures of the object drill-down: crops with outlines, grey-value histograms, the fit plot.

Like :mod:`inspector.render`, everything here only draws arrays the library computed
(dark panels, RGB, made with OpenCV).
"""

from __future__ import annotations

from typing import Sequence

import cv2
import numpy as np

from inspector.render import to_display

__all__ = ["side_by_side", "crop_box", "crop_with_outline", "histogram_plot", "fit_plot"]

_REFERENCE_RGB = (86, 180, 233)
_TARGET_RGB = (240, 160, 40)
_PANEL_RGB = (28, 30, 36)
_AXIS_RGB = (150, 150, 160)
_TEXT_RGB = (225, 225, 230)
_FONT = cv2.FONT_HERSHEY_SIMPLEX


def side_by_side(left: np.ndarray, right: np.ndarray, gap: int = 6) -> np.ndarray:
    """Place two RGB images next to each other on the panel background."""
    height = max(left.shape[0], right.shape[0])
    out = np.empty((height, left.shape[1] + gap + right.shape[1], 3), np.uint8)
    out[:] = _PANEL_RGB
    out[: left.shape[0], : left.shape[1]] = left
    out[: right.shape[0], left.shape[1] + gap :] = right
    return out


def crop_box(mask: np.ndarray, margin: float = 0.25, min_side: int = 24) -> tuple[slice, slice]:
    """Bounding box of ``mask`` grown by ``margin`` of its size (at least ``min_side`` px)."""
    rows, cols = np.nonzero(mask)
    if rows.size == 0:
        return slice(0, mask.shape[0]), slice(0, mask.shape[1])
    boxes = []
    for low, high, limit in ((rows.min(), rows.max() + 1, mask.shape[0]), (cols.min(), cols.max() + 1, mask.shape[1])):
        grow = max(int((high - low) * margin), (min_side - (high - low)) // 2, 2)
        boxes.append(slice(max(0, low - grow), min(limit, high + grow)))
    return boxes[0], boxes[1]


def crop_with_outline(
    image: np.ndarray,
    mask: np.ndarray,
    value_range: tuple[float, float],
    colour: tuple[int, int, int],
    box: tuple[slice, slice],
    size: int = 220,
) -> np.ndarray:
    """Crop ``box`` from ``image``, scale it to ``size`` px (longest side), outline ``mask``."""
    grey = to_display(image[box], value_range)
    rgb = np.repeat(grey[:, :, None], 3, axis=2)
    zoom = size / max(grey.shape)
    new_size = (max(1, int(round(grey.shape[1] * zoom))), max(1, int(round(grey.shape[0] * zoom))))
    rgb = cv2.resize(rgb, new_size, interpolation=cv2.INTER_NEAREST if zoom >= 1 else cv2.INTER_AREA)
    inside = cv2.resize(mask[box].astype(np.uint8), new_size, interpolation=cv2.INTER_NEAREST)
    contours, _ = cv2.findContours(inside, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    cv2.drawContours(rgb, contours, -1, colour, 2, cv2.LINE_AA)
    return rgb


def _plot_frame(size: tuple[int, int], title: str) -> tuple[np.ndarray, tuple[int, int, int, int]]:
    """A dark canvas with a title; returns it and the plot area ``(x0, y0, x1, y1)``."""
    width, height = size
    canvas = np.empty((height, width, 3), np.uint8)
    canvas[:] = _PANEL_RGB
    cv2.putText(canvas, title, (10, 20), _FONT, 0.5, _TEXT_RGB, 1, cv2.LINE_AA)
    area = (44, 32, width - 12, height - 28)
    cv2.rectangle(canvas, area[:2], area[2:], _AXIS_RGB, 1)
    return canvas, area


def _tick_label(value: float) -> str:
    return f"{value:.0f}" if abs(value) >= 100 else f"{value:.3g}"


def histogram_plot(
    series: Sequence[tuple[str, np.ndarray, tuple[int, int, int]]],
    value_range: tuple[float, float],
    title: str,
    bins: int = 64,
    size: tuple[int, int] = (440, 200),
) -> np.ndarray:
    """Draw normalised grey-value histograms of several pixel sets as lines (RGB image).

    Parameters
    ----------
    series : sequence of (label, values, rgb)
        Pixel values (NaN ignored) and how to draw them; a label ending in ``"(before)"``
        is drawn thin.
    value_range : (float, float)
        Range of the horizontal axis (use the pair's display range).
    title : str
    bins : int
    size : (int, int)
        ``(width, height)`` of the picture.
    """
    canvas, (x0, y0, x1, y1) = _plot_frame(size, title)
    low, high = value_range
    edges = np.linspace(low, high, bins + 1)
    counts = []
    for _, values, _ in series:
        values = np.asarray(values, dtype=np.float64).ravel()
        values = values[np.isfinite(values)]
        hist = np.histogram(np.clip(values, low, high), edges)[0].astype(np.float64)
        counts.append(hist / max(hist.sum(), 1.0))
    peak = max((c.max() for c in counts), default=1.0) or 1.0
    xs = np.linspace(x0, x1, bins)
    for (label, _, colour), hist in zip(series, counts):
        ys = y1 - hist / peak * (y1 - y0 - 4)
        points = np.stack([xs, ys], axis=1).round().astype(np.int32)
        thin = label.endswith("(before)")
        cv2.polylines(canvas, [points], False, tuple(int(c * (0.6 if thin else 1.0)) for c in colour), 1 if thin else 2, cv2.LINE_AA)
    for k, (label, _, colour) in enumerate(series):
        cv2.putText(canvas, label, (x1 - 150, y0 + 16 + 15 * k), _FONT, 0.4, colour, 1, cv2.LINE_AA)
    cv2.putText(canvas, _tick_label(low), (x0 - 4, y1 + 16), _FONT, 0.4, _AXIS_RGB, 1, cv2.LINE_AA)
    label = _tick_label(high)
    cv2.putText(canvas, label, (x1 - 8 * len(label), y1 + 16), _FONT, 0.4, _AXIS_RGB, 1, cv2.LINE_AA)
    return canvas


def fit_plot(
    x: np.ndarray,
    y: np.ndarray,
    weights: np.ndarray | None,
    gain: float,
    offset: float,
    title: str,
    size: tuple[int, int] = (440, 260),
) -> np.ndarray:
    """Scatter the invariant points (target grey x, reference grey y) with the fitted line.

    Points are shaded by their weight (eq 11); the fitted line ``y = gain x + offset``
    (eq 8) is solid, the identity line dashed.
    """
    canvas, (x0, y0, x1, y1) = _plot_frame(size, title)
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    finite = np.isfinite(x) & np.isfinite(y)
    if not finite.any():
        cv2.putText(canvas, "no invariant points", (x0 + 10, (y0 + y1) // 2), _FONT, 0.5, _TEXT_RGB, 1, cv2.LINE_AA)
        return canvas
    values = np.concatenate([x[finite], y[finite]])
    low, high = float(values.min()), float(values.max())
    pad = max((high - low) * 0.08, 1e-3)
    low, high = low - pad, high + pad

    def to_px(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        px = x0 + (u - low) / (high - low) * (x1 - x0)
        py = y1 - (v - low) / (high - low) * (y1 - y0)
        return np.stack([px, py], axis=-1)

    line = np.array([low, high])
    dashes = to_px(np.linspace(low, high, 41), np.linspace(low, high, 41)).astype(np.int32)
    for start in range(0, 40, 2):
        cv2.line(canvas, tuple(dashes[start]), tuple(dashes[start + 1]), _AXIS_RGB, 1, cv2.LINE_AA)
    if np.isfinite(gain) and np.isfinite(offset):
        ends = to_px(line, gain * line + offset)
        clipped = cv2.clipLine((x0, y0, x1 - x0, y1 - y0), tuple(np.round(ends[0]).astype(int)), tuple(np.round(ends[1]).astype(int)))
        if clipped[0]:
            cv2.line(canvas, clipped[1], clipped[2], _TARGET_RGB, 2, cv2.LINE_AA)
    w = np.ones_like(x) if weights is None or np.size(weights) != x.size else np.asarray(weights, dtype=np.float64)
    w = np.clip(w / (np.nanmax(w) if np.nanmax(w) > 0 else 1.0), 0.15, 1.0)
    for (px, py), weight in zip(to_px(x[finite], y[finite]), w[finite]):
        colour = tuple(int(c * weight) for c in _REFERENCE_RGB)
        cv2.circle(canvas, (int(round(px)), int(round(py))), 3, colour, -1, cv2.LINE_AA)
    cv2.putText(canvas, "target grey", ((x0 + x1) // 2 - 40, y1 + 20), _FONT, 0.4, _AXIS_RGB, 1, cv2.LINE_AA)
    cv2.putText(canvas, _tick_label(low), (x0, y1 + 14), _FONT, 0.35, _AXIS_RGB, 1, cv2.LINE_AA)
    cv2.putText(canvas, _tick_label(high), (x1 - 30, y1 + 14), _FONT, 0.35, _AXIS_RGB, 1, cv2.LINE_AA)
    cv2.putText(canvas, "ref", (6, (y0 + y1) // 2), _FONT, 0.4, _AXIS_RGB, 1, cv2.LINE_AA)
    cv2.putText(canvas, f"y = {gain:.3g} x + {offset:.3g}", (x0 + 8, y0 + 16), _FONT, 0.45, _TARGET_RGB, 1, cv2.LINE_AA)
    return canvas
