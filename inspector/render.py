"""Drawing for the inspector: display scaling, overlays, histograms, plots, colour maps.

Everything here turns arrays the library computed into 8-bit pictures; nothing here
computes a result of the method. Images are mapped to 8 bits with *one* range for both
images of a pair, so a brightness difference between them stays visible. Overlays are
drawn with OpenCV into a separate transparent layer (RGBA, sent as PNG), so toggling them
does not resend the images (RGB, sent as JPEG).
"""

from __future__ import annotations

import colorsys
from typing import Mapping, Sequence

import cv2
import numpy as np

__all__ = [
    "display_range",
    "to_display",
    "downsample_factor",
    "resize_for_display",
    "pair_colour",
    "outline_mask",
    "draw_overlay",
    "swipe_composite",
    "colourise",
    "error_map",
    "crop_box",
    "crop_with_outline",
    "histogram_plot",
    "fit_plot",
    "point_cloud",
    "side_by_side",
    "CORRECT_RGB",
    "WRONG_RGB",
    "FAILED_RGB",
]

#: Colours of the error map: matched within the threshold, wrong, failed (NaN).
CORRECT_RGB = (46, 204, 113)
WRONG_RGB = (231, 76, 60)
FAILED_RGB = (52, 120, 246)
_REFERENCE_RGB = (86, 180, 233)
_TARGET_RGB = (240, 160, 40)
_PANEL_RGB = (28, 30, 36)
_AXIS_RGB = (150, 150, 160)
_TEXT_RGB = (225, 225, 230)
_FONT = cv2.FONT_HERSHEY_SIMPLEX


# ----------------------------------------------------------------------------- scaling


def display_range(*images: np.ndarray, percentiles: tuple[float, float] = (0.5, 99.5), sample: int = 262_144) -> tuple[float, float]:
    """Return one grey-value range for all ``images`` (robust percentiles of their union).

    Parameters
    ----------
    *images : ndarray
        Images on any value range, NaN where invalid.
    percentiles : (float, float)
        Lower and upper percentile of the finite values of all images together.
    sample : int
        At most about this many pixels per image are read (a regular subsample).

    Returns
    -------
    (float, float)
        ``(low, high)`` with ``high > low``; ``(0, 1)`` when no pixel is finite.
    """
    values = []
    for image in images:
        step = max(1, int(np.sqrt(image.size / sample)))
        part = np.asarray(image[::step, ::step], dtype=np.float32).ravel()
        values.append(part[np.isfinite(part)])
    finite = np.concatenate(values) if values else np.zeros(0, np.float32)
    if finite.size == 0:
        return 0.0, 1.0
    low, high = (float(v) for v in np.percentile(finite, percentiles))
    if not high > low:
        low, high = float(finite.min()), float(finite.max())
    if not high > low:
        high = low + 1.0
    return low, high


def to_display(image: np.ndarray, value_range: tuple[float, float]) -> np.ndarray:
    """Map an image linearly from ``value_range`` onto 0..255 (uint8; NaN becomes 0)."""
    low, high = value_range
    scale = 255.0 / (high - low)
    scaled = (np.asarray(image, dtype=np.float32) - np.float32(low)) * np.float32(scale)
    scaled = np.nan_to_num(scaled, nan=0.0, posinf=255.0, neginf=0.0)
    return np.clip(scaled + 0.5, 0, 255).astype(np.uint8)


def downsample_factor(shape: Sequence[int], max_side: int) -> int:
    """Smallest integer factor that brings the longest side of ``shape`` to ``max_side`` or less."""
    return max(1, int(np.ceil(max(shape[:2]) / max_side)))


