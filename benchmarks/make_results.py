"""Regenerate the results report: ``docs/results.md``, ``docs/results.json`` and ``docs/img/``.

One command runs every evaluation of the report and writes it; no number in the report is
typed by hand. What it runs:

* synthetic pairs of :mod:`demo_data_gen` (scenarios ``multi-temporal``, ``multi-sensor``,
  ``mixed``; several seeds) with their exact ground truth, every method of
  :data:`COMPARED`, and the per-stage ablation on ``mixed``;
* real stereo pairs with real ground truth (Middlebury Cones from the shared data folder,
  Middlebury Motorcycle from scikit-image) whose target gets the simulated date / sensor
  difference of ``benchmarks/bench_baselines.py``;
* the real, epipolar-rectified Pleiades pair over La Reunion, without ground truth: the
  reference disparity is the left-right checked SGBM disparity of the clean pair, and the
  target gets the same kind of simulated difference;
* the paper's own means beside ours, plots, and a computed list of where the method does
  not win.

Usage::

    python benchmarks/make_results.py            # the report, into docs/
    python benchmarks/make_results.py --quick    # smoke run (small, one seed), into a temp folder

Options: ``--data`` (shared data folder; default ``$RADCONS_DATA`` or ``../shared/data``
beside the checkout), ``--out`` (folder of ``results.md``), ``--preset``, ``--size``,
``--seeds``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
# the checkout's packages first, so the script runs from the source tree as it is
sys.path.insert(0, str(REPO))

import cv2  # noqa: E402
import numpy as np  # noqa: E402
from scipy import ndimage  # noqa: E402

from bench_baselines import DEGRADATION  # noqa: E402
from demo_data_gen import generate  # noqa: E402
from radcons.evaluate.compare import Comparison, MethodResult, evaluate_methods  # noqa: E402
from radcons.evaluate.matching import MatcherParams, dense_disparity, disparity_range_from_matches  # noqa: E402
from radcons.evaluate.simulate import Degradation, degrade  # noqa: E402
from radcons.evaluate.truth_pairs import labels_to_target, load_cones, load_motorcycle, objects_from_disparity  # noqa: E402
from radcons.io import Pair, Raster, read_raster  # noqa: E402
from radcons.params import DEFAULT_PRESET, PRESETS, Params  # noqa: E402
from radcons.pipeline import Pipeline  # noqa: E402
from radcons.stages.association import match_features  # noqa: E402
from radcons.workflow import evaluate_pair  # noqa: E402

#: Demo scenarios evaluated (``none``, same date and sensor, only gives the ceiling).
SCENARIOS: tuple[str, ...] = ("multi-temporal", "multi-sensor", "mixed")
#: Baselines, in table order.
BASELINE_NAMES: tuple[str, ...] = ("histmatch", "meanstd", "irmad", "zhang", "zhong")
#: Methods of every table, in column order.
COMPARED: tuple[str, ...] = ("original", *BASELINE_NAMES, "paper", "ours")
#: Image stages of the ablation; the last stage's images are "ours".
ABLATION: tuple[str, ...] = ("original", "uniformity", "global", "refine", "sharpness", "ours")
ABLATION_LABELS = {
    "original": "original",
    "uniformity": "+ uniformity (eq 1-3)",
    "global": "+ global (eq 4-6)",
    "refine": "+ refine (eq 7-12)",
    "sharpness": "+ sharpness (not the paper's)",
    "ours": "+ smoothness (eq 13-19) = ours",
}
#: The paper's means over its 9 building objects (Su et al. 2018, Tables 1 and 2).
PAPER_MEANS = {
    "similarity": {"original": 0.807, "zhang": 0.811, "zhong": 0.835, "ours": 0.920},
    "object_rate": {"original": 0.287, "zhang": 0.242, "zhong": 0.337, "ours": 0.572},
}
#: Metrics of the summary tables: key -> (label, MethodResult attribute).
METRICS = {
    "similarity": ("mean object similarity C (eq 20)", "mean_similarity"),
    "rate": ("correct-matching rate, all pixels with ground truth", "correct_rate"),
    "object_rate": ("correct-matching rate, mean over objects", "mean_object_rate"),
}
#: Bar and legend colours (BGR) per method.
COLOURS = {
    "undegraded": (160, 160, 160),
    "original": (90, 90, 90),
    "histmatch": (60, 160, 230),
    "meanstd": (40, 200, 200),
    "irmad": (180, 120, 60),
    "zhang": (200, 90, 160),
    "zhong": (120, 60, 200),
    "paper": (150, 200, 90),
    "ours": (40, 150, 40),
}
#: Differences below this are ties at the report's three decimals.
TIE = 5e-4


@dataclass(frozen=True)
class Settings:
    """What one report run evaluates."""

    size: int
    seeds: tuple[int, ...]
    motorcycle_downsample: int
    pleiades_crop: int | None
    preset: str
    matcher: MatcherParams
    data: Path
    out: Path
    quick: bool


@dataclass
class Entry:
    """One evaluated pair: its comparison, pipeline timings and how it was built."""

    key: str
    title: str
    pair: Pair
    comparison: Comparison
    timings: dict[str, float]
    built: str
    objects: str
    extra: dict


# ----------------------------------------------------------------------------- numbers


def metric(result: MethodResult, key: str) -> float:
    """The value of summary metric ``key`` (or ``"noise_ratio"``) for one method (NaN when undefined)."""
    value = getattr(result, METRICS[key][1] if key in METRICS else key)
    return float("nan") if value is None else float(value)


def fmt(value: float | None, digits: int = 3) -> str:
    """A number for a table, ``-`` when undefined."""
    if value is None or not math.isfinite(value):
        return "-"
    return f"{value:.{digits}f}"


def bold_best(values: list[float], digits: int = 3, lower: bool = False) -> list[str]:
    """Format a row, bolding the largest (``lower``: smallest) value(s), ties at the shown precision."""
    finite = [v for v in values if math.isfinite(v)]
    best = (min(finite) if lower else max(finite)) if finite else float("nan")
    tie = 0.5 * 10.0**-digits
    out = []
    for v in values:
        text = fmt(v, digits)
        out.append(f"**{text}**" if math.isfinite(v) and abs(v - best) <= tie else text)
    return out


def md_table(header: list[str], rows: list[list[str]], numbers: bool = True) -> str:
    """A markdown table, first column left-aligned, the others right-aligned (numbers) or left."""
    align = "--:" if numbers else ":--"
    lines = ["| " + " | ".join(header) + " |", "| " + " | ".join([":--"] + [align] * (len(header) - 1)) + " |"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def seed_mean(entries: list[Entry], method: str, key: str) -> tuple[float, float]:
    """Mean and sample standard deviation of a metric over the entries (seeds)."""
    values = np.array([metric(e.comparison.method(method), key) for e in entries], float)
    values = values[np.isfinite(values)]
    if values.size == 0:
        return float("nan"), float("nan")
    return float(values.mean()), float(values.std(ddof=1)) if values.size > 1 else float("nan")


# ----------------------------------------------------------------------------- pairs


def shared_data_dir(explicit: str | None) -> Path:
    """The shared data folder: ``--data``, else ``$RADCONS_DATA``, else beside the checkout."""
    if explicit:
        return Path(explicit)
    return Path(os.environ.get("RADCONS_DATA") or REPO.parent / "shared" / "data")


def degraded_target(pair: Pair, degradation: Degradation) -> tuple[Pair, dict]:
    """The pair with its target degraded; also the share of the saturated object clipped."""
    target = pair.target.as_float32()
    out = degrade(target, degradation, labels=pair.target_objects)
    high = float(np.nanmax(target))
    region = pair.target_objects == degradation.saturate_label
    clipped = float(np.mean(out[region] >= high)) if region.any() else float("nan")
    degraded = replace(pair.with_images(pair.reference.as_float32(), out), name=pair.name)
    return degraded, {"saturated_object": degradation.saturate_label, "saturated_share_clipped": clipped}


def lr_checked_disparity(
    reference: np.ndarray, target: np.ndarray, matcher: MatcherParams, search: tuple[float, float]
) -> tuple[np.ndarray, dict]:
    """SGBM disparity of the reference, kept where the target's own disparity agrees (< 1 px).

    The target's disparity is computed by matching the mirrored target against the mirrored
    reference (mirroring turns ``target(x') <-> reference(x' + d)`` into the project's
    convention); a reference pixel ``x`` is kept when the target's disparity at
    ``round(x - d)`` is within 1 px of ``d``.
    """
    left = dense_disparity(reference, target, matcher, search)
    right = dense_disparity(target[:, ::-1], reference[:, ::-1], matcher, search)[:, ::-1]
    rows, cols = np.nonzero(np.isfinite(left))
    match = np.rint(cols - left[rows, cols]).astype(np.intp)
    inside = (match >= 0) & (match < left.shape[1])
    rows, cols, match = rows[inside], cols[inside], match[inside]
    agree = np.abs(right[rows, match] - left[rows, cols]) <= 1.0
    out = np.full(left.shape, np.nan, np.float32)
    out[rows[agree], cols[agree]] = left[rows[agree], cols[agree]]
    stats = {
        "search_range": [float(search[0]), float(search[1])],
        "left_valid_share": float(np.isfinite(left).mean()),
        "kept_share": float(np.isfinite(out).mean()),
    }
    return out, stats


def pleiades_pair(folder: Path, crop: int | None, matcher: MatcherParams) -> tuple[Pair, Pair, dict]:
    """The clean Pleiades pair with its reference disparity and objects, and its degraded copy."""
    reference = read_raster(folder / "a.tif").data.astype(np.float32)
    target = read_raster(folder / "b.tif").data.astype(np.float32)
    if crop is not None:
        y0 = (reference.shape[0] - crop) // 2
        x0 = (reference.shape[1] - crop) // 2
        reference = reference[y0 : y0 + crop, x0 : x0 + crop].copy()
        target = target[y0 : y0 + crop, x0 : x0 + crop].copy()
    search = disparity_range_from_matches(match_features(reference, target))
    disparity, stats = lr_checked_disparity(reference, target, matcher, search)
    labels = objects_from_disparity(disparity)
    clean = Pair(
        Raster(reference), Raster(target), disparity=disparity, reference_objects=labels,
        target_objects=labels_to_target(labels, disparity), name="pleiades-reunion",
        source=folder,
    )
    # offset and noise are given for a 0..255 image: scale them to the target's 1-99 %
    # percentile span, where nearly all of its pixels lie (a few bright outliers stretch
    # its minimum-maximum range eightfold)
    low, high = np.nanpercentile(target, [1, 99])
    scale = float(high - low) / 255.0
    degradation = replace(
        DEGRADATION, offset=DEGRADATION.offset * scale, noise_sigma=DEGRADATION.noise_sigma * scale
    )
    degraded, info = degraded_target(clean, degradation)
    stats.update(info, degradation=asdict(degradation), percentile_span=[float(low), float(high)])
    return clean, degraded, stats


def undegraded_result(clean: Pair, comparison: Comparison, degraded: Pair, matcher: MatcherParams) -> Comparison:
    """The comparison with a first column for the clean pair, measured the same way."""
    images = {"undegraded": (clean.reference.as_float32(), clean.target.as_float32())}
    extra = evaluate_methods(
        degraded, images, comparison.object_pairs, matcher, disparity_range=comparison.disparity_range
    )
    return replace(comparison, methods=(*extra.methods, *comparison.methods))


def object_sizes(pair: Pair) -> dict[int, int]:
    """Pixel count of every reference object."""
    ids, counts = np.unique(pair.reference_objects[pair.reference_objects > 0], return_counts=True)
    return {int(i): int(c) for i, c in zip(ids, counts)}


# ----------------------------------------------------------------------------- evaluation


def log(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def run_demo(settings: Settings, params: Params) -> tuple[dict[str, list[Entry]], list[Entry]]:
    """Every scenario and seed; also the same-date, same-sensor pairs (original only)."""
    pipeline = Pipeline(params)
    entries: dict[str, list[Entry]] = {}
    for scenario in SCENARIOS:
        methods = [*COMPARED, *ABLATION[1:-1]]
        entries[scenario] = []
        for seed in settings.seeds:
            log(f"demo {scenario} seed {seed} ...")
            pair = generate(settings.size, seed, scenario)
            run, comparison = evaluate_pair(pair, methods, params, settings.matcher, pipeline=pipeline)
            meta = pair.metadata
            built = f"`generate({settings.size}, {seed}, {scenario!r})`"
            entries[scenario].append(
                Entry(
                    f"{scenario}-{seed}", f"{scenario}, seed {seed}", pair, comparison, dict(run.timings),
                    built, "the generator's building labels", {"metadata": meta},
                )
            )
    ceiling = []
    for seed in settings.seeds:
        log(f"demo none seed {seed} ...")
        pair = generate(settings.size, seed, "none")
        images = {"original": (pair.reference.as_float32(), pair.target.as_float32())}
        comparison = evaluate_methods(pair, images, matcher=settings.matcher)
        ceiling.append(
            Entry(f"none-{seed}", f"none, seed {seed}", pair, comparison, {}, "", "", {"metadata": pair.metadata})
        )
    return entries, ceiling


def run_truth_pair(clean: Pair, settings: Settings, params: Params, built: str) -> Entry:
    """A real pair with ground truth, its target degraded by :data:`DEGRADATION`."""
    log(f"{clean.name} ...")
    pair, info = degraded_target(clean, DEGRADATION)
    run, comparison = evaluate_pair(pair, [*COMPARED, *ABLATION[1:-1]], params, settings.matcher)
    comparison = undegraded_result(clean, comparison, pair, settings.matcher)
    objects = "connected 4 px disparity layers of the ground truth (>= 300 px, 12 largest), carried to the target along it"
    return Entry(clean.name, clean.name, pair, comparison, dict(run.timings), built, objects, info)


def run_pleiades(folder: Path, settings: Settings, params: Params) -> Entry:
    """The Pleiades pair against the left-right checked disparity of its clean version."""
    log("pleiades-reunion ...")
    clean, pair, info = pleiades_pair(folder, settings.pleiades_crop, settings.matcher)
    run, comparison = evaluate_pair(pair, [*COMPARED, *ABLATION[1:-1]], params, settings.matcher)
    comparison = undegraded_result(clean, comparison, pair, settings.matcher)
    shape = f"{clean.shape[1]} x {clean.shape[0]}"
    built = f"`{folder.name}/a.tif`, `b.tif` ({shape}" + (", central crop)" if settings.pleiades_crop else ")")
    objects = (
        "connected 4 px layers of the reference disparity (>= 300 px, 12 largest), carried to the target along it"
    )
    return Entry("pleiades-reunion", "pleiades-reunion", pair, comparison, dict(run.timings), built, objects, info)


# ----------------------------------------------------------------------------- plots


def _text(canvas: np.ndarray, text: str, xy: tuple[int, int], scale: float = 0.5, colour=(0, 0, 0)) -> None:
    cv2.putText(canvas, text, xy, cv2.FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv2.LINE_AA)


def bar_chart(comparison: Comparison, methods: list[str], title: str) -> np.ndarray:
    """Per-object bars of eq 20 similarity (top) and correct-matching rate (bottom)."""
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
    where there is no ground truth; object outlines in white."""
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
    """The reference image, then the error map of each method, side by side, titled."""
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


