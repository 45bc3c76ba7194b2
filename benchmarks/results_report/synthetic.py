"""Report sections of the synthetic pairs: scenario means, the over-exposed roof, the
per-stage ablation and the stages on every pair."""

from __future__ import annotations

import math

import numpy as np

from .common import ABLATION, ABLATION_LABELS, COMPARED, METRICS, SCENARIOS, TIE, Entry, Settings
from .tables import bold_best, fmt, md_table, seed_mean, stage_values


def section_demo(demo: dict[str, list[Entry]], ceiling: list[Entry], settings: Settings) -> str:
    """Scenario means over seeds, and how the pairs were built.

    Parameters
    ----------
    demo : dict of str to list of Entry
        The synthetic pairs per scenario.
    ceiling : list of Entry
        The same-date, same-sensor pairs, one per seed.
    settings : Settings
        The run's image size and seeds.

    Returns
    -------
    str
        The markdown section.
    """
    lines = ["## Synthetic pairs (demo_data_gen, exact ground truth)", ""]
    lines.append(
        f"Means over seeds {', '.join(map(str, settings.seeds))} (± sample standard deviation over the "
        f"seeds), {settings.size} x {settings.size} px. The column \"same date+sensor\" is the original "
        "pair of scenario `none` (same seed, only the view and the noise draw differ): the ceiling the "
        "normalisation methods try to reach. Bold: best method of the row."
    )
    for key, (label, _) in METRICS.items():
        lines += ["", f"**{label}**", ""]
        header = ["scenario", *COMPARED, "same date+sensor"]
        rows = []
        for scenario, entries in demo.items():
            means = [seed_mean(entries, name, key) for name in COMPARED]
            cells = bold_best([m for m, _ in means])
            cells = [c + (f" ±{s:.3f}" if math.isfinite(s) else "") for c, (_, s) in zip(cells, means)]
            rows.append([scenario, *cells, fmt(seed_mean(ceiling, "original", key)[0])])
        lines.append(md_table(header, rows))
    lines += ["", "**noise ratio** (larger over smaller noise sigma of the two images, "
              "`radcons.noise`; 1 = the same noise level, the aim of the smoothness stage; bold: "
              "closest to 1). The original pair of multi-sensor and mixed holds an 11-bit and an 8-bit image, "
              "so its sigmas are in different units; every method's output is on one range.", ""]
    rows = []
    for scenario, entries in demo.items():
        means = [seed_mean(entries, name, "noise_ratio")[0] for name in COMPARED]
        rows.append([scenario, *bold_best(means, 2, lower=True), fmt(seed_mean(ceiling, "original", "noise_ratio")[0], 2)])
    lines.append(md_table(["scenario", *COMPARED, "same date+sensor"], rows))
    lines += overexposed_table(demo)
    lines += ["", "How the pairs differ (from the generator's metadata):", ""]
    header = ["pair", "target sensor", "target date", "target sun elev.", "gain / gamma", "over-exposed object",
              "objects", "changes (cars moved, building added/removed)"]
    rows = []
    for scenario, entries in demo.items():
        for entry in entries:
            meta = entry.extra["metadata"]
            rows.append([
                entry.title, str(meta.get("target_sensor")), str(meta.get("target_date")),
                f"{meta.get('target_sun_elevation_deg', float('nan')):.0f} deg",
                f"{meta.get('target_gain', float('nan')):.2f} / {meta.get('target_gamma', float('nan')):.2f}",
                str(meta.get("overexposed_object") or "-"), str(len(entry.comparison.object_pairs)),
                f"{meta.get('cars_moved', 0)}, {meta.get('added_building') or '-'}/{meta.get('removed_building') or '-'}",
            ])
    lines.append(md_table(header, rows, numbers=False))
    reference = demo[SCENARIOS[0]][0].extra["metadata"]
    lines += [
        "",
        f"Reference of every pair: {reference.get('reference_sensor')} ({reference.get('reference_bit_depth')}-bit), "
        f"{reference.get('reference_date')}. The rate over all pixels includes the changed areas "
        "(moved cars, added or removed buildings), which no normalisation can match.",
    ]
    return "\n".join(lines)


