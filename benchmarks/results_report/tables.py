"""Markdown tables and the numbers they show: metrics, seed means, the best method, the
methods that beat ours."""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from radcons.evaluate.compare import Comparison, MethodResult
from radcons.io import Pair

from .common import ABLATION, BASELINE_NAMES, METRICS, TIE, Entry

#: One row per pair of the summary tables: its label, then metric -> method -> value.
PairRows = list[tuple[str, dict[str, dict[str, float]]]]

# ----------------------------------------------------------------------------- formatting


def fmt(value: float | None, digits: int = 3) -> str:
    """A number for a table, ``-`` when undefined.

    Parameters
    ----------
    value : float or None
        The number.
    digits : int
        Decimals shown.

    Returns
    -------
    str
        The number with ``digits`` decimals, or ``-`` for None, NaN and infinities.
    """
    if value is None or not math.isfinite(value):
        return "-"
    return f"{value:.{digits}f}"


def bold_best(values: list[float], digits: int = 3, lower: bool = False) -> list[str]:
    """Format a row, bolding the largest (``lower``: smallest) value(s), ties at the shown precision.

    Parameters
    ----------
    values : list of float
        The row's numbers; NaN cells are shown as ``-`` and never bold.
    digits : int
        Decimals shown.
    lower : bool
        Bold the smallest value instead of the largest.

    Returns
    -------
    list of str
        One cell per value.
    """
    finite = [v for v in values if math.isfinite(v)]
    best = (min(finite) if lower else max(finite)) if finite else float("nan")
    tie = 0.5 * 10.0**-digits
    out = []
    for v in values:
        text = fmt(v, digits)
        out.append(f"**{text}**" if math.isfinite(v) and abs(v - best) <= tie else text)
    return out