# ----------------------------------------------------------------------------- report


def best_baseline(comparison: Comparison, key: str) -> tuple[str, float]:
    """The baseline with the highest value of metric ``key``."""
    scored = [(metric(comparison.method(name), key), name) for name in BASELINE_NAMES]
    scored = [(v, n) for v, n in scored if math.isfinite(v)]
    if not scored:
        return "-", float("nan")
    value, name = max(scored)
    return name, value


def beaters(values: dict[str, float], candidates: tuple[str, ...]) -> list[tuple[str, float]]:
    """Methods whose value beats ``values["ours"]`` by more than a tie, largest margin first."""
    ours = values["ours"]
    if not math.isfinite(ours):
        return []
    out = [(n, values[n] - ours) for n in candidates if math.isfinite(values.get(n, np.nan)) and values[n] > ours + TIE]
    return sorted(out, key=lambda item: -item[1])


def scenario_values(entries: list[Entry], key: str, methods: tuple[str, ...]) -> dict[str, float]:
    return {name: seed_mean(entries, name, key)[0] for name in methods}


def section_setup(settings: Settings, params: Params, elapsed: tuple[float, float, float], argv: list[str]) -> str:
    """What was run, with what, where."""
    commit = _git("rev-parse", "--short", "HEAD")
    out = settings.out.resolve()
    dirty = [  # the report's own files, written before this section, do not count
        line for line in _git("status", "--porcelain").splitlines()
        if not (REPO / line.split(maxsplit=1)[-1]).resolve().is_relative_to(out)
    ]
    version = f"{commit}{' with uncommitted changes' if dirty else ''}" if commit else "unknown"
    matcher = ", ".join(f"{k}={v}" for k, v in asdict(settings.matcher).items())
    degradation = ", ".join(f"{k}={v}" for k, v in asdict(DEGRADATION).items() if v is not None)
    lines = [
        "## What was run",
        "",
        f"- Command: `python benchmarks/make_results.py{' ' + ' '.join(argv) if argv else ''}` "
        f"(from the repository root; it writes this page, `results.json` and `img/`).",
        f"- Date: {datetime.date.today().isoformat()}; code: {version}.",
        f"- Machine: {os.cpu_count()} cores ({platform.machine()}, {platform.system()}), Python "
        f"{platform.python_version()}, numpy {np.__version__}, OpenCV {cv2.__version__}; "
        f"the whole script ran in {elapsed[0]:.0f} s wall time, {elapsed[1]:.0f} s CPU time (all threads; "
        f"load average {elapsed[2]:.1f} when it ended).",
        f"- Parameters of ours: preset `{params.preset}` (`Params.from_preset({params.preset!r})`), stages "
        f"switched off: {', '.join(sorted(params.disabled)) or 'none'}; \"ours\" is the image pair after "
        "the last stage. \"paper\" is the pipeline with the `paper` preset: the paper's stages, "
        "equations and values as printed.",
        f"- Dense matcher (one for every method): OpenCV semi-global matching, {matcher}; disparity search "
        "range = the ground truth's range with a 2 px margin. Both images are mapped to 8 bits with one "
        "linear mapping, the reference's 0.5-99.5 percentile range, clipped. Correct match: |d - d_gt| < 1 px; a failed match "
        "counts as wrong (the paper's Figure 5).",
        "- Metrics: eq 20 similarity per object pair (256 levels over the pair's common range, object "
        "bounding boxes with background 0), its mean over the objects; the correct-matching rate over "
        "every pixel with ground truth and its mean over the objects (the paper's Table 2 mean).",
        f"- Simulated date / sensor difference of the real pairs' targets (`bench_baselines.DEGRADATION`, "
        f"`radcons.evaluate.simulate.degrade`): {degradation}. In that order: gamma on the image's range, "
        "gain and offset, object `saturate_label` brightened and clipped (the paper's over-exposed "
        "Object 1), Gaussian blur, Gaussian noise, clip to the original range.",
        f"- Demo pairs: `demo_data_gen.generate(size={settings.size}, seed, scenario)`, seeds "
        f"{', '.join(map(str, settings.seeds))}; objects are the generator's building labels; the pipeline "
        "uses the same labels as its objects.",
    ]
    if settings.quick:
        lines.append("- **Quick smoke run** (`--quick`): small images and one seed; not the report's numbers.")
    return "\n".join(lines)


