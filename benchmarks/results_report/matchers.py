"""The report for several dense matchers: tables side by side, a headline per matcher and
what radiometric consistency buys with each.

Every section is written once per matcher (each entry seen through
:func:`~.common.for_matcher`) and the texts are merged by :func:`side_by_side`: blocks the
matchers share appear once, tables of the same shape show each differing cell as
``SGBM · census``, and other blocks that differ appear once per matcher, named.
"""

from __future__ import annotations

import difflib
import math

import numpy as np

from .common import BASELINE_NAMES, TIE, Entry, for_matcher
from .tables import fmt, headline_rows, md_table

#: Methods of the per-matcher headline, in column order.
HEADLINE = ("original", "best baseline", "paper", "ours")
#: Rates the matcher changes: key -> label (metric keys of :data:`~.common.METRICS`).
RATES = {"rate": "rate, all pixels", "object_rate": "rate, mean over objects"}
#: How the report names each matcher.
TITLES = {"sgbm": "SGBM", "census": "census"}


def title(name: str) -> str:
    """The report's name of matcher ``name``."""
    return TITLES.get(name, name)


#: Between the values of the matchers in a merged table cell.
JOIN = " · "


def side_by_side(texts: dict[str, str]) -> str:
    """Merge one section written once per matcher into one text.

    The texts are compared block by block (blocks are separated by blank lines).

    Parameters
    ----------
    texts : dict of str to str
        Matcher name -> the section as written with that matcher, in the report's order.

    Returns
    -------
    str
        Blocks the matchers share once; tables of the same shape merged cell by cell (in
        a column that differs anywhere, each cell shows every matcher's value joined by
        :data:`JOIN`); other differing blocks once per matcher, named.
    """
    names = list(texts)
    merged = _blocks(texts[names[0]])
    for index, name in enumerate(names[1:], start=1):
        other = _blocks(texts[name])
        out = []
        for tag, a0, a1, b0, b1 in difflib.SequenceMatcher(a=merged, b=other, autojunk=False).get_opcodes():
            if tag == "equal":
                out += merged[a0:a1]
                continue
            out += _merge_region(merged[a0:a1], other[b0:b1], names[0] if index == 1 else None, name)
        merged = out
    return "\n\n".join(merged)


def _merge_region(left: list[str], right: list[str], left_name: str | None, right_name: str) -> list[str]:
    """Blocks that differ: tables of one shape merged in order, everything else named."""
    out, i, j = [], 0, 0
    name_left = (lambda block: _named(left_name, block)) if left_name else (lambda block: [block])
    while i < len(left) or j < len(right):
        if i < len(left) and j < len(right) and _same_shape(left[i], right[j]):
            out.append(_merge_table(left[i], right[j]))
            i, j = i + 1, j + 1
        elif i < len(left) and (_table(left[i]) is None or j >= len(right)):
            out += name_left(left[i])
            i += 1
        elif j < len(right) and (_table(right[j]) is None or i >= len(left)):
            out += _named(right_name, right[j])
            j += 1
        else:  # two tables of different shapes
            out += name_left(left[i]) + _named(right_name, right[j])
            i, j = i + 1, j + 1
    return out


def _blocks(text: str) -> list[str]:
    return [block.strip("\n") for block in text.split("\n\n") if block.strip()]


def _table(block: str) -> list[list[str]] | None:
    lines = block.splitlines()
    if not lines or not all(line.startswith("|") and line.endswith("|") for line in lines):
        return None
    return [[cell.strip() for cell in line.strip("|").split("|")] for line in lines]


def _same_shape(a: str, b: str) -> bool:
    x, y = _table(a), _table(b)
    return x is not None and y is not None and [len(r) for r in x] == [len(r) for r in y] and x[:2] == y[:2]


def _merge_table(a: str, b: str) -> str:
    x, y = _table(a), _table(b)
    differs = [any(rx[c] != ry[c] for rx, ry in zip(x, y)) for c in range(len(x[0]))]
    rows = []
    for r, (rx, ry) in enumerate(zip(x, y)):
        cells = [f"{cx}{JOIN}{cy}" if differs[c] and c > 0 and r > 1 else cx for c, (cx, cy) in enumerate(zip(rx, ry))]
        rows.append("| " + " | ".join(cells) + " |")
    return "\n".join(rows)


def _named(name: str, block: str) -> list[str]:
    if block.startswith("#"):
        first, _, rest = block.partition("\n")
        return [f"{first} ({title(name)})" + (f"\n{rest}" if rest else "")]
    if _table(block) is not None:
        return [f"*{title(name)}:*", block]
    return [f"*{title(name)}:* {block}"]


def matcher_rows(demo: dict[str, list[Entry]], singles: list[Entry], name: str) -> list[tuple[str, dict]]:
    """Per pair (demo: mean over seeds), per rate: original, best baseline, paper, ours.

    Parameters
    ----------
    demo : dict of str to list of Entry
        The synthetic pairs per scenario.
    singles : list of Entry
        The real pairs.
    name : str
        The matcher.

    Returns
    -------
    list of (str, dict)
        Pair label, then rate key -> {method: value, "best baseline name": name}.
    """
    seen_demo = {scenario: [for_matcher(e, name) for e in entries] for scenario, entries in demo.items()}
    seen_singles = [for_matcher(e, name) for e in singles]
    rows = headline_rows(seen_demo, seen_singles, ("original", *BASELINE_NAMES, "paper", "ours"), RATES)
    out = []
    for label, values in rows:
        for key, by_method in values.items():
            scored = [(by_method[n], n) for n in BASELINE_NAMES if math.isfinite(by_method[n])]
            best, best_name = max(scored) if scored else (float("nan"), "-")
            by_method["best baseline"], by_method["best baseline name"] = best, best_name
        out.append((label, values))
    return out


