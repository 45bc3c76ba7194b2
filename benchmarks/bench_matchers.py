"""Dense matchers side by side: census + SGM (Pandora) and OpenCV SGBM, time and memory.

On the demo pair (scenario "none", so both matchers see the same radiometry) at 1024 x 1024
with 64 disparities starting 2 px below the ground truth's smallest, each matcher runs in a
fresh process: its first call (census: Pandora's imports, plugin loading and numba's
compile or cache load) is timed apart, then the median of ``--runs`` calls. Each row gives
the process' peak resident memory (``resource.getrusage``), census' own estimate
(:func:`radcons.numerics.census.census_memory_bytes`) and the correct-matching rate
(|d - d_gt| < 1 px over every pixel with ground truth).

``--median`` adds Pandora's own median filter against the one radcons gives Pandora
(:func:`radcons.numerics.census._median_filter`) on the census disparity of that pair and of its
256 x 256 px reduction (the height method's census grid), in one process, alternating,
with the check that both give the same values.

``--large`` adds the 4096 x 4096 demo pair (one call each; its generation takes about a
minute). Its disparities span about 216 px there: census over that range would need more
memory than most machines have, and is refused with the estimate; it then runs over
``--large-disparities`` disparities from the truth's low end (the rate counts only where
the truth lies in that window), to show how time and memory scale.

Run: ``.venv/bin/python benchmarks/bench_matchers.py [--runs 5] [--median] [--large] [--large-disparities 16]``
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import os
import resource
import statistics
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from radcons.numerics.census import CensusParams, census_memory_bytes
from radcons.errors import RadconsError
from radcons.evaluate.matching import MatcherParams, dense_disparity
from radcons.evaluate.rates import correct_matching_rate

MATCHERS = {"census": CensusParams(), "sgbm": MatcherParams()}


def table(title: str, header: list[str], rows: list[list]) -> None:
    print(f"\n## {title}\n")
    print("| " + " | ".join(header) + " |")
    print("|" + "|".join("---" for _ in header) + "|")
    for row in rows:
        print("| " + " | ".join(str(c) for c in row) + " |", flush=True)


def prepare(size: int, folder: str, queue) -> None:
    """In a fresh process: generate the demo pair, save it, report its truth's range.

    The pair is made apart so that the measuring processes, which start from this one's
    parent, do not inherit a large resident size (``ru_maxrss`` carries over).
    """
    from demo_data_gen import generate

    pair = generate(size=size, seed=0, scenario="none")
    np.save(Path(folder) / "reference.npy", pair.reference.as_float32())
    np.save(Path(folder) / "target.npy", pair.target.as_float32())
    np.save(Path(folder) / "truth.npy", pair.disparity)
    queue.put((float(np.nanmin(pair.disparity)), float(np.nanmax(pair.disparity))))


def measure(folder: str, matcher: str, search: tuple[float, float], runs: int, queue) -> None:
    """In a fresh process: load the pair, time the matcher, report times, memory and rate."""
    reference, target, truth = (np.load(Path(folder) / f"{name}.npy") for name in ("reference", "target", "truth"))
    params = MATCHERS[matcher]
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    seconds = []
    try:
        for _ in range(runs + 1):
            start = time.perf_counter()
            disparity = dense_disparity(reference, target, params, search)
            seconds.append(time.perf_counter() - start)
    except RadconsError as error:
        queue.put({"error": str(error)})
        return
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    inside = (truth >= math.floor(search[0])) & (truth <= math.ceil(search[1]))
    queue.put({
        "first": seconds[0],
        "median": statistics.median(seconds[1:]) if runs else seconds[0],
        "peak": peak,
        "baseline": before,
        "rate": correct_matching_rate(disparity, np.where(inside, truth, np.nan)),
    })


def in_child(function, *args):
    """Run ``function(*args, queue)`` in a fresh process; return what it put on the queue."""
    context = multiprocessing.get_context("spawn")
    queue = context.Queue()
    process = context.Process(target=function, args=(*args, queue))
    process.start()
    result = queue.get()
    process.join()
    return result


def rows_for(folder: str, size: int, label: str, search: tuple[float, float], runs: int) -> list[list]:
    """Both matchers on the saved pair over one disparity range: table rows."""
    rows = []
    disparities = math.ceil(search[1]) - math.floor(search[0]) + 1
    for matcher in MATCHERS:
        estimate = f"{census_memory_bytes((size, size), search) / 2**20:.0f}" if matcher == "census" else "-"
        result = in_child(measure, folder, matcher, search, runs)
        if "error" in result:
            rows.append([matcher, label, disparities, "refused", result["error"], "", "", estimate, ""])
            continue
        rows.append([
            matcher, label, disparities,
            f"{result['first']:.2f}", f"{result['median']:.2f}", runs,
            f"{result['peak'] / 2**20:.0f} ({(result['peak'] - result['baseline']) / 2**20:+.0f})",
            estimate, f"{result['rate']:.3f}",
        ])
        print(f"  done: {matcher} on {label}", flush=True)
    return rows


def median_rows(runs: int) -> list[list]:
    """Pandora's median filter against radcons' on the demo pair's census disparity, 1024 and 256 px."""
    import importlib.util

    import pandora.filter.median
    from pandora.filter import AbstractFilter

    from demo_data_gen import generate
    from radcons.numerics.census import _median_filter, census_disparity
    from radcons.numerics.coarse_disparity import downsample

    registered = dict(AbstractFilter.filter_methods_avail)
    spec = importlib.util.spec_from_file_location("pandora.filter.own_median", pandora.filter.median.__file__)
    own = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(own)  # Pandora's code as shipped; it registers itself again ...
    AbstractFilter.filter_methods_avail.clear()
    AbstractFilter.filter_methods_avail.update(registered)  # ... so the registry is put back
    pair = generate(size=1024, seed=0, scenario="none")
    rows = []
    for factor in (1, 4):
        reference, target = (downsample(image.as_float32(), factor) for image in (pair.reference, pair.target))
        low = math.floor(np.nanmin(pair.disparity) / factor) - 2
        disparity = census_disparity(reference, target, (low, low + max(16, 64 // factor) - 1))
        filter_ = SimpleNamespace(_filter_size=3)
        times: dict[str, list[float]] = {"pandora": [], "radcons": []}
        for _ in range(max(runs, 1)):
            for name, function in (("pandora", own.MedianFilter.median_filter), ("radcons", _median_filter)):
                start = time.perf_counter()
                out = function(filter_, disparity)
                times[name].append(time.perf_counter() - start)
                if name == "pandora":
                    expected = out
        same = np.array_equal(out, expected, equal_nan=True)
        pandora_s, radcons_s = (statistics.median(times[name]) for name in ("pandora", "radcons"))
        side = reference.shape[0]
        rows.append([f"{side} x {side}", f"{pandora_s:.4f}", f"{radcons_s:.4f}", f"{pandora_s / radcons_s:.1f}", same])
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5, help="timed calls after the first, per matcher")
    parser.add_argument("--median", action="store_true", help="also Pandora's median filter against radcons'")
    parser.add_argument("--large", action="store_true", help="also the 4096 x 4096 demo pair (minutes)")
    parser.add_argument("--large-disparities", type=int, default=16, help="census window on the large pair")
    args = parser.parse_args()

    rows = []
    with tempfile.TemporaryDirectory() as folder:
        truth_low, _ = in_child(prepare, 1024, folder)
        low = math.floor(truth_low) - 2
        rows += rows_for(folder, 1024, "demo 1024", (low, low + 63), args.runs)
        if args.large:
            truth_low, truth_high = in_child(prepare, 4096, folder)
            low = math.floor(truth_low) - 2
            rows += rows_for(folder, 4096, "demo 4096, full range", (low, math.ceil(truth_high) + 2), 0)
            window = (low, low + args.large_disparities - 1)
            rows += rows_for(folder, 4096, f"demo 4096, {args.large_disparities} disparities", window, 0)

    header = [
        "matcher", "pair", "disparities", "first call (s)", "median (s)", "runs",
        "peak RSS MiB (run)", "census estimate MiB", "rate < 1 px",
    ]
    table(
        f"dense matchers, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; census: {CensusParams()}",
        header,
        rows,
    )
    if args.median:
        table(
            "3 x 3 median filter of a census disparity (Pandora's step), median of "
            f"{max(args.runs, 1)} s; ratio = Pandora's / radcons'",
            ["disparity map", "Pandora (s)", "radcons (s)", "ratio", "same values"],
            median_rows(args.runs),
        )


if __name__ == "__main__":
    main()
