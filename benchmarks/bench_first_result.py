"""Time to the inspector's first result and to an objects re-tune on raw real pairs.

The pipeline the inspector runs (``radcons`` preset, full resolution, up to its live
stage :data:`inspector.app.LIVE_UNTIL`) on two files as ``radcons inspect A B`` loads
them, then the same pipeline after one rule of the objects stage changed (``tree_texture``
x 1.1), which keeps the rectification and the census matching. Each figure is the median
of ``--repeat`` trials, each on a fresh pipeline, in one process; the first trial also
pays imports and numba's compilation. The page's own drawing is not included.

Run: ``.venv/bin/python benchmarks/bench_first_result.py [--data DIR] [--repeat 3]``
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from inspector.app import LIVE_UNTIL
from radcons.geometry import settle_geometry
from radcons.io import load_pair_files
from radcons.params import Params
from radcons.pipeline import Pipeline

#: Pair name -> its two files under the data folder.
PAIRS = {
    "Kahramanmaras pre1/post2": ("pleiades_kahramanmaras_prepost/pre_event_img1.tif", "pleiades_kahramanmaras_prepost/post_event_img2.tif"),
    "Gizeh": ("pleiades_gizeh/img1.tif", "pleiades_gizeh/img2.tif"),
}


def trial(pair) -> tuple[float, float, dict[str, float]]:
    """Seconds to the first result, to the re-tuned result, and the first run's stage timings."""
    pipeline = Pipeline(Params.from_preset("radcons"))
    start = time.perf_counter()
    run = pipeline.run(pair, until=LIVE_UNTIL)
    first = time.perf_counter() - start
    tuned = run.params.with_stage("objects", tree_texture=run.params.objects.tree_texture * 1.1)
    start = time.perf_counter()
    pipeline.run(pair, tuned, until=LIVE_UNTIL)
    return first, time.perf_counter() - start, dict(run.timings)


def main() -> None:
    """Print one table row per pair."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[2] / "shared" / "data")
    parser.add_argument("--repeat", type=int, default=3, help="trials per pair (median reported)")
    args = parser.parse_args()
    print("| pair | first result, s (median) | trials | objects re-tune, s (median) | slowest stages of trial 1 |")
    print("| --- | --- | --- | --- | --- |")
    for name, (a, b) in PAIRS.items():
        if not (args.data / a).exists():
            print(f"| {name} | absent ({args.data / a}) | | | |")
            continue
        pair = settle_geometry(load_pair_files(args.data / a, args.data / b))
        trials = [trial(pair) for _ in range(args.repeat)]
        firsts = [t[0] for t in trials]
        slowest = sorted(trials[0][2].items(), key=lambda item: -item[1])[:2]
        print(
            f"| {name} | {statistics.median(firsts):.1f} | {', '.join(f'{s:.1f}' for s in firsts)} "
            f"| {statistics.median(t[1] for t in trials):.2f} | {', '.join(f'{k} {v:.2f}' for k, v in slowest)} |"
        )


if __name__ == "__main__":
    main()