def _git(*args: str) -> str:
    try:
        done = subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True, timeout=20)
    except (OSError, subprocess.SubprocessError):
        return ""
    return done.stdout.strip() if done.returncode == 0 else ""


def section_demo(demo: dict[str, list[Entry]], ceiling: list[Entry], settings: Settings) -> str:
    """Scenario means over seeds, and how the pairs were built."""
    lines = ["## Synthetic pairs (demo_data_gen, exact ground truth)", ""]
    lines.append(
        f"Means over seeds {', '.join(map(str, settings.seeds))} (± sample standard deviation over the "
        f"seeds), {settings.size} x {settings.size} px. The column \"same date+sensor\" is the original "
        "pair of scenario `none` (same seed, only the view and the noise draw differ): the ceiling the "
        "normalisation methods try to reach. Bold: best method of the row."
    )
    for key, (label, _) in METRICS.items():
        lines += ["", f"**{label}**", ""]
        header = ["scenario", *COMPARED, "same date+sensor"]
        rows = []
        for scenario, entries in demo.items():
            means = [seed_mean(entries, name, key) for name in COMPARED]
            cells = bold_best([m for m, _ in means])
            cells = [c + (f" ±{s:.3f}" if math.isfinite(s) else "") for c, (_, s) in zip(cells, means)]
            rows.append([scenario, *cells, fmt(seed_mean(ceiling, "original", key)[0])])
        lines.append(md_table(header, rows))
    lines += ["", "**noise ratio** (larger over smaller noise sigma of the two images, "
              "`radcons.evaluate.noise`; 1 = the same noise level, the aim of the smoothness stage; bold: "
              "closest to 1). The original pair of multi-sensor and mixed holds an 11-bit and an 8-bit image, "
              "so its sigmas are in different units; every method's output is on one range.", ""]
    rows = []
    for scenario, entries in demo.items():
        means = [seed_mean(entries, name, "noise_ratio")[0] for name in COMPARED]
        rows.append([scenario, *bold_best(means, 2, lower=True), fmt(seed_mean(ceiling, "original", "noise_ratio")[0], 2)])
    lines.append(md_table(["scenario", *COMPARED, "same date+sensor"], rows))
    lines += overexposed_table(demo)
    lines += ["", "How the pairs differ (from the generator's metadata):", ""]
    header = ["pair", "target sensor", "target date", "target sun elev.", "gain / gamma", "over-exposed object",
              "objects", "changes (cars moved, building added/removed)"]
    rows = []
    for scenario, entries in demo.items():
        for entry in entries:
            meta = entry.extra["metadata"]
            rows.append([
                entry.title, str(meta.get("target_sensor")), str(meta.get("target_date")),
                f"{meta.get('target_sun_elevation_deg', float('nan')):.0f} deg",
                f"{meta.get('target_gain', float('nan')):.2f} / {meta.get('target_gamma', float('nan')):.2f}",
                str(meta.get("overexposed_object") or "-"), str(len(entry.comparison.object_pairs)),
                f"{meta.get('cars_moved', 0)}, {meta.get('added_building') or '-'}/{meta.get('removed_building') or '-'}",
            ])
    lines.append(md_table(header, rows, numbers=False))
    reference = demo[SCENARIOS[0]][0].extra["metadata"]
    lines += [
        "",
        f"Reference of every pair: {reference.get('reference_sensor')} ({reference.get('reference_bit_depth')}-bit), "
        f"{reference.get('reference_date')}. The rate over all pixels includes the changed areas "
        "(moved cars, added or removed buildings), which no normalisation can match.",
    ]
    return "\n".join(lines)


