"""Report sections over all pairs together: the headline, the paper's own means, where ours
does not win, and the pipeline's stage times."""

from __future__ import annotations

import math

import numpy as np

from .common import BASELINE_NAMES, METRICS, PAPER_MEANS, TIE, Entry
from .tables import PairRows, beaters, fmt, md_table, metric


def section_headline(rows: PairRows) -> str:
    """Ours against the best baseline on every pair and metric, with a computed summary.

    Parameters
    ----------
    rows : PairRows
        The summary rows of :func:`~.tables.headline_rows`.

    Returns
    -------
    str
        The markdown section; losses of ours are bold.
    """
    lines = ["## Headline: ours against the best baseline", ""]
    lines.append("Best baseline = the highest of histmatch, meanstd, irmad, zhang, zhong on that metric and pair.")
    header = ["pair"]
    for key in METRICS:
        header += [f"{key.replace('_', ' ')}: ours", "best baseline", "ours - best"]
    table = []
    for label, values in rows:
        row = [label]
        for key in METRICS:
            ours = values[key]["ours"]
            scored = [(values[key][n], n) for n in BASELINE_NAMES if math.isfinite(values[key][n])]
            best, name = max(scored) if scored else (float("nan"), "-")
            diff = ours - best
            row += [fmt(ours), f"{name} {fmt(best)}", f"**{diff:+.3f}**" if diff < -TIE else f"{diff:+.3f}"]
        table.append(row)
    lines += ["", md_table(header, table)]
    lines += ["", headline_summary(rows)]
    return "\n".join(lines)


def headline_summary(rows: PairRows) -> str:
    """One computed paragraph: how often ours wins, the largest loss, histogram matching.

    Parameters
    ----------
    rows : PairRows
        The summary rows of :func:`~.tables.headline_rows`.

    Returns
    -------
    str
        The paragraph.
    """
    cells = wins = 0
    worst = (0.0, "", "", "")
    hist = []
    for label, values in rows:
        for key in METRICS:
            if not math.isfinite(values[key]["ours"]):
                continue
            cells += 1
            found = beaters(values[key], BASELINE_NAMES)
            wins += not found
            if found and found[0][1] > worst[0]:
                worst = (found[0][1], found[0][0], key, label)
            margin = values[key]["histmatch"] - values[key]["ours"]
            if margin > TIE:
                hist.append(f"{label} {key.replace('_', ' ')} (+{margin:.3f})")
    text = f"Ours is at least as good as every baseline in {wins} of {cells} pair-metric cells."
    if worst[1]:
        text += (f" The largest loss: {worst[1]} beats ours by {worst[0]:.3f} on {worst[2].replace('_', ' ')} "
                 f"({worst[3]}).")
    if hist:
        text += f" Plain histogram matching beats ours on {len(hist)} cells: {', '.join(hist)}."
    else:
        text += " Plain histogram matching never beats ours."
    return text


def section_paper(rows: PairRows) -> str:
    """The paper's means (Tables 1-2) beside this report's, for the methods both have.

    Parameters
    ----------
    rows : PairRows
        The summary rows of :func:`~.tables.headline_rows`.

    Returns
    -------
    str
        The markdown section.
    """
    lines = ["## Beside the paper's own means", ""]
    lines.append(
        "**The data differ**: the paper measures 9 building objects of its own WorldView-2 / QuickBird and "
        "BJ-2 pairs (not public); the rows below are this report's pairs, with this project's "
        "reconstructions of Zhang's and Zhong's methods and its own matcher. Only the direction and size "
        "of the gaps can be compared, not the values. Rate = mean over the objects, as the paper's Table 2."
    )
    names = ("original", "zhang", "zhong", "ours")
    header = ["data", *[f"C {n}" for n in names], *[f"rate {n}" for n in names]]
    table = [["paper (Tables 1-2)", *[fmt(PAPER_MEANS["similarity"][n]) for n in names],
              *[fmt(PAPER_MEANS["object_rate"][n]) for n in names]]]
    for label, values in rows:
        table.append([label, *[fmt(values["similarity"][n]) for n in names], *[fmt(values["object_rate"][n]) for n in names]])
    lines += ["", md_table(header, table)]
    return "\n".join(lines)


