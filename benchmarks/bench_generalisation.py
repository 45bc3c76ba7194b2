"""Does the method help on pairs and differences it was not tuned on?

Two benchmarks, both measured with both dense matchers (SGBM and census) and the same
disparity range for every method (the ground truth's, 2 px margin):

1. **Randomised differences** (:mod:`radcons.evaluate.simulate`): for every seed of the
   chosen split (tuning or held-out, fixed in ``simulate.split_of``) one date / sensor
   difference is drawn and applied to each real stereo pair with ground truth (Middlebury
   Cones, Middlebury Motorcycle, the demo pair without differences); every method
   normalises the result: as given, histogram matching, IR-MAD, Zhang, Zhong, the
   ``paper`` and ``radcons`` presets. Printed: the correct-matching rate (|d - d_gt| <
   1 px, all pixels with ground truth) per difference kind, mean over seeds and pairs, the
   best baseline and ours minus it, and the noise ratio of ours.
2. **US3D** (real multi-date WorldView-3 tiles with lidar truth): every method, both
   matchers, 1 px and 3 px tolerance, the mean per-object rate at 3 px, and the 1 px and
   3 px rates over the pixels whose lidar disparity lies more than 3 px from zero (most
   of a tile lies within 3 px of zero, where a constant zero disparity is right at 3 px);
   beside them the rates of a constant zero disparity (no matching), the floor to read
   them against, and ours minus as given over those pixels.

Rates are kept in a JSON cache (``--cache``) keyed by pair, seed, method (presets by a
fingerprint of their parameters) and matcher, so a re-run only computes what changed.

Usage::

    python benchmarks/bench_generalisation.py [--split held-out] [--blocks 1] [--seeds 9 10]
        [--pairs cones motorcycle demo] [--demo-size 256] [--matchers sgbm census]
        [--methods original histmatch irmad zhang zhong paper radcons]
        [--us3d] [--us3d-only] [--us3d-crop 512] [--cache gen.json] [--json out.json]
        [--timing 5] [--timing-only] [--set refine.agreement_gate=false smoothness.enabled=true]
        [--versus 'refine.background="histogram"'] [--withhold-labels]

``--set STAGE.KEY=VALUE`` (TOML values) changes the ``radcons`` preset measured, so that a
variant is compared with the same baselines (cached) on the same seeds. ``--versus
STAGE.KEY=VALUE`` runs a second variant of the preset beside it and prints ours minus it
pair-seed by pair-seed, per kind, with the standard error of the mean
(:func:`paired_differences`): how a default is chosen between two candidates.

``--timing N`` also times the default preset on a 1024 x 1024 pair (the first US3D tile,
else the demo pair at 1024 px): median of N runs (fresh pipeline each, no cache), beside
histogram matching's median in the same process.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import statistics
import time
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np

from demo_data_gen import generate
from radcons.baselines import BASELINES
from radcons.numerics.census import CensusParams
from radcons.evaluate.matching import MatcherParams, dense_disparity, disparity_range_from_truth
from radcons.evaluate.measure import as_written
from radcons.evaluate.rates import correct_matching_rate, elevated_mask, object_matching_rates
from radcons.evaluate.simulate import KINDS, SPLITS, sample_difference, simulate_pair, split_seeds
from radcons.evaluate.truth_pairs import load_cones, load_motorcycle, load_us3d, us3d_names
from radcons.noise import noise_ratio
from radcons.params import DEFAULT_PRESET, Params
from radcons.pipeline import Pipeline

PAIRS = ("cones", "motorcycle", "demo")
COMPARED_BASELINES = ("histmatch", "irmad", "zhang", "zhong")
METHODS = ("original", *COMPARED_BASELINES, "paper", "radcons")
MATCHERS = {"sgbm": MatcherParams(), "census": CensusParams()}
US3D_FOLDER = "us3d_jacksonville_multidate"
#: The US3D records' pseudo-method: a constant zero disparity (:func:`zero_disparity_rates`).
ZERO = "zero disparity"
#: The method name of the ``radcons`` variant ``--versus`` compares ours with, pair-seed by pair-seed.
VERSUS = "versus"
#: US3D: the ``elevated1`` / ``elevated3`` rates count the pixels whose lidar disparity lies
#: more than this many pixels from zero (:func:`elevated_rates`).
ELEVATED_MARGIN = 3.0


def base_pairs(names, data: Path, demo_size: int, withhold_labels: bool = False):
    """``(label, pair)`` of the real pairs with ground truth asked for (Cones needs ``data``).

    With ``withhold_labels`` the pairs lose their object label rasters, so the pipeline
    segments its own objects (what a user without footprints gets); their labels then end
    in ``-segmented`` so their measurements are cached apart.
    """
    out = []
    for name in names:
        if name == "cones":
            folder = data / "middlebury_cones"
            if folder.is_dir():
                out.append(("cones", load_cones(folder)))
            else:
                print(f"(skipping Cones: {folder} not found)")
        elif name == "motorcycle":
            out.append(("motorcycle", load_motorcycle()))
        else:
            out.append(("demo", generate(size=demo_size, seed=0, scenario="none")))
    if withhold_labels:
        out = [(f"{label}-segmented", replace(pair, reference_objects=None, target_objects=None)) for label, pair in out]
    return out


def fingerprint(params: Params) -> str:
    """Short hash of a parameter set (cache key of a preset's results)."""
    return hashlib.sha1(json.dumps(params.to_dict(), sort_keys=True).encode()).hexdigest()[:10]


def method_key(method: str, presets: dict[str, Params]) -> str:
    """Cache name of a method's results: a preset's by its parameters' fingerprint (the
    ``--versus`` variant is a ``radcons`` variant, cached as one)."""
    if method not in presets:
        return method
    return f"{'radcons' if method == VERSUS else method}@{fingerprint(presets[method])}"


def method_images(pair, method: str, presets: dict[str, Params]):
    """``(reference, target)`` float32 images a method produces, and its seconds: a preset's
    as ``radcons process`` writes them (:func:`radcons.evaluate.measure.as_written`), a
    baseline's as computed."""
    start = time.perf_counter()
    reference, target = pair.reference.as_float32(), pair.target.as_float32()
    if method in BASELINES:
        target = BASELINES[method](reference, target)
    elif method in presets:
        reference, target = as_written(pair, *Pipeline(presets[method]).run(pair).images())
    return (reference, target), time.perf_counter() - start


def elevated_rates(disparity: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    """Rates at 1 and 3 px over the pixels whose truth lies more than ``ELEVATED_MARGIN`` from zero.

    Parameters
    ----------
    disparity : ndarray
        Dense disparity, NaN where matching failed.
    truth : ndarray
        Ground-truth disparity, NaN where unknown.

    Returns
    -------
    dict
        ``{"elevated1": rate at 1 px, "elevated3": rate at 3 px}`` over
        :func:`radcons.evaluate.rates.elevated_mask` (NaN where no such pixel).
    """
    mask = elevated_mask(truth, ELEVATED_MARGIN)
    return {f"elevated{t}": correct_matching_rate(disparity, truth, mask, threshold=float(t)) for t in (1, 3)}


def measure(pair, images, matcher: str, labels=None, elevated: bool = False) -> dict:
    """Rates at 1 and 3 px (all pixels; objects' mean at 3 px where ``labels``; over the
    pixels away from zero disparity, :func:`elevated_rates`, where ``elevated``), noise ratio."""
    truth = pair.disparity
    disparity = dense_disparity(*images, MATCHERS[matcher], disparity_range_from_truth(truth))
    out = {
        "rate1": correct_matching_rate(disparity, truth, threshold=1.0),
        "rate3": correct_matching_rate(disparity, truth, threshold=3.0),
        "noise_ratio": noise_ratio(*images),
    }
    if elevated:
        out.update(elevated_rates(disparity, truth))
    if labels is not None and labels.max() > 0:
        rates = [r for r in object_matching_rates(disparity, truth, labels, 3.0).values() if math.isfinite(r)]
        out["objects3"] = float(np.mean(rates)) if rates else float("nan")
    return out


class Cache:
    """Measurements by key, read from and written back to a JSON file (or memory only)."""

    def __init__(self, path: str | None):
        self.path = Path(path) if path else None
        self.data = json.loads(self.path.read_text()) if self.path and self.path.is_file() else {}

    def get(self, key: str, compute):
        if key not in self.data:
            self.data[key] = compute()
            if self.path:
                self.path.write_text(json.dumps(self.data))
        return self.data[key]


def evaluate_pair(label, pair, methods, matchers, presets, cache: Cache, labels=None, elevated: bool = False) -> dict:
    """``method -> matcher -> measurements`` of one pair, through the cache (see :func:`measure`)."""
    results: dict[str, dict] = {}
    for method in methods:
        images = None
        results[method] = {}
        for matcher in matchers:
            key = f"{label}|{method_key(method, presets)}|{matcher}"
            if key not in cache.data and images is None:
                images, seconds = method_images(pair, method, presets)
                cache.data[f"{label}|{method_key(method, presets)}|seconds"] = seconds
            results[method][matcher] = cache.get(key, lambda: measure(pair, images, matcher, labels, elevated))
    return results


def run_randomised(pairs, seeds, methods, matchers, presets, cache: Cache) -> list[dict]:
    """One record per pair, seed, method and matcher."""
    records = []
    for seed in seeds:
        difference = sample_difference(seed)
        for label, pair in pairs:
            simulated = None
            keys = [f"{label} s{seed}|{method_key(m, presets)}|{k}" for m in methods for k in matchers]
            if not all(key in cache.data for key in keys):
                simulated = simulate_pair(pair, difference)
            results = evaluate_pair(f"{label} s{seed}", simulated, methods, matchers, presets, cache)
            for method, by_matcher in results.items():
                for matcher, values in by_matcher.items():
                    records.append({"pair": label, "seed": seed, "kind": difference.kind, "split": difference.split,
                                    "method": method, "matcher": matcher, **values})
        print(f"seed {seed} ({difference.kind}): done", flush=True)
    return records


def run_us3d(
    folder: Path, methods, matchers, presets, cache: Cache, crop: int | None, withhold_labels: bool = False
) -> list[dict]:
    """One record per tile, method and matcher.

    Every record holds the rates over the pixels away from zero disparity
    (:func:`elevated_rates`), of the images as written (8-bit tiles: rounded); the
    tiles' cache labels end in ``elevated written`` so that measurements without them, or
    of float images, are not read back. With ``withhold_labels`` the pipeline
    does not get the tiles' label rasters (it finds its own objects), while the objects'
    mean rate is still measured over them; the tiles' labels then end in ``-segmented`` so
    their measurements are cached apart.
    """
    records = []
    for name in us3d_names(folder):
        pair = load_us3d(folder, name, crop=crop)
        label = f"us3d {name}" + (f" crop{crop}" if crop else "") + ("-segmented" if withhold_labels else "") + " elevated written"
        run_pair = replace(pair, reference_objects=None, target_objects=None) if withhold_labels else pair
        results = evaluate_pair(
            label, run_pair, methods, matchers, presets, cache, labels=pair.reference_objects, elevated=True
        )
        for method, by_matcher in results.items():
            for matcher, values in by_matcher.items():
                records.append({"pair": name, "method": method, "matcher": matcher, **values})
        records.append({"pair": name, "method": ZERO, "matcher": "none", **zero_disparity_rates(pair)})
        print(f"{name}: done", flush=True)
    return records


def zero_disparity_rates(pair) -> dict:
    """Rates at 1 and 3 px (and the objects' mean at 3 px) of a constant zero disparity.

    No matching at all: the floor a tile's rates should be read against. A tile whose
    disparities lie mostly within 3 px of zero rewards any method that pulls a matcher's
    disparities toward zero at 3 px, whatever it does to the radiometry; hence also the
    share of the pixels with truth that lie more than ``ELEVATED_MARGIN`` from zero
    (``elevated_share``), over which :func:`elevated_rates` compares methods (zero
    disparity scores 0 there).
    """
    truth = pair.disparity
    zero = np.zeros(truth.shape, np.float32)
    out = {f"rate{t}": correct_matching_rate(zero, truth, threshold=float(t)) for t in (1, 3)}
    out.update(elevated_rates(zero, truth))
    known = np.isfinite(truth)
    out["elevated_share"] = float(np.count_nonzero(elevated_mask(truth, ELEVATED_MARGIN)) / max(np.count_nonzero(known), 1))
    labels = pair.reference_objects
    if labels is not None and labels.max() > 0:
        rates = [r for r in object_matching_rates(zero, truth, labels, 3.0).values() if math.isfinite(r)]
        out["objects3"] = float(np.mean(rates)) if rates else float("nan")
    return out


def mean_rate(records, key="rate1", **where) -> float:
    values = [r[key] for r in records if all(r[k] == v for k, v in where.items()) and math.isfinite(r[key])]
    return float(np.mean(values)) if values else float("nan")


def us3d_gain(records, key: str, matchers, ours: str = "radcons") -> float:
    """Ours minus as given on the US3D records: ``key``'s rate, mean over tiles and matchers.

    Parameters
    ----------
    records : list of dict
        The records of :func:`run_us3d`.
    key : str
        The rate compared (``"rate3"``, ``"elevated3"``, ...).
    matchers : iterable of str
        The matchers averaged over.
    ours : str
        The method compared with the pair as given.

    Returns
    -------
    float
        The mean over matchers of (mean over tiles of ours) - (mean over tiles as given).
    """
    return float(np.mean([
        mean_rate(records, key, method=ours, matcher=m) - mean_rate(records, key, method="original", matcher=m)
        for m in matchers
    ]))


def randomised_table(records, methods, matcher: str, ours: str = "radcons") -> list[list]:
    """Rows ``[kind, rate per method..., best baseline, ours - best]``, then an "all" row."""
    baselines = [m for m in ("original", *COMPARED_BASELINES) if m in methods]
    rows = []
    kinds = [k for k in KINDS if any(r["kind"] == k for r in records)]
    for kind in [*kinds, "all"]:
        where = {"matcher": matcher} if kind == "all" else {"matcher": matcher, "kind": kind}
        values = {m: mean_rate(records, method=m, **where) for m in methods}
        best = max(values[m] for m in baselines)
        margin = values[ours] - best if ours in values else float("nan")
        rows.append([kind, *[values[m] for m in methods], best, margin])
    return rows


def print_rows(title, header, rows) -> None:
    print(f"\n{title}")
    print(header[0].ljust(14) + "".join(h.rjust(11) for h in header[1:]))
    for row in rows:
        cells = [f"{v:+.3f}" if i == len(row) - 1 and isinstance(v, float) and header[-1].startswith("ours")
                 else (f"{v:.3f}" if isinstance(v, float) else str(v)) for i, v in enumerate(row[1:], 1)]
        print(str(row[0]).ljust(14) + "".join(c.rjust(11) for c in cells))


def print_randomised(records, methods, matchers, split) -> None:
    header = ["kind", *methods, "best base", "ours-best"]
    for matcher in matchers:
        rows = randomised_table(records, methods, matcher)
        print_rows(f"{split} split, {matcher}: correct-matching rate (1 px), mean over seeds and pairs", header, rows)
    if "radcons" in methods:
        ratios = [r["noise_ratio"] for r in records if r["method"] == "radcons" and r["matcher"] == matchers[0]]
        print(f"\nnoise ratio of ours ({split}): median {np.median(ratios):.2f}, "
              f"mean {np.mean(ratios):.2f}, share within 1.0-1.3 {np.mean(np.array(ratios) <= 1.3):.2f}")


def paired_differences(records, matcher: str, ours: str = "radcons", other: str = VERSUS) -> dict[str, tuple[float, float, int]]:
    """Kind (then ``"all"``) -> mean of ``ours - other`` at 1 px over the pair-seeds both
    have, its standard error (NaN below two), and their count."""
    rates = {(r["pair"], r["seed"], r["method"]): (r["kind"], r["rate1"]) for r in records if r["matcher"] == matcher}
    both = [(kind, rate - rates[(pair, seed, other)][1]) for (pair, seed, method), (kind, rate) in rates.items()
            if method == ours and (pair, seed, other) in rates]
    out = {}
    for kind in [*(k for k in KINDS if any(b[0] == k for b in both)), "all"]:
        values = np.array([d for k, d in both if kind in ("all", k)])
        se = float(values.std(ddof=1) / math.sqrt(values.size)) if values.size > 1 else float("nan")
        out[kind] = (float(values.mean()) if values.size else float("nan"), se, int(values.size))
    return out


def print_paired(records, matchers, split) -> None:
    """``--versus``: ours minus the variant, pair-seed by pair-seed, per kind and matcher."""
    for matcher in matchers:
        print(f"\n{split} split, {matcher}: ours - versus at 1 px, paired over pair-seeds (standard error)")
        for kind, (mean, se, n) in paired_differences(records, matcher).items():
            print(f"{kind:14s} {mean:+.4f} ({se:.4f}) n={n}")


def print_us3d(records, methods, matchers) -> None:
    """Per tile and over tiles: every method's rates (``eN`` = over the pixels more than
    ``ELEVATED_MARGIN`` from zero), a zero disparity's, then ours minus as given."""
    tiles = sorted({r["pair"] for r in records})
    keys = [(k, f"{kind}{t}") for k in matchers for kind in ("rate", "elevated") for t in (1, 3)]
    header = [
        "method", *[f"{k[:5]} {'e' if key.startswith('elevated') else ''}{key[-1]}px" for k, key in keys],
        f"{matchers[-1][:5]} obj3",
    ]
    for tile in [*tiles, "mean"]:
        where = {} if tile == "mean" else {"pair": tile}
        rows = []
        for method in methods:
            cells = [mean_rate(records, key, method=method, matcher=k, **where) for k, key in keys]
            cells.append(mean_rate(records, "objects3", method=method, matcher=matchers[-1], **where))
            rows.append([method, *cells])
        print_rows(f"US3D {tile}: correct-matching rate", header, rows)
        print(f"a constant zero disparity (no matching): 1 px {mean_rate(records, 'rate1', method=ZERO, **where):.3f}, "
              f"3 px {mean_rate(records, 'rate3', method=ZERO, **where):.3f}; "
              f"pixels more than {ELEVATED_MARGIN:g} px from zero {mean_rate(records, 'elevated_share', method=ZERO, **where):.3f}")
    if "radcons" in methods and "original" in methods:
        print(f"\nours minus as given, mean over tiles and matchers: 3 px {us3d_gain(records, 'rate3', matchers):+.3f}, "
              f"3 px over pixels more than {ELEVATED_MARGIN:g} px from zero {us3d_gain(records, 'elevated3', matchers):+.3f}")


def print_timing(data: Path, repeat: int) -> None:
    """Median run time of the default preset and of histogram matching on a 1024 x 1024 pair."""
    folder = data / US3D_FOLDER
    pair = load_us3d(folder, us3d_names(folder)[0]) if folder.is_dir() else generate(size=1024, seed=0, scenario="mixed")
    params = Params.from_preset(DEFAULT_PRESET)
    Pipeline(params).run(pair)  # warm-up: imports, numba and Pandora set-up
    preset, histogram = [], []
    for _ in range(repeat):
        start = time.perf_counter()
        Pipeline(params).run(pair)
        preset.append(time.perf_counter() - start)
        start = time.perf_counter()
        BASELINES["histmatch"](pair.reference.as_float32(), pair.target.as_float32())
        histogram.append(time.perf_counter() - start)
    p, h = statistics.median(preset), statistics.median(histogram)
    print(f"\nrun time on {pair.name} {pair.shape[1]} x {pair.shape[0]}, median of {repeat}:")
    print(f"{DEFAULT_PRESET} preset {p:.2f} s, histogram matching {h:.3f} s, ratio {p / h:.0f}")


def radcons_variant(settings: list[str]) -> Params:
    """The ``radcons`` preset with ``STAGE.KEY=VALUE`` changes (TOML values)."""
    tables: dict[str, dict] = {}
    for setting in settings:
        name, _, value = setting.partition("=")
        stage, _, key = name.partition(".")
        if not (stage and key and value):
            raise SystemExit(f"--set needs STAGE.KEY=VALUE, got {setting!r}")
        tables.setdefault(stage, {})[key] = tomllib.loads(f"v = {value}")["v"]
    return Params.from_dict({"preset": "radcons", **tables})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    shared = Path(__file__).resolve().parents[2] / "shared" / "data"
    parser.add_argument("--data", default=os.environ.get("RADCONS_DATA", str(shared)), help="shared data folder")
    parser.add_argument("--split", choices=SPLITS, default="held-out")
    parser.add_argument("--blocks", type=int, default=1, help="blocks of len(KINDS) seeds of the split")
    parser.add_argument("--seeds", type=int, nargs="+", help="these seeds instead of the split's")
    parser.add_argument("--pairs", nargs="+", default=list(PAIRS), choices=PAIRS)
    parser.add_argument("--demo-size", type=int, default=256, help="side of the demo pair, px")
    parser.add_argument("--matchers", nargs="+", default=list(MATCHERS), choices=list(MATCHERS))
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    parser.add_argument("--us3d", action="store_true", help="also the US3D tiles")
    parser.add_argument("--us3d-only", action="store_true", help="only the US3D tiles")
    parser.add_argument("--us3d-crop", type=int, help="central crop of the US3D tiles, px (default whole)")
    parser.add_argument("--cache", help="JSON cache of the measurements (re-runs compute only what changed)")
    parser.add_argument("--json", help="write the records here")
    parser.add_argument("--timing", type=int, default=0, metavar="N", help="time the default preset, N runs")
    parser.add_argument("--set", nargs="+", default=[], metavar="STAGE.KEY=VALUE", help="change the radcons preset")
    parser.add_argument(
        "--versus", nargs="+", metavar="STAGE.KEY=VALUE",
        help="also run the radcons preset with these changes and print ours minus it, paired (randomised only)",
    )
    parser.add_argument("--timing-only", action="store_true", help="only the timing (N = --timing, default 5)")
    parser.add_argument(
        "--withhold-labels", action="store_true", help="pairs and US3D tiles without their object labels (segmented)"
    )
    args = parser.parse_args()

    presets = {name: Params.from_preset(name) for name in ("paper", "radcons") if name in args.methods}
    if "radcons" in presets and args.set:
        presets["radcons"] = radcons_variant(args.set)
    methods = list(args.methods)
    if args.versus:
        if "radcons" not in presets:
            raise SystemExit("--versus compares with the radcons method: add it to --methods")
        presets[VERSUS] = radcons_variant(args.versus)
        methods.append(VERSUS)
    cache = Cache(args.cache)
    report: dict[str, list] = {}
    if args.timing_only:
        print_timing(Path(args.data), args.timing or 5)
        return
    if not args.us3d_only:
        seeds = args.seeds or split_seeds(args.split, args.blocks)
        pairs = base_pairs(args.pairs, Path(args.data), args.demo_size, args.withhold_labels)
        report["randomised"] = run_randomised(pairs, seeds, methods, args.matchers, presets, cache)
        splits = sorted({r["split"] for r in report["randomised"]})
        for split in splits:
            records = [r for r in report["randomised"] if r["split"] == split]
            print_randomised(records, args.methods, args.matchers, split)
            if args.versus:
                print_paired(records, args.matchers, split)
    if args.us3d or args.us3d_only:
        folder = Path(args.data) / US3D_FOLDER
        if folder.is_dir():
            report["us3d"] = run_us3d(
                folder, args.methods, args.matchers, presets, cache, args.us3d_crop, args.withhold_labels
            )
            print_us3d(report["us3d"], args.methods, args.matchers)
        else:
            print(f"(skipping US3D: {folder} not found)")
    if args.timing:
        print_timing(Path(args.data), args.timing)
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