def section_stages_everywhere(demo: dict[str, list[Entry]], singles: list[Entry]) -> str:
    """Each pair's value after each stage, for the similarity and the all-pixel rate."""
    lines = ["", "The same stages on every pair (demo: mean over the seeds):"]
    for key in ("similarity", "rate"):
        header = ["pair", *[ABLATION_LABELS[name].split(" (")[0] for name in ABLATION]]
        rows = []
        for label, values in stage_values(demo, singles, key):
            rows.append([label, *bold_best([values[n] for n in ABLATION])])
        lines += ["", f"*{METRICS[key][0]}*", "", md_table(header, rows)]
    drops = []
    for label, values in stage_values(demo, singles, "rate"):
        for before, after in zip(ABLATION, ABLATION[1:]):
            change = values[after] - values[before]
            if change < -0.005:
                drops.append(f"{ABLATION_LABELS[after].split(' (')[0].lstrip('+ ')} on {label} ({change:+.3f})")
    lines += ["", "Stages that lower the all-pixel rate by more than 0.005: " + ("; ".join(drops) or "none") + "."]
    return "\n".join(lines)


def stage_values(demo: dict[str, list[Entry]], singles: list[Entry], key: str) -> list[tuple[str, dict[str, float]]]:
    """Per pair (demo: mean over seeds), the value of ``key`` after each stage."""
    out = [(f"demo {s}", {n: seed_mean(e, n, key)[0] for n in ABLATION}) for s, e in demo.items()]
    out += [(e.title, {n: metric(e.comparison.method(n), key) for n in ABLATION}) for e in singles]
    return out


