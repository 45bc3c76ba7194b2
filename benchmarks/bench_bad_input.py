"""Every bad input of the command line: what the user sees, the exit code, the time to it.

Runs each case of ``tests/test_bad_input.py`` (the table-driven bad-input suite) through
the real ``radcons`` command in a subprocess and prints one row per case: the exit code, the
one line on stderr, the wall time from start to exit (Python start-up and imports included)
and whether every input file is byte-identical afterwards.

Usage::

    python benchmarks/bench_bad_input.py [--markdown]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_bad_input import CASES, _digests, radcons  # noqa: E402


def run_case(case) -> tuple[int, str, float, bool]:
    """Run one case in a fresh folder: exit code, stderr's last line, seconds, inputs unchanged."""
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        args, _, _ = case(root)
        before = _digests(root)
        start = time.perf_counter()
        result = radcons(*args)
        seconds = time.perf_counter() - start
        after = {path: digest for path, digest in _digests(root).items() if path in before}
        lines = result.stderr.strip().splitlines()
        return result.returncode, lines[-1] if lines else "", seconds, after == before


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--markdown", action="store_true", help="print a markdown table")
    args = parser.parse_args()
    rows = []
    for case in CASES:
        code, line, seconds, unchanged = run_case(case)
        rows.append((case.__name__, code, seconds, "yes" if unchanged else "NO", line))
    if args.markdown:
        print("| input | exit | time (s) | inputs unchanged | message |")
        print("| --- | --- | --- | --- | --- |")
        for name, code, seconds, unchanged, line in rows:
            print(f"| {name} | {code} | {seconds:.2f} | {unchanged} | {line.replace('|', '/')} |")
        return
    width = max(len(row[0]) for row in rows)
    print(f"{'input':<{width}}  exit  time (s)  unchanged  message")
    for name, code, seconds, unchanged, line in rows:
        print(f"{name:<{width}}  {code:>4}  {seconds:8.2f}  {unchanged:>9}  {line}")


if __name__ == "__main__":
    main()
