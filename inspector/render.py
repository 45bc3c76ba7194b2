"""Drawing for the inspector: display scaling, overlays, swipe, colour maps, the 3D point cloud.

Everything here turns arrays the library computed into 8-bit pictures; nothing here
computes a result of the method. Images are mapped to 8 bits with *one* range for both
images of a pair, so a brightness difference between them stays visible. Overlays are
drawn with OpenCV into a separate transparent layer (RGBA, sent as PNG), so toggling them
does not resend the images (RGB, sent as JPEG). The object drill-down's pictures are
drawn by :mod:`inspector.plots`.

A rectified pair has no data (NaN) outside each image's footprint in the epipolar frame.
The pictures show only the bounding box of the pixels valid in either image
(:class:`DisplayFrame`), and what is left of that area without data in a flat dim grey
(:data:`NODATA_GREY`, just above the viewer's background), so that it reads as no
picture rather than as black ground.
"""

from __future__ import annotations

import colorsys
from dataclasses import dataclass
from typing import Mapping, Sequence

import cv2
import numpy as np

from radcons.record.colors import LEFT_OUT_RGB

__all__ = [
    "display_range",
    "to_display",
    "downsample_factor",
    "resize_for_display",
    "NODATA_GREY",
    "valid_box",
    "DisplayFrame",
    "display_frame",
    "mark_nodata",
    "outline_thickness",
    "pair_colour",
    "outline_mask",
    "draw_overlay",
    "swipe_composite",
    "colourise",
    "height_range",
    "height_layer",
    "LEFT_OUT_COLOURS",
    "left_out_layer",
    "colour_bar",
    "error_map",
    "point_cloud",
    "CORRECT_RGB",
    "WRONG_RGB",
    "FAILED_RGB",
]

#: Colours of the error map: matched within the threshold, wrong, failed (NaN).
CORRECT_RGB = (46, 204, 113)
WRONG_RGB = (231, 76, 60)
FAILED_RGB = (52, 120, 246)
#: Grey of the pixels without data (the viewer's background is 20).
NODATA_GREY = 34
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


def valid_box(*images: np.ndarray) -> tuple[int, int, int, int]:
    """``(row0, row1, col0, col1)``: the bounding box of the pixels finite in any of ``images``.

    Images may differ in shape (an unrectified pair's do); the whole first image when no
    pixel is finite.
    """
    boxes = []
    for image in images:
        valid = np.isfinite(image)
        rows, cols = np.flatnonzero(valid.any(axis=1)), np.flatnonzero(valid.any(axis=0))
        if rows.size:
            boxes.append((int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1))
    if not boxes:
        return 0, images[0].shape[0], 0, images[0].shape[1]
    corners = np.array(boxes)
    return int(corners[:, 0].min()), int(corners[:, 1].max()), int(corners[:, 2].min()), int(corners[:, 3].max())


@dataclass(frozen=True)
class DisplayFrame:
    """The part of the work-pair images that is displayed, and how much it is shrunk.

    Attributes
    ----------
    box : (int, int, int, int)
        ``(row0, row1, col0, col1)`` of the shown part, work-pair pixels.
    factor : int
        Downsampling factor from that part to the pictures sent.
    """

    box: tuple[int, int, int, int]
    factor: int

    @property
    def shape(self) -> tuple[int, int]:
        """``(height, width)`` of the shown part, work-pair pixels."""
        return self.box[1] - self.box[0], self.box[3] - self.box[2]

    @property
    def origin(self) -> tuple[int, int]:
        """``(x, y)`` work-pair pixel of the shown part's top-left corner."""
        return self.box[2], self.box[0]

    def apply(self, image: np.ndarray, labels: bool = False) -> np.ndarray:
        """Crop a work-pair-sized array to :attr:`box` and shrink it (:func:`resize_for_display`)."""
        row0, row1, col0, col1 = self.box
        return resize_for_display(image[row0:row1, col0:col1], self.factor, labels)


def display_frame(images: Sequence[np.ndarray], max_side: int) -> DisplayFrame:
    """The frame of a pair's pictures: the box of its valid pixels (:func:`valid_box`),
    shrunk by the smallest factor that brings its longest side to ``max_side`` or less."""
    box = valid_box(*images)
    return DisplayFrame(box, downsample_factor((box[1] - box[0], box[3] - box[2]), max_side))


def mark_nodata(picture: np.ndarray, invalid: np.ndarray, grey: int = NODATA_GREY) -> np.ndarray:
    """``picture`` (grey or RGB, uint8) with its ``invalid`` pixels set to a flat ``grey``."""
    out = picture.copy()
    out[invalid] = grey
    return out


def outline_thickness(scale: float, screen_px: float = 1.0) -> int:
    """Picture pixels of a line drawn ``screen_px`` canvas pixels wide (at least 1).

    ``scale`` is picture pixels per canvas pixel: a picture shrunk on screen needs wider
    lines, or the browser's own shrinking thins them to nothing.
    """
    return max(1, int(round(screen_px * scale)))


# ----------------------------------------------------------------------------- overlays


