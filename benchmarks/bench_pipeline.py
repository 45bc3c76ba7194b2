"""Pipeline timings: the illumination chain and a re-run after one parameter changes.

Prints a table of medians over several runs on a demo pair (1024 px by default):

* the whole illumination chain (objects, association, uniformity, global, refine) through
  :class:`radcons.pipeline.Pipeline` with an empty cache, per preset;
* the same pipeline re-run after a change of the uniformity mu or zeta only (the stages
  upstream of it come from the cache), as the inspector does on a slider change.

Run: ``.venv/bin/python benchmarks/bench_pipeline.py [--size 1024] [--runs 5]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from demo_data_gen import generate
from radcons.params import Params
from radcons.pipeline import Pipeline


def chain_seconds(pair, params: Params, runs: int) -> list[float]:
    """Cold runs of the chain up to refine, a new pipeline (empty cache) each time."""
    out = []
    for _ in range(runs):
        start = time.perf_counter()
        Pipeline(params).run(pair, until="refine")
        out.append(time.perf_counter() - start)
    return out


def rerun_seconds(pair, params: Params, runs: int) -> list[float]:
    """Re-runs after alternating mu / zeta changes, on a warm pipeline."""
    pipeline = Pipeline(params)
    pipeline.run(pair, until="refine")
    out = []
    for index in range(runs):
        changed = params.with_stage("uniformity", mu=0.1 + 0.01 * (index + 1), zeta=0.8 - 0.01 * (index % 2))
        start = time.perf_counter()
        pipeline.run(pair, changed, until="refine")
        out.append(time.perf_counter() - start)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    pair = generate(size=args.size, seed=0, scenario="mixed")
    # the segmentation is part of the chain: do not use the demo's own labels
    paper = Params().with_stage("objects", use_supplied=False)
    radcons = Params.from_preset("radcons").with_stage("objects", use_supplied=False).with_stage("uniformity", enabled=True)
    rows = []
    for name, params in (("paper", paper), ("radcons (uniformity on)", radcons)):
        cold = statistics.median(chain_seconds(pair, params, args.runs))
        warm = statistics.median(rerun_seconds(pair, params, args.runs))
        rows.append((name, cold, warm, warm / cold))
    print(f"\n## pipeline, demo 'mixed' {args.size} px, median of {args.runs}, load {os.getloadavg()[0]:.1f}\n")
    print("| preset | chain to refine, cold (s) | re-run after mu/zeta change (s) | ratio |")
    print("|---|---|---|---|")
    for name, cold, warm, ratio in rows:
        print(f"| {name} | {cold:.3f} | {warm:.3f} | {ratio:.2f} |")


if __name__ == "__main__":
    main()
