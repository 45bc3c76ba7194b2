"""``benchmarks/bench_generalisation.py --versus``: ours minus a variant, pair-seed by pair-seed."""

from __future__ import annotations

import math
import statistics
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from bench_generalisation import VERSUS, paired_differences  # noqa: E402


def test_paired_differences_match_a_direct_mean_and_standard_error():
    rates = {  # (pair, seed) -> kind, ours, the variant
        ("cones", 4): ("light", 0.80, 0.78), ("demo", 4): ("light", 0.70, 0.69), ("motorcycle", 4): ("light", 0.75, 0.75),
        ("cones", 5): ("shadows", 0.60, 0.61), ("demo", 5): ("shadows", 0.65, 0.62),
    }
    records = []
    for (pair, seed), (kind, ours, other) in rates.items():
        for method, rate in (("radcons", ours), (VERSUS, other), ("histmatch", 0.1)):
            records.append({"pair": pair, "seed": seed, "kind": kind, "method": method, "matcher": "sgbm", "rate1": rate})
    # a pair-seed the variant lacks, and another matcher's record: both left out
    records.append({"pair": "cones", "seed": 6, "kind": "clipping", "method": "radcons", "matcher": "sgbm", "rate1": 0.9})
    records.append({"pair": "cones", "seed": 4, "kind": "light", "method": VERSUS, "matcher": "census", "rate1": 0.0})
    out = paired_differences(records, "sgbm")
    assert list(out) == ["light", "shadows", "all"]
    for kind, keys in (("light", [("cones", 4), ("demo", 4), ("motorcycle", 4)]),
                       ("shadows", [("cones", 5), ("demo", 5)]), ("all", list(rates))):
        differences = [rates[k][1] - rates[k][2] for k in keys]
        mean, se, n = out[kind]
        assert n == len(keys)
        assert mean == pytest.approx(statistics.mean(differences))
        assert se == pytest.approx(statistics.stdev(differences) / math.sqrt(len(differences)))