def pair_colour(index: int) -> tuple[int, int, int]:
    """A distinct, saturated RGB colour for the ``index``-th associated object pair."""
    hue = (index * 0.618033988749895) % 1.0
    red, green, blue = colorsys.hsv_to_rgb(hue, 0.75, 1.0)
    return int(red * 255), int(green * 255), int(blue * 255)


def outline_mask(labels: np.ndarray, thickness: int = 1) -> np.ndarray:
    """True on the pixels of an object (label > 0) within ``thickness`` pixels (Chebyshev
    distance) of another label or the background: a border ``thickness`` pixels wide."""
    labels = np.asarray(labels)
    kernel = np.ones((2 * thickness + 1, 2 * thickness + 1), np.uint8)
    as_float = labels.astype(np.float32)
    return (cv2.dilate(as_float, kernel) != cv2.erode(as_float, kernel)) & (labels > 0)


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
    base: np.ndarray | None = None,
    line_px: float = 1.0,
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
    base : ndarray of uint8, shape (H, W, 4), optional
        A layer drawn first, under everything else (e.g. :func:`height_layer`).
    line_px : float
        Width of the outlines and rings on screen, canvas pixels
        (:func:`outline_thickness`).

    Returns
    -------
    ndarray of uint8, shape (H, W, 4)
        Transparent where nothing is drawn.
    """
    height, width = shape
    layer = np.zeros((height, width, 4), np.uint8) if base is None else base.copy()
    thickness = outline_thickness(scale, line_px)
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


def height_range(height: np.ndarray, percentile: float = 99.5) -> tuple[float, float]:
    """Colour range of a height-above-ground map: from the ground (0) to its ``percentile``.

    Below-ground values (noise of the ground surface) take the colour of 0, and the few
    highest pixels the colour of the top, so that one mismatched spike does not flatten
    the colours of every roof. The top is at least one unit above the ground.

    Parameters
    ----------
    height : ndarray
        Height above ground (NaN where unknown).
    percentile : float
        Percentile of the finite heights taken as the top of the range.

    Returns
    -------
    (float, float)
        ``(0, top)`` with ``top >= 1``.
    """
    finite = np.asarray(height, dtype=np.float32)
    finite = finite[np.isfinite(finite)]
    top = float(np.percentile(finite, percentile)) if finite.size else 1.0
    return 0.0, max(top, 1.0)


def height_layer(height: np.ndarray, value_range: tuple[float, float], alpha: int = 255) -> np.ndarray:
    """RGBA layer of a height map: turbo colours over ``value_range``, transparent where NaN.

    Parameters
    ----------
    height : ndarray, shape (H, W)
        Height above ground at display resolution.
    value_range : (float, float)
        Heights mapped to the first and last colour of the map (clipped beyond).
    alpha : int
        Opacity of the pixels with a height.

    Returns
    -------
    ndarray of uint8, shape (H, W, 4)
    """
    layer = np.zeros((*height.shape, 4), np.uint8)
    layer[..., :3] = colourise(height, value_range)
    layer[..., 3] = np.where(np.isfinite(height), np.uint8(alpha), np.uint8(0))
    return layer


#: Rule code of :data:`radcons.stages.objects.rules.LEFT_OUT_RULES` -> (RGB, the square
#: that shows that colour in the legend); the colours are the recordings'.
LEFT_OUT_COLOURS: dict[int, tuple[tuple[int, int, int], str]] = {
    code: (rgb, square) for (code, rgb), square in zip(LEFT_OUT_RGB.items(), ("🟩", "🟨", "🟧", "🟪", "🟦", "🟫", "⬜", "⬛"), strict=True)
}


def left_out_layer(codes: np.ndarray, base: np.ndarray | None = None, fill: int = 80) -> np.ndarray:
    """RGBA layer of the regions the height method left out: each in its rule's colour.

    Parameters
    ----------
    codes : ndarray of int, shape (H, W)
        Rule codes at display resolution (:attr:`radcons.stages.objects.regions.
        HeightObjects.left_out`; 0: not left out).
    base : ndarray of uint8, shape (H, W, 4), optional
        A layer to draw over (e.g. :func:`height_layer`).
    fill : int
        Opacity of the regions' inside; their outline is opaque.

    Returns
    -------
    ndarray of uint8, shape (H, W, 4)
    """
    layer = np.zeros((*codes.shape, 4), np.uint8) if base is None else base.copy()
    edges = outline_mask(codes)
    for code, (colour, _) in LEFT_OUT_COLOURS.items():
        inside = codes == code
        layer[inside] = (*colour, fill)
        layer[inside & edges] = (*colour, 255)
    return layer


def colour_bar(width: int = 256, height: int = 14, colormap: int = cv2.COLORMAP_TURBO) -> np.ndarray:
    """A horizontal colour bar of ``colormap``, low on the left (RGB, uint8)."""
    ramp = np.tile(np.linspace(0, 255, width).round().astype(np.uint8), (height, 1))
    return cv2.cvtColor(cv2.applyColorMap(ramp, colormap), cv2.COLOR_BGR2RGB)


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
