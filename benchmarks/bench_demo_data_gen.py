"""Time the synthetic stereo pair generator.

Prints, for each size and scenario, the median wall-clock and CPU time of ``generate``
over several runs, and the ratio of each scenario's CPU time to that of the "none"
scenario of the same size (the reference measured in the same process: "none" renders one
scene and one sun, the others add a second date and/or a second sensor). CPU time is the
process time of all threads; on a busy machine it is steadier than wall time and close to
what an idle machine takes.

Usage::

    python benchmarks/bench_demo_data_gen.py [--sizes 512 1024 2048] [--runs 3] [--seed 0]
"""

from __future__ import annotations

import argparse
import statistics
import time

from demo_data_gen import SCENARIOS, generate


def measure(size: int, scenario: str, seed: int, runs: int) -> tuple[float, float]:
    """Median wall-clock and CPU seconds of ``generate(size, seed, scenario)``."""
    wall, cpu = [], []
    for _ in range(runs):
        start_wall, start_cpu = time.perf_counter(), time.process_time()
        generate(size, seed, scenario)
        wall.append(time.perf_counter() - start_wall)
        cpu.append(time.process_time() - start_cpu)
    return statistics.median(wall), statistics.median(cpu)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[512, 1024, 2048])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    generate(64, args.seed, "mixed")  # imports, first-call set-up
    print(f"median of {args.runs} runs, seed {args.seed}; ratio = cpu / cpu of 'none' at the same size")
    print(f"{'size':>6} {'scenario':<15} {'wall s':>8} {'cpu s':>8} {'ratio':>6}")
    for size in args.sizes:
        base = None
        for scenario in SCENARIOS:
            wall, cpu = measure(size, scenario, args.seed, args.runs)
            base = cpu if base is None else base
            print(f"{size:>6} {scenario:<15} {wall:>8.3f} {cpu:>8.3f} {cpu / base:>6.2f}")


if __name__ == "__main__":
    main()