def resize_for_display(image: np.ndarray, factor: int, labels: bool = False) -> np.ndarray:
    """Shrink an array by an integer ``factor`` (area average, or nearest for labels)."""
    if factor == 1:
        return image
    height, width = image.shape[:2]
    size = (max(1, width // factor), max(1, height // factor))
    if labels or image.dtype == bool:
        return image[: size[1] * factor : factor, : size[0] * factor : factor]
    return cv2.resize(image, size, interpolation=cv2.INTER_AREA)


def side_by_side(left: np.ndarray, right: np.ndarray, gap: int = 6) -> np.ndarray:
    """Place two RGB images next to each other on the panel background."""
    height = max(left.shape[0], right.shape[0])
    out = np.empty((height, left.shape[1] + gap + right.shape[1], 3), np.uint8)
    out[:] = _PANEL_RGB
    out[: left.shape[0], : left.shape[1]] = left
    out[: right.shape[0], left.shape[1] + gap :] = right
    return out


# ----------------------------------------------------------------------------- overlays


def pair_colour(index: int) -> tuple[int, int, int]:
    """A distinct, saturated RGB colour for the ``index``-th associated object pair."""
    hue = (index * 0.618033988749895) % 1.0
    red, green, blue = colorsys.hsv_to_rgb(hue, 0.75, 1.0)
    return int(red * 255), int(green * 255), int(blue * 255)


def outline_mask(labels: np.ndarray, thickness: int = 1) -> np.ndarray:
    """True on the pixels where an object (label > 0) meets another label or the background."""
    labels = np.asarray(labels)
    kernel = np.ones((3, 3), np.uint8)
    as_float = labels.astype(np.float32)
    dilated = cv2.dilate(as_float, kernel)
    eroded = cv2.erode(as_float, kernel)
    edge = (dilated != eroded) & (labels > 0)
    if thickness > 1:
        edge = cv2.dilate(edge.astype(np.uint8), np.ones((thickness, thickness), np.uint8)) > 0
        edge &= labels > 0
    return edge


def _label_positions(labels: np.ndarray) -> dict[int, tuple[int, int]]:
    """Return ``id -> (x, y)``: a pixel well inside each object (its distance-transform peak)."""
    import scipy.ndimage

    positions: dict[int, tuple[int, int]] = {}
    for index, box in enumerate(scipy.ndimage.find_objects(labels)):
        if box is None:
            continue
        object_id = index + 1
        mask = (labels[box] == object_id).astype(np.uint8)
        distance = cv2.distanceTransform(np.pad(mask, 1), cv2.DIST_L2, 3)[1:-1, 1:-1]
        row, col = np.unravel_index(int(np.argmax(distance)), distance.shape)
        positions[object_id] = (int(box[1].start + col), int(box[0].start + row))
    return positions


def _put_label(canvas: np.ndarray, text: str, xy: tuple[int, int], colour: Sequence[int], scale: float) -> None:
    thickness = max(1, int(round(scale * 2)))
    (width, height), _ = cv2.getTextSize(text, _FONT, scale, thickness)
    x = int(np.clip(xy[0] - width // 2, 0, max(0, canvas.shape[1] - width)))
    y = int(np.clip(xy[1] + height // 2, height, canvas.shape[0] - 1))
    cv2.putText(canvas, text, (x, y), _FONT, scale, (0, 0, 0, 255), thickness + 2, cv2.LINE_AA)
    cv2.putText(canvas, text, (x, y), _FONT, scale, (*colour, 255), thickness, cv2.LINE_AA)


def draw_overlay(
    shape: tuple[int, int],
    *,
    labels: np.ndarray | None = None,
    outlines: bool = True,
    colours: Mapping[int, tuple[int, int, int]] | None = None,
    names: Mapping[int, str] | None = None,
    selected: int | None = None,
    points: np.ndarray | None = None,
    invariant: np.ndarray | None = None,
    change: np.ndarray | None = None,
    scale: float = 1.0,
) -> np.ndarray:
    """Draw the overlay layer of one image: outlines, ids, points and the change mask.

    Parameters
    ----------
    shape : (int, int)
        ``(height, width)`` of the displayed image.
    labels : ndarray of int, optional
        Object labels at display resolution (for outlines, ids and the selection).
    outlines : bool
        Draw the object outlines.
    colours : mapping, optional
        ``label -> RGB`` of the objects that belong to an associated pair (the same colour
        in both images); other objects are outlined in grey.
    names : mapping, optional
        ``label -> text`` written inside the objects; None writes every object's own id,
        an empty mapping none.
    selected : int, optional
        Label outlined thickly in white.
    points : ndarray, shape (N, 2), optional
        Feature matches ``(x, y)`` in display pixels (small yellow rings).
    invariant : ndarray, shape (M, 2), optional
        Invariant points ``(x, y)`` in display pixels (filled green dots).
    change : ndarray of bool, optional
        Change mask at display resolution (translucent red).
    scale : float
        Image pixels per screen pixel: lines, dots and text grow with it.

    Returns
    -------
    ndarray of uint8, shape (H, W, 4)
        Transparent where nothing is drawn.
    """
    height, width = shape
    layer = np.zeros((height, width, 4), np.uint8)
    thickness = max(1, int(round(scale)))
    if change is not None and change.any():
        layer[change] = (235, 64, 52, 90)
    if labels is not None:
        colours = colours or {}
        if outlines:
            edges = outline_mask(labels, thickness)
            palette = np.zeros((int(labels.max()) + 1, 4), np.uint8)
            palette[1:] = (190, 190, 190, 170)
            for object_id, colour in colours.items():
                if 0 < object_id < palette.shape[0]:
                    palette[object_id] = (*colour, 255)
            layer[edges] = palette[labels[edges]]
        if selected is not None and selected > 0 and (labels == selected).any():
            ring = outline_mask(np.where(labels == selected, selected, 0), thickness + 2)
            layer[ring] = (255, 255, 255, 255)
        if names is None or names:
            for object_id, xy in _label_positions(labels).items():
                text = str(object_id) if names is None else names.get(object_id)
                if text is not None:
                    _put_label(layer, text, xy, colours.get(object_id, (210, 210, 210)), 0.5 * scale)
    radius = max(2, int(round(3 * scale)))
    if points is not None:
        for x, y in np.asarray(points, dtype=np.float64):
            cv2.circle(layer, (int(round(x)), int(round(y))), radius, (255, 230, 0, 230), thickness, cv2.LINE_AA)
    if invariant is not None:
        for x, y in np.asarray(invariant, dtype=np.float64):
            cv2.circle(layer, (int(round(x)), int(round(y))), radius, (40, 255, 120, 255), -1, cv2.LINE_AA)
    return layer


def swipe_composite(reference: np.ndarray, target: np.ndarray, position: float, line: bool = True) -> np.ndarray:
    """Reference left of ``position`` (0..1 of the width), target right of it, a white
    line between (grey, RGB or RGBA images)."""
    width = reference.shape[1]
    split = int(round(np.clip(position, 0.0, 1.0) * width))
    out = target.copy()
    out[:, :split] = reference[:, :split]
    if line:
        half = max(1, width // 400)
        out[:, max(0, split - half) : min(width, split + half)] = 255
    return out


# ----------------------------------------------------------------------------- maps


def colourise(values: np.ndarray, value_range: tuple[float, float], colormap: int = cv2.COLORMAP_TURBO) -> np.ndarray:
    """Colour-map a float array (disparity, say) over ``value_range``; NaN is black (RGB)."""
    scaled = to_display(values, value_range)
    rgb = cv2.cvtColor(cv2.applyColorMap(scaled, colormap), cv2.COLOR_BGR2RGB)
    rgb[~np.isfinite(values)] = 0
    return rgb


def error_map(disparity: np.ndarray, truth: np.ndarray, threshold: float = 1.0) -> np.ndarray:
    """Colour each pixel with known truth: correct (green), wrong (red), failed (blue).

    Pixels without ground truth are black. ``|d - d_gt| < threshold`` is correct, as in
    :func:`radcons.evaluate.rates.correct_matching_rate`.
    """
    out = np.zeros((*truth.shape, 3), np.uint8)
    known = np.isfinite(truth)
    failed = known & ~np.isfinite(disparity)
    with np.errstate(invalid="ignore"):
        correct = known & (np.abs(disparity - truth) < threshold)
    out[known] = WRONG_RGB
    out[correct] = CORRECT_RGB
    out[failed] = FAILED_RGB
    return out


# ----------------------------------------------------------------------------- objects


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


# ----------------------------------------------------------------------------- 3D


def point_cloud(
    disparity: np.ndarray,
    colours: np.ndarray,
    *,
    max_points: int = 200_000,
    height_scale: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Points ``(x, y, z)`` of the scene from a disparity map, coloured by an image.

    The image spans ``[-w/2, w/2] x [-h/2, h/2]`` with its longest side 1 unit (x right,
    y down, as in the image); ``z`` is the disparity relative to its median (larger
    disparity, closer to the cameras: higher), in the same unit as a pixel, times
    ``height_scale``. Pixels without disparity are left out.

    Parameters
    ----------
    disparity : ndarray, shape (H, W)
    colours : ndarray of uint8, shape (H, W) or (H, W, 3)
    max_points : int
        The map is subsampled on a regular grid to about this many points.
    height_scale : float
        Vertical exaggeration.

    Returns
    -------
    points : ndarray of float32, shape (N, 3)
    rgb : ndarray of uint8, shape (N, 3)
    """
    height, width = disparity.shape
    step = max(1, int(np.ceil(np.sqrt(height * width / max_points))))
    rows, cols = np.mgrid[0:height:step, 0:width:step]
    values = disparity[rows, cols]
    keep = np.isfinite(values)
    rows, cols, values = rows[keep], cols[keep], values[keep]
    unit = 1.0 / max(height, width)
    centre = float(np.median(values)) if values.size else 0.0
    points = np.stack(
        [(cols - width / 2) * unit, (rows - height / 2) * unit, (values - centre) * unit * height_scale], axis=1
    ).astype(np.float32)
    picked = colours[rows, cols]
    rgb = np.repeat(picked[:, None], 3, axis=1) if picked.ndim == 1 else picked[:, :3]
    return points, rgb.astype(np.uint8)