def overexposed_table(demo: dict[str, list[Entry]]) -> list[str]:
    """Similarity and rate of the over-exposed roof (the paper's Object 1), mean over seeds."""
    rows = []
    for scenario, entries in demo.items():
        values = {}
        for name in COMPARED:
            c, r = [], []
            for entry in entries:
                obj = entry.extra["metadata"].get("overexposed_object")
                result = entry.comparison.method(name)
                if obj and obj in result.similarity:
                    c.append(result.similarity[obj])
                    r.append(result.object_rates.get(obj, np.nan))
            values[name] = (float(np.nanmean(c)) if c else np.nan, float(np.nanmean(r)) if r else np.nan)
        if any(math.isfinite(v[0]) for v in values.values()):
            cells = [f"{fmt(c)} / {fmt(r)}" for c, r in values.values()]
            rows.append([scenario, *cells])
    if not rows:
        return []
    return [
        "", "**The over-exposed roof** (the paper's Object 1; clipped in the target): similarity / "
        "correct-matching rate of that object, mean over the seeds", "",
        md_table(["scenario", *COMPARED], rows),
    ]


def section_ablation(entries: list[Entry]) -> str:
    """Per-stage means on the mixed scenario, with the change each stage brings."""
    lines = ["## Per-stage ablation (mixed scenario)", ""]
    lines.append(
        "Each row is the image pair after that stage of one pipeline run (cumulative), means over the seeds; "
        "the change is against the row above."
    )
    header = ["stage"]
    for key in METRICS:
        header += [key.replace("_", " "), "change"]
    rows = []
    previous = None
    for name in ABLATION:
        values = {key: seed_mean(entries, name, key)[0] for key in METRICS}
        row = [ABLATION_LABELS[name]]
        for key in METRICS:
            change = "" if previous is None else f"{values[key] - previous[key]:+.3f}"
            row += [fmt(values[key]), change]
        rows.append(row)
        previous = values
    lines += ["", md_table(header, rows)]
    worse = []
    previous = None
    for name in ABLATION:
        values = {key: seed_mean(entries, name, key)[0] for key in METRICS}
        if previous is not None:
            for key in METRICS:
                if values[key] < previous[key] - TIE:
                    worse.append(f"{ABLATION_LABELS[name].lstrip('+ ')} lowers {key.replace('_', ' ')} by "
                                 f"{previous[key] - values[key]:.3f}")
        previous = values
    if worse:
        lines += ["", "Stages that make a mean worse: " + "; ".join(worse) + "."]
    else:
        lines += ["", "No stage makes a mean worse."]
    return "\n".join(lines)


def per_object_tables(entry: Entry) -> str:
    """Tables 1 and 2 of the paper for one pair, plus noise ratio and times."""
    comparison = entry.comparison
    present = {m.name for m in comparison.methods}
    names = [n for n in ("undegraded", *COMPARED) if n in present]
    sizes = object_sizes(entry.pair)
    ids = [ref_id for ref_id, _ in comparison.object_pairs]
    header = ["object (px)", *names]
    lines = ["", "Object similarity C (eq 20), as the paper's Table 1:", ""]
    rows = [[f"{i} ({sizes.get(i, 0)})", *bold_best([comparison.method(n).similarity.get(i, np.nan) for n in names])] for i in ids]
    rows.append(["**mean**", *bold_best([comparison.method(n).mean_similarity for n in names])])
    lines.append(md_table(header, rows))
    lines += ["", "Correct-matching rate (|d - d_gt| < 1 px), as the paper's Table 2:", ""]
    rows = [[f"{i} ({sizes.get(i, 0)})", *bold_best([comparison.method(n).object_rates.get(i, np.nan) for n in names])] for i in ids]
    rows.append(["**mean (objects)**", *bold_best([comparison.method(n).mean_object_rate for n in names])])
    rows.append(["**all pixels**", *bold_best([metric(comparison.method(n), "rate") for n in names])])
    lines.append(md_table(header, rows))
    lines += unmatchable_note(entry)
    lines += ["", "Noise ratio (larger over smaller noise sigma of the two images; 1 = same noise) and "
              "normalisation time:", ""]
    rows = [
        ["noise ratio", *[fmt(comparison.method(n).noise_ratio, 2) for n in names]],
        ["normalisation s", *[fmt(comparison.method(n).seconds.get("normalisation"), 2) for n in names]],
    ]
    lines.append(md_table(["", *names], rows))
    return "\n".join(lines)