def section_losses(rows: PairRows, demo: dict[str, list[Entry]], object_entries: list[Entry]) -> str:
    """Computed: every method that beats ours, per pair and metric; per object too.

    Parameters
    ----------
    rows : PairRows
        The summary rows of :func:`~.tables.headline_rows`.
    demo : dict of str to list of Entry
        The synthetic pairs per scenario (to count the seeds on which a method wins).
    object_entries : list of Entry
        The pairs whose objects are counted one by one.

    Returns
    -------
    str
        The markdown section.
    """
    candidates = ("original", *BASELINE_NAMES)
    lines = ["## Where ours does not win", ""]
    lines.append(
        "Computed from the numbers above: for each pair and metric, every method (the original pair "
        "included) whose value is higher than ours by more than 0.0005, with the margin. For the demo "
        "scenarios the value is the mean over the seeds, and \"k/n\" counts the seeds on which the "
        "method beats ours."
    )
    header = ["pair", *[METRICS[k][0] for k in METRICS]]
    table = []
    seed_entries = {f"demo {s} (mean of {len(e)})": e for s, e in demo.items()}
    for label, values in rows:
        row = [label]
        for key in METRICS:
            found = beaters(values[key], candidates)
            cells = []
            for name, margin in found:
                text = f"{name} +{margin:.3f}"
                if label in seed_entries:
                    per_seed = seed_entries[label]
                    wins = sum(
                        metric(e.comparison.method(name), key) > metric(e.comparison.method("ours"), key) + TIE
                        for e in per_seed
                    )
                    text += f" ({wins}/{len(per_seed)})"
                cells.append(text)
            row.append(", ".join(cells) if cells else "none: ours is best")
        table.append(row)
    lines += ["", md_table(header, table, numbers=False)]
    lines += ["", "Per object (each pair with per-object tables, and the first seed of each demo scenario):", ""]
    header = ["pair", "objects", "ours best C", "ours best rate", "histmatch beats ours: C / rate",
              "largest per-object rate loss of ours"]
    table = []
    for entry in object_entries:
        comparison = entry.comparison
        ids = [ref_id for ref_id, _ in comparison.object_pairs]
        best_c = best_r = hist_c = hist_r = 0
        worst = (0.0, "-", "-")
        for i in ids:
            c = {n: comparison.method(n).similarity.get(i, np.nan) for n in candidates + ("ours",)}
            r = {n: comparison.method(n).object_rates.get(i, np.nan) for n in candidates + ("ours",)}
            best_c += not beaters(c, candidates)
            best_r += not beaters(r, candidates)
            hist_c += c["histmatch"] > c["ours"] + TIE
            hist_r += r["histmatch"] > r["ours"] + TIE
            for name, margin in beaters(r, candidates)[:1]:
                if margin > worst[0]:
                    worst = (margin, str(i), name)
        loss = f"object {worst[1]}: {worst[2]} +{worst[0]:.3f}" if worst[1] != "-" else "none"
        table.append([entry.title, str(len(ids)), str(best_c), str(best_r), f"{hist_c} / {hist_r}", loss])
    lines.append(md_table(header, table))
    return "\n".join(lines)


def section_timings(demo: dict[str, list[Entry]], singles: list[Entry]) -> str:
    """Pipeline stage times (s) per pair.

    Parameters
    ----------
    demo : dict of str to list of Entry
        The synthetic pairs per scenario (shown as means over the seeds).
    singles : list of Entry
        The real pairs.

    Returns
    -------
    str
        The markdown section.
    """
    stages = ("association", "uniformity", "global", "refine", "smoothness")
    lines = ["## Pipeline time per stage (s)", ""]
    lines += ["Wall seconds of each stage in this run (see \"What was run\" for the machine and its load); "
              "the objects stage reads the given labels and takes no time.", ""]
    rows = []
    for scenario, entries in demo.items():
        rows.append([f"demo {scenario} (mean)", *[fmt(float(np.mean([e.timings.get(s, 0.0) for e in entries])), 2) for s in stages]])
    for entry in singles:
        rows.append([entry.title, *[fmt(entry.timings.get(s, 0.0), 2) for s in stages]])
    lines.append(md_table(["pair", *stages], rows))
    return "\n".join(lines)
