"""Baselines on real stereo pairs with ground truth and a simulated date/sensor difference.

For Middlebury Cones (from the shared data folder) and Middlebury Motorcycle (scikit-image)
the target is degraded (gamma, gain, offset, one saturated object, blur, noise: see
``DEGRADATION``), every registered baseline normalises it to the reference, and the
comparison machinery measures eq 20 object similarity, the correct-matching rate of SGBM
(|d - d_gt| < 1 px, all pixels with ground truth and per object) and the noise ratio for
"undegraded" (the real pair as it is), "original" (the degraded pair) and each baseline. It
prints the tables, then the baselines' run times (median of ``--repeat`` runs) as ratios to
histogram matching measured in the same process.

Usage::

    python benchmarks/bench_baselines.py [--data ../shared/data] [--repeat 5] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from pathlib import Path

from radcons.baselines import BASELINES
from radcons.evaluate.compare import baseline_images, evaluate_methods
from radcons.evaluate.simulate import Degradation, degrade
from radcons.evaluate.truth_pairs import load_cones, load_motorcycle

#: The simulated second date / second sensor of the target.
DEGRADATION = Degradation(
    gamma=0.6, gain=0.85, offset=15.0, saturate_label=3, saturate_factor=1.6,
    blur_sigma=1.0, noise_sigma=4.0, seed=0,
)


def degraded(pair):
    """The pair with its target degraded by :data:`DEGRADATION` (objects 3 saturated)."""
    target = degrade(pair.target.as_float32(), DEGRADATION, labels=pair.target_objects)
    return pair.with_images(pair.reference.as_float32(), target)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    shared = Path(__file__).resolve().parents[2] / "shared" / "data"
    default_data = os.environ.get("RADCONS_DATA", str(shared))
    parser.add_argument("--data", default=default_data, help="shared data folder (holds middlebury_cones/)")
    parser.add_argument("--repeat", type=int, default=5, help="timing repeats per baseline")
    parser.add_argument("--json", help="also write the measurements as JSON here")
    args = parser.parse_args()

    pairs = []
    cones_dir = Path(args.data) / "middlebury_cones"
    if cones_dir.is_dir():
        pairs.append(load_cones(cones_dir))
    else:
        print(f"(skipping Cones: {cones_dir} not found)")
    pairs.append(load_motorcycle())

    print(f"degradation of the target: {DEGRADATION}\n")
    report = {}
    for clean in pairs:
        pair = degraded(clean)
        seconds: dict[str, float] = {}
        images = {
            "undegraded": (clean.reference.as_float32(), clean.target.as_float32()),
            "original": (pair.reference.as_float32(), pair.target.as_float32()),
        }
        images.update(baseline_images(pair, list(BASELINES), seconds))
        comparison = evaluate_methods(pair, images, normalise_seconds=seconds)
        report[pair.name] = comparison.to_json_dict()
        print(comparison.format_table())

        reference, target = images["original"]
        times = {}
        for name, method in BASELINES.items():
            runs = []
            for _ in range(args.repeat):
                start = time.perf_counter()
                method(reference, target)
                runs.append(time.perf_counter() - start)
            times[name] = statistics.median(runs)
        print(f"\nbaseline run time on {pair.name} {pair.shape}, median of {args.repeat}")
        print(f"{'baseline':<12}{'ms':>10}{'x histmatch':>14}")
        for name, value in times.items():
            print(f"{name:<12}{value * 1e3:>10.1f}{value / times['histmatch']:>14.2f}")
        print("\n" + "=" * 78 + "\n")
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