def unmatchable_note(entry: Entry) -> list[str]:
    """Objects that even the undegraded pair does not match (< 5 %), and why when it is the
    matcher's left border (SGBM leaves the first columns without a match)."""
    comparison = entry.comparison
    names = [m.name for m in comparison.methods]
    if "undegraded" not in names:
        return []
    clean = comparison.method("undegraded")
    bad = [i for i, _ in comparison.object_pairs if clean.object_rates.get(i, 1.0) < 0.05]
    if not bad:
        return []
    matched_cols = np.nonzero(np.isfinite(clean.disparity).any(axis=0))[0]
    border = int(matched_cols[0]) if matched_cols.size else entry.pair.shape[1]
    labels = entry.pair.reference_objects
    parts = []
    for i in bad:
        share = float(np.mean(np.nonzero(labels == i)[1] < border))
        parts.append(f"{i} ({100 * share:.0f} % of it in that border)")
    return [
        "",
        f"Objects that not even the undegraded pair matches (rate < 0.05): {', '.join(parts)}. The matcher "
        f"leaves the first {border} columns without a match; these objects count as failed for every "
        "method alike and pull every mean down the same way.",
    ]


def section_truth_pairs(entries: list[Entry], skipped: list[str]) -> str:
    lines = ["## Real stereo pairs with real ground truth, simulated date / sensor difference", ""]
    lines.append(
        "The reference image is the real left image; the target is the real right image degraded as in "
        "\"What was run\". \"undegraded\" is the real pair as it is, measured the same way (not a method: "
        "what the normalisation should get back to). Objects: connected 4 px disparity layers of the "
        "ground truth (at least 300 px, the 12 largest, numbered by decreasing area), carried into the "
        "target along the ground truth (`radcons.evaluate.truth_pairs`)."
    )
    for note in skipped:
        lines += ["", f"*{note}*"]
    for entry in entries:
        clipped = entry.extra.get("saturated_share_clipped", float("nan"))
        lines += [
            "",
            f"### {entry.title}",
            "",
            f"Built from {entry.built}; {entry.pair.shape[1]} x {entry.pair.shape[0]} px, "
            f"{len(entry.comparison.object_pairs)} objects; disparity search "
            f"{entry.comparison.disparity_range[0]:.1f} .. {entry.comparison.disparity_range[1]:.1f} px. "
            f"Object {entry.extra.get('saturated_object')} is the saturated one "
            f"({fmt(100 * clipped, 0)} % of its target pixels clipped).",
        ]
        lines.append(per_object_tables(entry))
    return "\n".join(lines)


def section_pleiades(entry: Entry | None, note: str | None) -> str:
    lines = ["## Real Pleiades pair (La Reunion), no ground truth", ""]
    if entry is None:
        lines.append(f"*{note}*")
        return "\n".join(lines)
    info = entry.extra
    degradation = info["degradation"]
    clipped = info.get("saturated_share_clipped", float("nan"))
    lines.append(
        f"Built from {entry.built}. No ground truth exists: the reference disparity is the SGBM disparity "
        "of the clean pair (same matcher), computed both ways (the target's by matching the mirrored "
        "images) and kept where the two agree within 1 px: "
        f"{100 * info['left_valid_share']:.0f} % of the pixels had a match, {100 * info['kept_share']:.0f} % "
        f"passed the check (search range {info['search_range'][0]:.1f} .. {info['search_range'][1]:.1f} px, "
        "from the SIFT matches). Objects: connected 4 px layers of that disparity (at least 300 px, the 12 "
        "largest), carried into the target along it; they are terrain patches, not buildings. "
        "The target then gets the simulated difference, with the offset and the noise (given for 0..255) "
        f"scaled to the target's 1-99 % span ({info['percentile_span'][0]:.0f} .. {info['percentile_span'][1]:.0f}): "
        f"offset {degradation['offset']:.1f}, noise sigma {degradation['noise_sigma']:.2f}. Object "
        f"{info['saturated_object']} is brightened; {fmt(100 * clipped, 0)} % of its pixels reach the "
        "clip level (a few bright outliers set the image's maximum far above its content). "
        "The \"undegraded\" column matches the clean pair against a reference made from that same pair, so "
        "it is high by construction; the methods are measured by how close they bring the degraded pair's "
        "matching to the clean pair's."
    )
    lines.append(per_object_tables(entry))
    return "\n".join(lines)


def headline_rows(demo: dict[str, list[Entry]], singles: list[Entry]) -> list[tuple[str, dict[str, dict[str, float]]]]:
    """Per pair (scenario means, then each real pair): metric -> method -> value."""
    methods = ("original", *BASELINE_NAMES, "ours")
    out = []
    for scenario, entries in demo.items():
        out.append((f"demo {scenario} (mean of {len(entries)})", {k: scenario_values(entries, k, methods) for k in METRICS}))
    for entry in singles:
        out.append((entry.title, {k: {n: metric(entry.comparison.method(n), k) for n in methods} for k in METRICS}))
    return out


def section_headline(rows: list[tuple[str, dict[str, dict[str, float]]]]) -> str:
    lines = ["## Headline: ours against the best baseline", ""]
    lines.append("Best baseline = the highest of histmatch, meanstd, irmad, zhang, zhong on that metric and pair.")
    header = ["pair"]
    for key in METRICS:
        header += [f"{key.replace('_', ' ')}: ours", "best baseline", "ours - best"]
    table = []
    for label, values in rows:
        row = [label]
        for key in METRICS:
            ours = values[key]["ours"]
            scored = [(values[key][n], n) for n in BASELINE_NAMES if math.isfinite(values[key][n])]
            best, name = max(scored) if scored else (float("nan"), "-")
            diff = ours - best
            row += [fmt(ours), f"{name} {fmt(best)}", f"**{diff:+.3f}**" if diff < -TIE else f"{diff:+.3f}"]
        table.append(row)
    lines += ["", md_table(header, table)]
    lines += ["", headline_summary(rows)]
    return "\n".join(lines)