def md_table(header: list[str], rows: list[list[str]], numbers: bool = True) -> str:
    """A markdown table, first column left-aligned, the others right-aligned (numbers) or left.

    Parameters
    ----------
    header : list of str
        Column titles.
    rows : list of list of str
        The cells, one list per row.
    numbers : bool
        Right-align every column but the first (else left-align them).

    Returns
    -------
    str
        The table, without a trailing newline.
    """
    align = "--:" if numbers else ":--"
    lines = ["| " + " | ".join(header) + " |", "| " + " | ".join([":--"] + [align] * (len(header) - 1)) + " |"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


# ----------------------------------------------------------------------------- numbers


def metric(result: MethodResult, key: str) -> float:
    """The value of summary metric ``key`` (or ``"noise_ratio"``) for one method (NaN when undefined).

    Parameters
    ----------
    result : MethodResult
        One method's measures on one pair.
    key : str
        A key of :data:`~.common.METRICS`, or a ``MethodResult`` attribute.

    Returns
    -------
    float
        The value, NaN when undefined.
    """
    value = getattr(result, METRICS[key][1] if key in METRICS else key)
    return float("nan") if value is None else float(value)


def seed_mean(entries: list[Entry], method: str, key: str) -> tuple[float, float]:
    """Mean and sample standard deviation of a metric over the entries (seeds).

    Parameters
    ----------
    entries : list of Entry
        The seeds of one scenario.
    method : str
        The method's name.
    key : str
        The metric, as for :func:`metric`.

    Returns
    -------
    mean, std : float
        Over the finite values; NaN when there are none (std: fewer than two).
    """
    values = np.array([metric(e.comparison.method(method), key) for e in entries], float)
    values = values[np.isfinite(values)]
    if values.size == 0:
        return float("nan"), float("nan")
    return float(values.mean()), float(values.std(ddof=1)) if values.size > 1 else float("nan")


def scenario_values(entries: list[Entry], key: str, methods: tuple[str, ...]) -> dict[str, float]:
    """Seed means of one metric for each method.

    Parameters
    ----------
    entries : list of Entry
        The seeds of one scenario.
    key : str
        The metric, as for :func:`metric`.
    methods : tuple of str
        The methods' names.

    Returns
    -------
    dict of str to float
        Method -> mean over the seeds.
    """
    return {name: seed_mean(entries, name, key)[0] for name in methods}


def best_baseline(comparison: Comparison, key: str) -> tuple[str, float]:
    """The baseline with the highest value of metric ``key``.

    Parameters
    ----------
    comparison : Comparison
        Every method's measures on one pair.
    key : str
        The metric, as for :func:`metric`.

    Returns
    -------
    name : str
        The baseline, ``-`` when none has a value.
    value : float
        Its value, NaN when none has one.
    """
    scored = [(metric(comparison.method(name), key), name) for name in BASELINE_NAMES]
    scored = [(v, n) for v, n in scored if math.isfinite(v)]
    if not scored:
        return "-", float("nan")
    value, name = max(scored)
    return name, value


def beaters(values: dict[str, float], candidates: tuple[str, ...]) -> list[tuple[str, float]]:
    """Methods whose value beats ``values["ours"]`` by more than a tie, largest margin first.

    Parameters
    ----------
    values : dict of str to float
        Method -> value, ``ours`` included.
    candidates : tuple of str
        The methods that may beat ours.

    Returns
    -------
    list of (str, float)
        Each beating method with its margin; empty when ours is undefined.
    """
    ours = values["ours"]
    if not math.isfinite(ours):
        return []
    out = [(n, values[n] - ours) for n in candidates if math.isfinite(values.get(n, np.nan)) and values[n] > ours + TIE]
    return sorted(out, key=lambda item: -item[1])


def headline_rows(
    demo: dict[str, list[Entry]],
    singles: list[Entry],
    methods: tuple[str, ...] = ("original", *BASELINE_NAMES, "ours"),
    keys: Iterable[str] = METRICS,
) -> PairRows:
    """Per pair (scenario means, then each real pair): metric -> method -> value.

    Parameters
    ----------
    demo : dict of str to list of Entry
        The synthetic pairs per scenario.
    singles : list of Entry
        The real pairs.
    methods : tuple of str
        The methods measured (default: the original, the baselines and ours).
    keys : iterable of str
        The metrics, as for :func:`metric` (default every metric of :data:`~.common.METRICS`).

    Returns
    -------
    PairRows
    """
    out = []
    for scenario, entries in demo.items():
        out.append((f"demo {scenario} (mean of {len(entries)})", {k: scenario_values(entries, k, methods) for k in keys}))
    for entry in singles:
        out.append((entry.title, {k: {n: metric(entry.comparison.method(n), k) for n in methods} for k in keys}))
    return out


def stage_values(demo: dict[str, list[Entry]], singles: list[Entry], key: str) -> list[tuple[str, dict[str, float]]]:
    """Per pair (demo: mean over seeds), the value of ``key`` after each stage.

    Parameters
    ----------
    demo : dict of str to list of Entry
        The synthetic pairs per scenario.
    singles : list of Entry
        The real pairs.
    key : str
        The metric, as for :func:`metric`.

    Returns
    -------
    list of (str, dict of str to float)
        Pair label, then stage of :data:`~.common.ABLATION` -> value.
    """
    out = [(f"demo {s}", {n: seed_mean(e, n, key)[0] for n in ABLATION}) for s, e in demo.items()]
    out += [(e.title, {n: metric(e.comparison.method(n), key) for n in ABLATION}) for e in singles]
    return out


def object_sizes(pair: Pair) -> dict[int, int]:
    """Pixel count of every reference object.

    Parameters
    ----------
    pair : Pair
        A pair with reference objects (0 = background).

    Returns
    -------
    dict of int to int
        Object label -> pixels.
    """
    ids, counts = np.unique(pair.reference_objects[pair.reference_objects > 0], return_counts=True)
    return {int(i): int(c) for i, c in zip(ids, counts)}