def overexposed_table(demo: dict[str, list[Entry]]) -> list[str]:
    """Similarity and rate of the over-exposed roof (the paper's Object 1), mean over seeds.

    Parameters
    ----------
    demo : dict of str to list of Entry
        The synthetic pairs per scenario.

    Returns
    -------
    list of str
        Lines of the titled table (one row per scenario with an over-exposed roof); empty
        when no scenario has one.
    """
    rows = []
    for scenario, entries in demo.items():
        values = {}
        for name in COMPARED:
            c, r = [], []
            for entry in entries:
                obj = entry.extra["metadata"].get("overexposed_object")
                result = entry.comparison.method(name)
                if obj and obj in result.similarity:
                    c.append(result.similarity[obj])
                    r.append(result.object_rates.get(obj, np.nan))
            values[name] = (float(np.nanmean(c)) if c else np.nan, float(np.nanmean(r)) if r else np.nan)
        if any(math.isfinite(v[0]) for v in values.values()):
            cells = [f"{fmt(c)} / {fmt(r)}" for c, r in values.values()]
            rows.append([scenario, *cells])
    if not rows:
        return []
    return [
        "", "**The over-exposed roof** (the paper's Object 1; clipped in the target): similarity / "
        "correct-matching rate of that object, mean over the seeds", "",
        md_table(["scenario", *COMPARED], rows),
    ]


def section_ablation(entries: list[Entry]) -> str:
    """Per-stage means on the mixed scenario, with the change each stage brings.

    Parameters
    ----------
    entries : list of Entry
        The seeds of the ``mixed`` scenario.

    Returns
    -------
    str
        The markdown section, with the stages that make a mean worse.
    """
    lines = ["## Per-stage ablation (mixed scenario)", ""]
    lines.append(
        "Each row is the image pair after that stage of one pipeline run (cumulative), means over the seeds; "
        "the change is against the row above."
    )
    header = ["stage"]
    for key in METRICS:
        header += [key.replace("_", " "), "change"]
    rows = []
    previous = None
    for name in ABLATION:
        values = {key: seed_mean(entries, name, key)[0] for key in METRICS}
        row = [ABLATION_LABELS[name]]
        for key in METRICS:
            change = "" if previous is None else f"{values[key] - previous[key]:+.3f}"
            row += [fmt(values[key]), change]
        rows.append(row)
        previous = values
    lines += ["", md_table(header, rows)]
    worse = []
    previous = None
    for name in ABLATION:
        values = {key: seed_mean(entries, name, key)[0] for key in METRICS}
        if previous is not None:
            for key in METRICS:
                if values[key] < previous[key] - TIE:
                    worse.append(f"{ABLATION_LABELS[name].lstrip('+ ')} lowers {key.replace('_', ' ')} by "
                                 f"{previous[key] - values[key]:.3f}")
        previous = values
    if worse:
        lines += ["", "Stages that make a mean worse: " + "; ".join(worse) + "."]
    else:
        lines += ["", "No stage makes a mean worse."]
    return "\n".join(lines)


def section_stages_everywhere(demo: dict[str, list[Entry]], singles: list[Entry]) -> str:
    """Each pair's value after each stage, for the similarity and the all-pixel rate.

    Parameters
    ----------
    demo : dict of str to list of Entry
        The synthetic pairs per scenario (shown as means over the seeds).
    singles : list of Entry
        The real pairs.

    Returns
    -------
    str
        Markdown that continues the ablation section (it starts with an empty line), with
        the stages that lower the all-pixel rate by more than 0.005.
    """
    lines = ["", "The same stages on every pair (demo: mean over the seeds):"]
    for key in ("similarity", "rate"):
        header = ["pair", *[ABLATION_LABELS[name].split(" (")[0] for name in ABLATION]]
        rows = []
        for label, values in stage_values(demo, singles, key):
            rows.append([label, *bold_best([values[n] for n in ABLATION])])
        lines += ["", f"*{METRICS[key][0]}*", "", md_table(header, rows)]
    drops = []
    for label, values in stage_values(demo, singles, "rate"):
        for before, after in zip(ABLATION, ABLATION[1:]):
            change = values[after] - values[before]
            if change < -0.005:
                drops.append(f"{ABLATION_LABELS[after].split(' (')[0].lstrip('+ ')} on {label} ({change:+.3f})")
    lines += ["", "Stages that lower the all-pixel rate by more than 0.005: " + ("; ".join(drops) or "none") + "."]
    return "\n".join(lines)