def section_matcher_headline(rows: dict[str, list[tuple[str, dict]]]) -> str:
    """One headline table per matcher: original, best baseline, paper and ours per pair.

    Parameters
    ----------
    rows : dict
        Matcher name -> the rows of :func:`matcher_rows`.

    Returns
    -------
    str
        The markdown section.
    """
    lines = ["## Headline per matcher: correct-matching rate (|d - d_gt| < 1 px)", ""]
    lines.append(
        "The same images matched by each dense matcher: OpenCV SGBM, and census + SGM by CNES Pandora "
        "(the matcher of CNES' CARS pipeline). Best baseline = the highest of "
        f"{', '.join(BASELINE_NAMES)} on that pair and rate."
    )
    for name, table_rows in rows.items():
        header = ["pair"] + [f"{RATES[k]}: {m}" for k in RATES for m in HEADLINE]
        table = []
        for label, values in table_rows:
            row = [label]
            for key in RATES:
                v = values[key]
                row += [fmt(v["original"]), f"{v['best baseline name']} {fmt(v['best baseline'])}", fmt(v["paper"]), fmt(v["ours"])]
            table.append(row)
        lines += ["", f"**{title(name)}**", "", md_table(header, table)]
    return "\n".join(lines)


def section_consistency_buys(rows: dict[str, list[tuple[str, dict]]]) -> str:
    """What radiometric consistency buys with each matcher: computed gains and the best preset.

    Parameters
    ----------
    rows : dict
        Matcher name -> the rows of :func:`matcher_rows`.

    Returns
    -------
    str
        The markdown section: per matcher and rate, the mean over the pairs of the
        original rate and of each normalisation's gain over it, then computed sentences.
    """
    lines = ["## What consistency buys with each matcher", ""]
    lines.append(
        "Gain = rate of the normalised pair minus rate of the pair as given, mean over the report's pairs "
        "(demo scenarios as their seed means, then each real pair)."
    )
    header = ["matcher", "rate", "pairs", "original", "best baseline - original", "paper - original", "ours - original"]
    table, sentences = [], []
    means: dict[str, dict[str, dict[str, float]]] = {}
    for name, table_rows in rows.items():
        means[name] = {}
        for key in RATES:
            got = {m: np.array([v[key][m] for _, v in table_rows], float) for m in HEADLINE}
            ok = np.all([np.isfinite(a) for a in got.values()], axis=0)
            mean = {m: float(a[ok].mean()) if ok.any() else float("nan") for m, a in got.items()}
            means[name][key] = mean
            table.append([
                title(name), RATES[key], str(int(ok.sum())), fmt(mean["original"]),
                *[f"{mean[m] - mean['original']:+.3f}" for m in ("best baseline", "paper", "ours")],
            ])
    lines += ["", md_table(header, table), ""]
    for name, by_key in means.items():
        rate = by_key["rate"]
        better = "paper" if rate["paper"] > rate["ours"] else "ours"
        other = "ours" if better == "paper" else "paper"
        sentences.append(
            f"- {title(name)}: the pair as given matches {fmt(rate['original'])} of its pixels on average; "
            f"ours changes that by {rate['ours'] - rate['original']:+.3f}, paper by "
            f"{rate['paper'] - rate['original']:+.3f}, the best baseline by {rate['best baseline'] - rate['original']:+.3f}. "
            f"The better preset with {title(name)} is `{better if better == 'paper' else 'ours'}` "
            f"({fmt(rate[better])} against {fmt(rate[other])} for `{other}`)."
        )
    for name, table_rows in rows.items():
        idle = [
            b for b in BASELINE_NAMES
            if all(abs(v[k][b] - v[k]["original"]) <= TIE for _, v in table_rows for k in RATES if math.isfinite(v[k][b]))
        ]
        if idle:
            sentences.append(
                f"- With {title(name)}, {', '.join(idle)} leave every rate of the pair as given unchanged "
                f"(within {TIE:g}): on these pairs they are increasing maps of the target's grey levels, "
                "which change no census description." if name == "census" else
                f"- With {title(name)}, {', '.join(idle)} leave every rate of the pair as given unchanged (within {TIE:g})."
            )
    names = list(means)
    if len(names) > 1:
        first, second = names[0], names[1]
        a, b = means[first]["rate"], means[second]["rate"]
        sentences.append(
            f"- The pair as given matches {b['original'] - a['original']:+.3f} better with {title(second)} than with "
            f"{title(first)}; ours with {title(first)} reaches {fmt(a['ours'])}, the pair as given with "
            f"{title(second)} {fmt(b['original'])}."
        )
        best = {n: ("paper" if means[n]["rate"]["paper"] > means[n]["rate"]["ours"] else "ours") for n in names}
        if len(set(best.values())) > 1:
            sentences.append(
                "- **The best preset differs by matcher**: "
                + "; ".join(f"{title(n)}: `{best[n]}`" for n in names)
                + " (rates above)."
            )
        else:
            sentences.append(f"- The same preset, `{best[first]}`, is the better one with every matcher.")
    return "\n".join(lines + sentences)
