"""Cost of recording a run to rerun, against the cost of the run itself.

A demo pair (``mixed`` scenario) is processed by the full pipeline (the reference: median of
``--runs`` runs, each on a fresh pipeline so nothing is cached) and compared by dense
matching for ``original`` and ``ours``; then the finished run and its comparison are logged
``--repeat`` times:

* ``log_run`` to an in-memory recording (the logging itself: previews, class images, error
  maps, markdown, arrow conversion, encoding);
* ``save_recording`` to an ``.rrd`` file (the same plus the blueprint and writing the file);
* ``save_recording`` with a stage matcher, as ``radcons process --rrd F --matcher M`` does:
  every image stage's pair matched densely (SGBM, then census) and logged with its error
  map and rates; the matching of the stages (``review_stages``) is also timed alone.
  Census' first call in the process (numba's compile) is made before the timing.

Prints a table of medians and of their ratios to the pipeline run, and the file size.
The target of the recorder: well under 10% of the run at 1024 x 1024.

Usage::

    python benchmarks/bench_record.py [--size 1024] [--runs 1] [--repeat 5] [--seed 0]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import rerun as rr

from demo_data_gen import generate
from radcons.numerics.census import CensusParams, census_disparity
from radcons.evaluate.matching import MatcherParams
from radcons.pipeline import Pipeline
from radcons.record import log_run, save_recording
from radcons.record.stage_review import review_stages
from radcons.workflow import evaluate_run


def median_seconds(function, repeat: int) -> float:
    """Median wall time of ``repeat`` calls of ``function``."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1024, help="image side in pixels (default 1024)")
    parser.add_argument("--seed", type=int, default=0, help="demo pair seed (default 0)")
    parser.add_argument("--runs", type=int, default=1, help="pipeline runs timed (default 1: minutes at 1024)")
    parser.add_argument("--repeat", type=int, default=5, help="recordings timed (default 5)")
    parser.add_argument("--stage-repeat", type=int, default=3, help="recordings with stage disparity timed (default 3)")
    args = parser.parse_args()

    pair = generate(size=args.size, seed=args.seed, scenario="mixed")
    runs = []

    def process() -> None:
        runs.append(Pipeline().run(pair))

    run_seconds = median_seconds(process, args.runs)
    run = runs[-1]
    comparison = evaluate_run(run, ["original", "ours"])

    def to_memory() -> None:
        recording = rr.RecordingStream("radcons-bench")
        memory = recording.memory_recording()
        log_run(run, recording, comparison)
        recording.flush()
        memory.drain_as_bytes()

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "bench.rrd"
        log_seconds = median_seconds(to_memory, args.repeat)
        save_seconds = median_seconds(lambda: save_recording(run, path, comparison=comparison), args.repeat)
        size_mb = path.stat().st_size / 1e6
        census_disparity(*run.images("original"), (0, 15))  # numba's compile, outside the timings
        stage_rows = []
        for name, matcher in (("sgbm", MatcherParams()), ("census", CensusParams())):
            review = median_seconds(lambda: review_stages(run, matcher), args.stage_repeat)
            total = median_seconds(lambda: save_recording(run, path, matcher=matcher), args.stage_repeat)
            stage_rows += [(f"  review_stages ({name})", review), (f"save_recording --matcher {name}", total)]

    print(f"demo pair {args.size} x {args.size} (mixed, seed {args.seed}); "
          f"medians of {args.runs} run(s) / {args.repeat} recordings / {args.stage_repeat} with the "
          f"{len(run.image_stages)} stages matched")
    print(f"{'what':<34}{'median s':>10}{'/ run':>9}")
    print(f"{'pipeline run (reference)':<34}{run_seconds:>10.3f}{1.0:>9.3f}")
    for name, seconds in (("log_run to memory", log_seconds), ("save_recording to .rrd", save_seconds), *stage_rows):
        print(f"{name:<34}{seconds:>10.3f}{seconds / run_seconds:>9.3f}")
    print(f".rrd size: {size_mb:.1f} MB; stage timings of the last run: "
          + ", ".join(f"{name} {seconds:.2f}s" for name, seconds in run.timings.items()))


if __name__ == "__main__":
    main()
