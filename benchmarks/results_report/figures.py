"""The report's figures: per-object bar charts and dense-matching error maps (the paper's
Figure 5), drawn with OpenCV."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
from scipy import ndimage

from radcons.evaluate.compare import Comparison

from .common import COLOURS, COMPARED, Entry
from .tables import best_baseline, fmt


def _text(
    canvas: np.ndarray, text: str, xy: tuple[int, int], scale: float = 0.5, colour: tuple[int, int, int] = (0, 0, 0)
) -> None:
    """Write ``text`` on ``canvas`` in place, its baseline starting at ``xy``.

    Parameters
    ----------
    canvas : numpy.ndarray
        BGR uint8 image.
    text : str
        The text.
    xy : tuple of int
        Bottom-left corner (x, y) of the text.
    scale : float
        Font scale.
    colour : tuple of int
        BGR colour.
    """
    cv2.putText(canvas, text, xy, cv2.FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv2.LINE_AA)


def bar_chart(comparison: Comparison, methods: list[str], title: str) -> np.ndarray:
    """Per-object bars of eq 20 similarity (top) and correct-matching rate (bottom).

    Parameters
    ----------
    comparison : Comparison
        Every method's measures on one pair.
    methods : list of str
        The methods drawn, one bar each per object, in this order.
    title : str
        The chart's title.

    Returns
    -------
    numpy.ndarray
        BGR uint8 image; the last group of bars is the mean over the objects.
    """
    ids = [ref_id for ref_id, _ in comparison.object_pairs]
    results = [comparison.method(m) for m in methods]
    groups = [str(i) for i in ids] + ["mean"]
    bar, gap, left, right = 7, 14, 60, 20
    group_width = bar * len(methods) + gap
    width = max(900, left + right + group_width * len(groups) + gap)
    panel, top_margin, legend = 300, 50, 60
    height = legend + 2 * (panel + top_margin) + 20
    canvas = np.full((height, width, 3), 255, np.uint8)
    _text(canvas, title, (left, 24), 0.65)
    x = left
    for name in methods:
        cv2.rectangle(canvas, (x, 38), (x + 14, 50), COLOURS[name], -1)
        _text(canvas, name, (x + 18, 50), 0.45)
        x += 36 + cv2.getTextSize(name, cv2.FONT_HERSHEY_SIMPLEX, 0.45, 1)[0][0]
    panels = [
        ("object similarity C (eq 20)", [list(r.similarity.get(i, np.nan) for i in ids) + [r.mean_similarity] for r in results]),
        ("correct-matching rate (|d - d_gt| < 1 px)", [list(r.object_rates.get(i, np.nan) for i in ids) + [r.mean_object_rate] for r in results]),
    ]
    for index, (label, values) in enumerate(panels):
        y0 = legend + index * (panel + top_margin) + top_margin
        _text(canvas, label, (left, y0 - 12), 0.5)
        for tick in np.linspace(0, 1, 6):
            y = int(round(y0 + panel * (1 - tick)))
            cv2.line(canvas, (left, y), (width - right, y), (225, 225, 225), 1)
            _text(canvas, f"{tick:.1f}", (left - 34, y + 4), 0.4)
        for g, group in enumerate(groups):
            gx = left + gap + g * group_width
            for m, name in enumerate(methods):
                value = values[m][g]
                if not math.isfinite(value):
                    continue
                bx = gx + m * bar
                cv2.rectangle(canvas, (bx, int(round(y0 + panel * (1 - value)))), (bx + bar - 2, y0 + panel), COLOURS[name], -1)
            _text(canvas, group, (gx + 2, y0 + panel + 16), 0.4)
            if all(not math.isfinite(values[m][g]) or values[m][g] < 0.005 for m in range(len(methods))):
                _text(canvas, "all 0", (gx + 2, y0 + panel - 6), 0.35, (120, 120, 120))
        cv2.line(canvas, (left, y0 + panel), (width - right, y0 + panel), (0, 0, 0), 1)
    return canvas


def error_map(disparity: np.ndarray, truth: np.ndarray, labels: np.ndarray | None) -> np.ndarray:
    """Figure 5 colours: green where |d - d_gt| < 1 px, blue where wrong or failed, grey
    where there is no ground truth; object outlines in white.

    Parameters
    ----------
    disparity : numpy.ndarray
        A method's dense disparity, NaN where matching failed.
    truth : numpy.ndarray
        The ground-truth disparity, NaN where unknown.
    labels : numpy.ndarray or None
        Reference objects (0 = background) to outline, or None.

    Returns
    -------
    numpy.ndarray
        BGR uint8 image of the disparity's shape.
    """
    known = np.isfinite(truth)
    with np.errstate(invalid="ignore"):
        correct = known & (np.abs(disparity - truth) < 1.0)
    out = np.full(truth.shape + (3,), 40, np.uint8)
    out[known] = (200, 60, 0)
    out[correct] = (0, 180, 0)
    if labels is not None:
        edges = (labels > 0) & (ndimage.grey_dilation(labels, 3) != ndimage.grey_erosion(labels, 3))
        out[edges] = (255, 255, 255)
    return out


def error_maps(entry: Entry, methods: list[str]) -> np.ndarray:
    """The reference image, then the error map of each method, side by side, titled.

    Parameters
    ----------
    entry : Entry
        The evaluated pair.
    methods : list of str
        The methods whose error maps follow the reference, in this order.

    Returns
    -------
    numpy.ndarray
        BGR uint8 image.
    """
    pair, comparison = entry.pair, entry.comparison
    reference = pair.reference.as_float32()
    low, high = np.nanpercentile(reference, [0.5, 99.5])
    grey = np.clip((np.nan_to_num(reference, nan=low) - low) / (high - low) * 255, 0, 255).astype(np.uint8)
    panels = [(f"{entry.title}: reference", cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR))]
    for name in methods:
        result = comparison.method(name)
        title = f"{name}: {fmt(result.correct_rate)} all, {fmt(result.mean_object_rate)} objects"
        panels.append((title, error_map(result.disparity, pair.disparity, pair.reference_objects)))
    height, width = pair.shape
    header, gap = 28, 8
    canvas = np.full((height + header, len(panels) * (width + gap) - gap, 3), 255, np.uint8)
    for index, (title, image) in enumerate(panels):
        x = index * (width + gap)
        canvas[header:, x : x + width] = image
        _text(canvas, title, (x + 4, 19), 0.5)
    return canvas


def draw_plots(entries: list[Entry], img_dir: Path) -> list[tuple[str, str, str]]:
    """Write the bar chart, then the error maps, of each entry into ``img_dir``.

    Parameters
    ----------
    entries : list of Entry
        The pairs drawn, in order.
    img_dir : Path
        The report's image folder (``img/`` beside ``results.md``), existing.

    Returns
    -------
    list of (str, str, str)
        Per figure, in order: title, caption and path relative to the report.
    """
    plots = []
    for entry in entries:
        name = f"bars_{entry.key}.png"
        cv2.imwrite(str(img_dir / name), bar_chart(entry.comparison, list(COMPARED), f"{entry.title}: per object"))
        plots.append((
            f"Per object, {entry.title}",
            "Eq 20 similarity (top) and correct-matching rate (bottom) of each object, one bar per method; "
            "the last group is the mean over the objects.",
            f"img/{name}",
        ))
    for entry in entries:
        best = best_baseline(entry.comparison, "rate")[0]
        name = f"errors_{entry.key}.png"
        cv2.imwrite(str(img_dir / name), error_maps(entry, ["original", best, "ours"]))
        plots.append((
            f"Dense matching errors, {entry.title}",
            "As the paper's Figure 5: green correct (< 1 px), blue wrong or failed, dark grey no ground truth; "
            f"white lines outline the objects. Panels: the reference image, original, the best baseline by "
            f"the all-pixel rate ({best}), ours.",
            f"img/{name}",
        ))
    return plots