def headline_summary(rows: list[tuple[str, dict[str, dict[str, float]]]]) -> str:
    """One computed paragraph: how often ours wins, the largest loss, histogram matching."""
    cells = wins = 0
    worst = (0.0, "", "", "")
    hist = []
    for label, values in rows:
        for key in METRICS:
            if not math.isfinite(values[key]["ours"]):
                continue
            cells += 1
            found = beaters(values[key], BASELINE_NAMES)
            wins += not found
            if found and found[0][1] > worst[0]:
                worst = (found[0][1], found[0][0], key, label)
            margin = values[key]["histmatch"] - values[key]["ours"]
            if margin > TIE:
                hist.append(f"{label} {key.replace('_', ' ')} (+{margin:.3f})")
    text = f"Ours is at least as good as every baseline in {wins} of {cells} pair-metric cells."
    if worst[1]:
        text += (f" The largest loss: {worst[1]} beats ours by {worst[0]:.3f} on {worst[2].replace('_', ' ')} "
                 f"({worst[3]}).")
    if hist:
        text += f" Plain histogram matching beats ours on {len(hist)} cells: {', '.join(hist)}."
    else:
        text += " Plain histogram matching never beats ours."
    return text


def section_paper(rows: list[tuple[str, dict[str, dict[str, float]]]]) -> str:
    lines = ["## Beside the paper's own means", ""]
    lines.append(
        "**The data differ**: the paper measures 9 building objects of its own WorldView-2 / QuickBird and "
        "BJ-2 pairs (not public); the rows below are this report's pairs, with this project's "
        "reconstructions of Zhang's and Zhong's methods and its own matcher. Only the direction and size "
        "of the gaps can be compared, not the values. Rate = mean over the objects, as the paper's Table 2."
    )
    names = ("original", "zhang", "zhong", "ours")
    header = ["data", *[f"C {n}" for n in names], *[f"rate {n}" for n in names]]
    table = [["paper (Tables 1-2)", *[fmt(PAPER_MEANS["similarity"][n]) for n in names],
              *[fmt(PAPER_MEANS["object_rate"][n]) for n in names]]]
    for label, values in rows:
        table.append([label, *[fmt(values["similarity"][n]) for n in names], *[fmt(values["object_rate"][n]) for n in names]])
    lines += ["", md_table(header, table)]
    return "\n".join(lines)


def section_losses(rows, demo: dict[str, list[Entry]], singles: list[Entry], object_entries: list[Entry]) -> str:
    """Computed: every method that beats ours, per pair and metric; per object too."""
    candidates = ("original", *BASELINE_NAMES)
    lines = ["## Where ours does not win", ""]
    lines.append(
        "Computed from the numbers above: for each pair and metric, every method (the original pair "
        "included) whose value is higher than ours by more than 0.0005, with the margin. For the demo "
        "scenarios the value is the mean over the seeds, and \"k/n\" counts the seeds on which the "
        "method beats ours."
    )
    header = ["pair", *[METRICS[k][0] for k in METRICS]]
    table = []
    seed_entries = {f"demo {s} (mean of {len(e)})": e for s, e in demo.items()}
    for label, values in rows:
        row = [label]
        for key in METRICS:
            found = beaters(values[key], candidates)
            cells = []
            for name, margin in found:
                text = f"{name} +{margin:.3f}"
                if label in seed_entries:
                    per_seed = seed_entries[label]
                    wins = sum(
                        metric(e.comparison.method(name), key) > metric(e.comparison.method("ours"), key) + TIE
                        for e in per_seed
                    )
                    text += f" ({wins}/{len(per_seed)})"
                cells.append(text)
            row.append(", ".join(cells) if cells else "none: ours is best")
        table.append(row)
    lines += ["", md_table(header, table, numbers=False)]
    lines += ["", "Per object (each pair with per-object tables, and the first seed of each demo scenario):", ""]
    header = ["pair", "objects", "ours best C", "ours best rate", "histmatch beats ours: C / rate",
              "largest per-object rate loss of ours"]
    table = []
    for entry in object_entries:
        comparison = entry.comparison
        ids = [ref_id for ref_id, _ in comparison.object_pairs]
        best_c = best_r = hist_c = hist_r = 0
        worst = (0.0, "-", "-")
        for i in ids:
            c = {n: comparison.method(n).similarity.get(i, np.nan) for n in candidates + ("ours",)}
            r = {n: comparison.method(n).object_rates.get(i, np.nan) for n in candidates + ("ours",)}
            best_c += not beaters(c, candidates)
            best_r += not beaters(r, candidates)
            hist_c += c["histmatch"] > c["ours"] + TIE
            hist_r += r["histmatch"] > r["ours"] + TIE
            for name, margin in beaters(r, candidates)[:1]:
                if margin > worst[0]:
                    worst = (margin, str(i), name)
        loss = f"object {worst[1]}: {worst[2]} +{worst[0]:.3f}" if worst[1] != "-" else "none"
        table.append([entry.title, str(len(ids)), str(best_c), str(best_r), f"{hist_c} / {hist_r}", loss])
    lines.append(md_table(header, table))
    return "\n".join(lines)


def section_plots(images: list[tuple[str, str, str]]) -> str:
    lines = ["## Plots", ""]
    for title, caption, path in images:
        lines += [f"**{title}.** {caption}", "", f"![{title}]({path})", ""]
    return "\n".join(lines).rstrip()


def section_timings(demo: dict[str, list[Entry]], singles: list[Entry]) -> str:
    """Pipeline stage times (s) per pair."""
    stages = ("association", "uniformity", "global", "refine", "smoothness")
    lines = ["## Pipeline time per stage (s)", ""]
    lines += ["Wall seconds of each stage in this run (see \"What was run\" for the machine and its load); "
              "the objects stage reads the given labels and takes no time.", ""]
    rows = []
    for scenario, entries in demo.items():
        rows.append([f"demo {scenario} (mean)", *[fmt(float(np.mean([e.timings.get(s, 0.0) for e in entries])), 2) for s in stages]])
    for entry in singles:
        rows.append([entry.title, *[fmt(entry.timings.get(s, 0.0), 2) for s in stages]])
    lines.append(md_table(["pair", *stages], rows))
    return "\n".join(lines)


# ----------------------------------------------------------------------------- main


