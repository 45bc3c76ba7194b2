"""The method against the baselines: SGBM correct-matching rate, every pair, every stage.

For each pair (degraded Middlebury Cones and Motorcycle as in ``bench_baselines.py``, the
demo 'mixed' pair at several seeds, the demo 'multi-temporal' and 'multi-sensor' pairs)
it prints the correct-matching rate (|d - d_gt| < 1 px, all pixels with ground truth, one
SGBM matcher and disparity range for every method) of the original pair, each baseline,
each image stage of the ``paper`` preset (its last stage is the paper's method) and each
stage of the ``radcons`` preset (its last is ours). Stages a preset switches off are not
shown.
The last rows give the best baseline and the margin of each preset over it.

Two tables: the project's evaluation (``evaluate_methods``: both images mapped to 8 bits
over their common value range), then the same with both images first mapped to 0..255 by
the *reference's* 0.5-99.5 percentile range and clipped. The first lets a method's
outlying pixels widen the common range and so lower the contrast the matcher sees, which
by itself changes the rate (one pixel widening the range twofold raises histogram
matching's rate on the demo 'mixed' pair from 0.516 to 0.590); the second gives every
method the reference's contrast.

Usage::

    python benchmarks/bench_method.py [--data ../shared/data] [--size 512] [--seeds 0 1 2]
                                      [--pairs cones motorcycle mixed multi-temporal multi-sensor]
                                      [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from bench_baselines import degraded
from demo_data_gen import generate
from radcons.baselines import BASELINES
from radcons.evaluate.compare import baseline_images, evaluate_methods
from radcons.evaluate.truth_pairs import load_cones, load_motorcycle
from radcons.params import Params
from radcons.pipeline import IMAGE_STAGES, Pipeline

PAIRS = ("cones", "motorcycle", "mixed", "multi-temporal", "multi-sensor")


def load_pairs(names, data: Path, size: int, seeds):
    """``(column label, pair)`` for every pair asked for (Cones skipped without its data)."""
    out = []
    for name in names:
        if name == "cones":
            folder = data / "middlebury_cones"
            if folder.is_dir():
                out.append(("cones", degraded(load_cones(folder))))
            else:
                print(f"(skipping Cones: {folder} not found)")
        elif name == "motorcycle":
            out.append(("motorcycle", degraded(load_motorcycle())))
        elif name == "mixed":
            out += [(f"mixed s{seed}", generate(size=size, seed=seed, scenario="mixed")) for seed in seeds]
        else:
            out.append((name, generate(size=size, seed=seeds[0], scenario=name)))
    return out


def reference_range_8bit(images):
    """Each method's images mapped to 0..255 by its reference's 0.5-99.5 percentiles, clipped."""
    out = {}
    for name, (reference, target) in images.items():
        low, high = np.percentile(reference[np.isfinite(reference)], [0.5, 99.5])
        scale = np.float32(255.0 / (high - low))
        out[name] = tuple(np.clip((image - np.float32(low)) * scale, 0.0, 255.0) for image in (reference, target))
    return out


def print_table(title, rates, columns):
    """Rates of every method (rows) on every pair (columns), best baseline and margins."""
    methods = list(rates[columns[0]])
    width = max(12, *(len(c) + 2 for c in columns))
    print(f"\n{title}")
    print("method".ljust(28) + "".join(c.rjust(width) for c in columns))
    for method in methods:
        print(method.ljust(28) + "".join(f"{rates[c][method]:.3f}".rjust(width) for c in columns))
    best = {c: max(rates[c][b] for b in BASELINES) for c in columns}
    print("best baseline".ljust(28) + "".join(f"{best[c]:.3f}".rjust(width) for c in columns))
    finals = [[m for m in methods if m.startswith(f"{preset}:")][-1] for preset in ("paper", "radcons")]
    for method in finals:
        margins = (f"{rates[c][method] - best[c]:+.3f}".rjust(width) for c in columns)
        print(f"{method} - best".ljust(28) + "".join(margins))


def with_mixed_mean(rates):
    """Add a 'mixed mean' column after the demo 'mixed' seeds; return the column order."""
    columns = list(rates)
    mixed = [c for c in columns if c.startswith("mixed s")]
    if len(mixed) > 1:
        rates["mixed mean"] = {m: float(np.mean([rates[c][m] for c in mixed])) for m in rates[mixed[0]]}
        columns.insert(columns.index(mixed[-1]) + 1, "mixed mean")
    return columns


def method_images(pair, stages_of):
    """Every method's ``(reference, target)``: original, baselines, each preset's stages."""
    images = {"original": (pair.reference.as_float32(), pair.target.as_float32())}
    images.update(baseline_images(pair, list(BASELINES)))
    info = {}
    for preset, params in stages_of.items():
        start = time.perf_counter()
        run = Pipeline(params).run(pair)
        info[f"{preset} s"] = time.perf_counter() - start
        for stage in IMAGE_STAGES[1:]:
            if params.enabled(stage):
                images[f"{preset}:{stage}"] = run.images(stage)
        if params.enabled("sharpness"):
            info["relative blur px"] = run.results["sharpness"].info["relative_blur"]
    return images, info


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    shared = Path(__file__).resolve().parents[2] / "shared" / "data"
    parser.add_argument("--data", default=os.environ.get("RADCONS_DATA", str(shared)), help="shared data folder")
    parser.add_argument("--size", type=int, default=512, help="demo pair size, px")
    parser.add_argument(
        "--seeds", type=int, nargs="+", default=[0, 1, 2], help="demo 'mixed' seeds (the first one: the other demos)"
    )
    parser.add_argument("--pairs", nargs="+", default=list(PAIRS), choices=PAIRS)
    parser.add_argument("--json", help="also write the rates as JSON here")
    args = parser.parse_args()

    presets = {"paper": Params.from_preset("paper"), "radcons": Params.from_preset("radcons")}
    rates: dict[str, dict[str, float]] = {}
    robust: dict[str, dict[str, float]] = {}
    extra: dict[str, dict[str, float]] = {}
    for label, pair in load_pairs(args.pairs, Path(args.data), args.size, args.seeds):
        images, info = method_images(pair, presets)
        comparison = evaluate_methods(pair, images, pairs=())
        rates[label] = {m.name: m.correct_rate for m in comparison.methods}
        comparison = evaluate_methods(pair, reference_range_8bit(images), pairs=())
        robust[label] = {m.name: m.correct_rate for m in comparison.methods}
        extra[label] = info
        print(f"{label}: done ({', '.join(f'{k} {v:.2f}' for k, v in info.items())})", flush=True)

    columns = with_mixed_mean(rates)
    with_mixed_mean(robust)
    width = max(12, *(len(c) + 2 for c in columns))
    print_table("correct-matching rate, |d - d_gt| < 1 px, all pixels with ground truth (SGBM)", rates, columns)
    print_table("the same, both images mapped to 8 bits by the reference's 0.5-99.5 % range", robust, columns)
    print()
    keys = sorted({k for info in extra.values() for k in info})
    for key in keys:
        print(key.ljust(28) + "".join(
            (f"{extra[c][key]:.2f}" if c in extra and key in extra[c] else "").rjust(width) for c in columns
        ))
    if args.json:
        report = {"rates": rates, "reference_range_rates": robust, "info": extra}
        Path(args.json).write_text(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