def parse(argv: list[str]) -> Settings:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small images, one seed, into a temp folder")
    parser.add_argument("--data", help="shared data folder (default $RADCONS_DATA or ../shared/data)")
    parser.add_argument("--out", help="folder of results.md (default docs/, or a temp folder with --quick)")
    parser.add_argument("--preset", default=DEFAULT_PRESET, choices=PRESETS, help="parameter preset of ours")
    parser.add_argument("--size", type=int, help="demo image size (default 512, 256 with --quick)")
    parser.add_argument("--seeds", type=int, nargs="+", help="demo seeds (default 0 1 2, 0 with --quick)")
    args = parser.parse_args(argv)
    quick = args.quick
    out = Path(args.out) if args.out else (
        Path(tempfile.gettempdir()) / "radcons-results-quick" if quick else REPO / "docs"
    )
    return Settings(
        size=args.size or (256 if quick else 512),
        seeds=tuple(args.seeds or ((0,) if quick else (0, 1, 2))),
        motorcycle_downsample=4 if quick else 2,
        pleiades_crop=384 if quick else None,
        preset=args.preset,
        matcher=MatcherParams(),
        data=shared_data_dir(args.data),
        out=out,
        quick=quick,
    )


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    settings = parse(argv)
    start, cpu_start = time.perf_counter(), time.process_time()
    params = Params.from_preset(settings.preset)
    img_dir = settings.out / "img"
    img_dir.mkdir(parents=True, exist_ok=True)

    demo, ceiling = run_demo(settings, params)

    truth_entries, skipped = [], []
    cones_dir = settings.data / "middlebury_cones"
    if cones_dir.is_dir():
        truth_entries.append(run_truth_pair(
            load_cones(cones_dir), settings, params, f"`{cones_dir.name}/left.tif`, `right.tif`, `disp_left_gt.tif`"
        ))
    else:
        skipped.append(f"Cones skipped: {cones_dir} not found (set --data or $RADCONS_DATA).")
    truth_entries.append(run_truth_pair(
        load_motorcycle(settings.motorcycle_downsample), settings, params,
        f"`skimage.data.stereo_motorcycle()`, grey, reduced {settings.motorcycle_downsample}x",
    ))
    pleiades_dir = settings.data / "pleiades_reunion_rectified"
    pleiades, pleiades_note = None, None
    if pleiades_dir.is_dir():
        pleiades = run_pleiades(pleiades_dir, settings, params)
    else:
        pleiades_note = f"Skipped: {pleiades_dir} not found (set --data or $RADCONS_DATA)."
    singles = truth_entries + ([pleiades] if pleiades else [])

    log("plots ...")
    plots = []
    mixed0 = demo["mixed"][0]
    chart_entries = [e for e in truth_entries if e.key == "cones"] + [mixed0]
    for entry in chart_entries:
        name = f"bars_{entry.key}.png"
        cv2.imwrite(str(img_dir / name), bar_chart(entry.comparison, list(COMPARED), f"{entry.title}: per object"))
        plots.append((
            f"Per object, {entry.title}",
            "Eq 20 similarity (top) and correct-matching rate (bottom) of each object, one bar per method; "
            "the last group is the mean over the objects.",
            f"img/{name}",
        ))
    for entry in chart_entries:
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

    rows = headline_rows(demo, singles)
    object_entries = truth_entries + ([pleiades] if pleiades else []) + [entries[0] for entries in demo.values()]
    elapsed = (time.perf_counter() - start, time.process_time() - cpu_start, os.getloadavg()[0])
    title = "# Results" + (" (quick smoke run)" if settings.quick else "")
    sections = [
        title,
        "This page is written by `benchmarks/make_results.py`; every number in it comes from that run "
        "(raw numbers: `results.json`). Regenerate it instead of editing it.",
        section_headline(rows),
        section_setup(settings, params, elapsed, argv),
        section_demo(demo, ceiling, settings),
        section_ablation(demo["mixed"]) + "\n" + section_stages_everywhere(demo, singles),
        section_truth_pairs(truth_entries, skipped),
        section_pleiades(pleiades, pleiades_note),
        section_paper(rows),
        section_losses(rows, demo, singles, object_entries),
        section_plots(plots),
        section_timings(demo, singles),
    ]
    settings.out.mkdir(parents=True, exist_ok=True)
    (settings.out / "results.md").write_text("\n\n".join(sections) + "\n", encoding="utf-8")
    report = {
        "settings": {
            "size": settings.size, "seeds": list(settings.seeds), "preset": settings.preset,
            "params": params.to_dict(), "matcher": asdict(settings.matcher), "degradation": asdict(DEGRADATION),
            "motorcycle_downsample": settings.motorcycle_downsample, "pleiades_crop": settings.pleiades_crop,
            "quick": settings.quick, "date": datetime.date.today().isoformat(), "cores": os.cpu_count(),
            "seconds": round(elapsed[0], 1), "cpu_seconds": round(elapsed[1], 1),
        },
        "demo": {
            scenario: {str(e.extra["metadata"]["seed"]): _entry_json(e) for e in entries}
            for scenario, entries in demo.items()
        },
        "demo_same_date_sensor": {str(e.extra["metadata"]["seed"]): _entry_json(e) for e in ceiling},
        "real": {e.key: _entry_json(e) for e in singles},
        "paper_means": PAPER_MEANS,
    }
    (settings.out / "results.json").write_text(json.dumps(_plain(report), indent=1, allow_nan=False) + "\n")
    log(f"wrote {settings.out / 'results.md'} in {elapsed[0]:.0f} s ({elapsed[1]:.0f} s CPU)")


def _entry_json(entry: Entry) -> dict:
    out = entry.comparison.to_json_dict()
    out["pipeline_seconds"] = {k: round(v, 4) for k, v in entry.timings.items()}
    out["built"] = entry.built
    out["objects"] = entry.objects
    out["extra"] = {k: v for k, v in entry.extra.items()}
    return out


def _plain(value):
    """JSON-ready copy: numpy scalars to Python, tuples to lists, NaN to None."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, set, frozenset)):
        return [_plain(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, Path):
        return str(value)
    return value


if __name__ == "__main__":
    main()
