"""Report section "segmented objects": every pair of the report with its labels withheld.

A user without building footprints gets the objects the pipeline segments itself. Every
pair of the report (the demo pairs of each scenario and seed, Cones, Motorcycle and the
Pleiades pair, their targets degraded as in the rest of the report, and the US3D tiles)
is run with the report's preset three times: with the pair's label rasters (as everywhere
else in the report), and with them withheld from the pipeline (``[objects] use_supplied =
false``), its objects segmented by the image-only method (``mbi``) or found from height
(``height``). The pairs keep their labels for the evaluation, so the mean over objects is
measured on the same objects in all three runs; the correct-matching rate over all pixels
does not depend on objects at all.

:func:`segmented_records` runs and measures; :func:`section_segmented` writes the markdown;
:func:`add_to_report` puts both into a written report (``results.md`` before its plots,
``results.json`` under ``segmented_objects``); :func:`write_segmented` does all three.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from bench_baselines import DEGRADATION
from bench_generalisation import US3D_FOLDER
from demo_data_gen import generate
from radcons.evaluate.truth_pairs import load_cones, load_motorcycle, load_us3d, us3d_names
from radcons.io import Pair
from radcons.params import Params
from radcons.pipeline import Pipeline
from radcons.workflow import evaluate_run_matchers

from .common import SCENARIOS, Settings, log
from .matchers import JOIN, title
from .run import degraded_target, pleiades_pair
from .tables import fmt, md_table

#: The runs of each pair: name -> objects method with the labels withheld (None: supplied).
VARIANTS: dict[str, str | None] = {"supplied": None, "mbi": "mbi", "height": "height"}
#: Where the section goes in ``results.md``: before this heading (else at the end).
BEFORE = "## Plots"
#: A rate difference below which ``height`` counts as losing to ``mbi``.
LOSS = 0.01


def report_pairs(settings: Settings) -> list[tuple[str, Pair]]:
    """The report's pairs as its other sections evaluate them: ``(name, pair)``.

    Demo pairs of every scenario and seed; Cones (when the shared data folder holds it),
    Motorcycle and the Pleiades pair (when present) with their targets degraded; the US3D
    tiles as published (real multi-date pairs; not in a quick report, as in its multi-date
    section).

    Parameters
    ----------
    settings : Settings
        The report's image size, seeds, data folder, Motorcycle reduction and Pleiades crop.

    Returns
    -------
    list of (str, Pair)
    """
    pairs = [
        (f"{scenario}, seed {seed}", generate(settings.size, seed, scenario))
        for scenario in SCENARIOS
        for seed in settings.seeds
    ]
    cones = settings.data / "middlebury_cones"
    if cones.is_dir():
        pairs.append(("cones", degraded_target(load_cones(cones), DEGRADATION)[0]))
    pairs.append(("motorcycle", degraded_target(load_motorcycle(settings.motorcycle_downsample), DEGRADATION)[0]))
    pleiades = settings.data / "pleiades_reunion_rectified"
    if pleiades.is_dir():
        pairs.append(("pleiades-reunion", pleiades_pair(pleiades, settings.pleiades_crop, settings.matcher)[1]))
    us3d = settings.data / US3D_FOLDER
    if us3d.is_dir() and not settings.quick:
        pairs += [(f"us3d {name}", load_us3d(us3d, name)) for name in us3d_names(us3d)]
    return pairs


def variant_params(params: Params, method: str | None) -> Params:
    """``params`` with the labels withheld and objects by ``method`` (None: unchanged)."""
    return params if method is None else params.with_stage("objects", method=method, use_supplied=False)


def measure_variant(pair: Pair, params: Params, settings: Settings) -> dict:
    """Run the pipeline on ``pair`` and measure its consistent pair with every matcher.

    Parameters
    ----------
    pair : Pair
        The pair, with its ground truth (and labels, which the evaluation uses).
    params : Params
        The run's parameters.
    settings : Settings
        The report's matchers.

    Returns
    -------
    dict
        ``rate`` and ``object_rate`` (matcher name -> value), ``objects_seconds``,
        ``association_seconds``, ``objects`` (reference objects), ``associated``, ``method``
        (the objects method that ran: the height method may fall back to ``mbi``) and
        ``note``.
    """
    run = Pipeline(params).run(pair)
    evaluation = evaluate_run_matchers(run, ["ours"], settings.matchers)
    ours = {name: comparison.method("ours") for name, comparison in evaluation.comparisons.items()}
    objects = run.objects
    return {
        "rate": {name: _number(result.correct_rate) for name, result in ours.items()},
        "object_rate": {name: _number(result.mean_object_rate) for name, result in ours.items()},
        "objects_seconds": float(run.timings.get("objects", math.nan)),
        "association_seconds": float(run.timings.get("association", math.nan)),
        "objects": int(np.unique(objects.reference[objects.reference > 0]).size),
        "associated": len(run.association.objects) if run.association is not None else 0,
        "method": "supplied" if objects.source == "user" else getattr(objects, "method", "mbi"),
        "note": getattr(objects, "note", ""),
    }


def segmented_records(settings: Settings, params: Params) -> list[dict]:
    """Every pair of the report with each of :data:`VARIANTS`.

    Parameters
    ----------
    settings : Settings
        The report's pairs and matchers.
    params : Params
        The report's parameters of ours.

    Returns
    -------
    list of dict
        One record per pair and variant: ``pair``, ``variant`` and the measures of
        :func:`measure_variant`.
    """
    records = []
    for name, pair in report_pairs(settings):
        for variant, method in VARIANTS.items():
            log(f"segmented objects: {name}, {variant} ...")
            records.append({"pair": name, "variant": variant, **measure_variant(pair, variant_params(params, method), settings)})
    return records


def section_segmented(records: list[dict], matchers: tuple[str, ...], preset: str) -> str:
    """The markdown section "Segmented objects (labels withheld)".

    Parameters
    ----------
    records : list of dict
        As returned by :func:`segmented_records`.
    matchers : tuple of str
        The matchers' names, in the report's order.
    preset : str
        The preset the records were run with.

    Returns
    -------
    str
        Markdown, starting with the section's title.
    """
    pairs = list(dict.fromkeys(r["pair"] for r in records))
    by = {(r["pair"], r["variant"]): r for r in records}
    names = JOIN.join(title(m) for m in matchers)
    lines = [
        "## Segmented objects (labels withheld)",
        "",
        f"What a user without building footprints gets: every pair above run again with the `{preset}` preset, "
        "the pair's label rasters withheld from the pipeline (`[objects] use_supplied = false`), its objects "
        "segmented from the images alone (`method = \"mbi\"`) or found from height (`method = \"height\"`: census "
        "disparity of the pair as given, ground, height above it). Correct-matching rate of the consistent pair "
        f"over all pixels with ground truth (< 1 px), **{names}**; the same ground truth, search range and degraded "
        "targets as above. Objects: reference objects found (associated). Seconds: the objects stage (the height "
        "method's census disparity included) plus the association stage.",
        "",
    ]
    header = [
        "pair", "supplied labels", "mbi", "height", "height - supplied", "objects mbi", "objects height",
        "seconds mbi", "seconds height",
    ]
    rows = []
    for pair in pairs:
        supplied, mbi, height = (by.get((pair, v)) for v in VARIANTS)
        if not (supplied and mbi and height):
            continue
        rows.append([
            pair, _rates(supplied, matchers), _rates(mbi, matchers), _rates(height, matchers),
            JOIN.join(_signed(_difference(height["rate"][m], supplied["rate"][m])) for m in matchers),
            _objects(mbi), _objects(height), _seconds(mbi), _seconds(height),
        ])
    means = {v: {m: _mean(r["rate"][m] for r in records if r["variant"] == v) for m in matchers} for v in VARIANTS}
    rows.append([
        "**mean**", *(JOIN.join(fmt(means[v][m]) for m in matchers) for v in VARIANTS),
        JOIN.join(_signed(means["height"][m] - means["supplied"][m]) for m in matchers), "", "", "", "",
    ])
    lines += [md_table(header, rows), ""]
    if any(pair.startswith("us3d") for pair in pairs):
        lines += [
            "The US3D tiles' label rasters are the lidar's disparity layers (connected 3 px layers of at least "
            "1500 px, ground included), which no user has: their `supplied labels` column is an oracle, and "
            "`mbi` and `height` are what the tiles give without lidar. At 1 px the lidar's offset from the "
            "images counts most correct matches of JAX_122 as wrong (see the multi-date section).",
            "",
        ]
    lines += [_where_height_loses(pairs, by, matchers, preset), ""]
    fallbacks = [f"{r['pair']}: {r['note']}" for r in records if r["variant"] == "height" and r["note"]]
    if fallbacks:
        lines += ["Notes of the height method: " + "; ".join(fallbacks) + ".", ""]
    return "\n".join(lines).rstrip()


def add_to_report(out: Path, section: str, records: list[dict]) -> None:
    """Put the section into a written report: ``results.md`` before :data:`BEFORE` (else at
    the end), the records into ``results.json`` under ``segmented_objects``.

    Parameters
    ----------
    out : Path
        The report's folder (``results.md``, ``results.json``).
    section : str
        The markdown of :func:`section_segmented`.
    records : list of dict
        The records of :func:`segmented_records`.
    """
    page = out / "results.md"
    text = page.read_text(encoding="utf-8")
    at = text.find("\n" + BEFORE + "\n")
    text = text.rstrip("\n") + "\n\n" + section + "\n" if at < 0 else text[: at + 1] + section + "\n\n" + text[at + 1 :]
    page.write_text(text, encoding="utf-8")
    raw = out / "results.json"
    report = json.loads(raw.read_text()) if raw.exists() else {}
    report["segmented_objects"] = records
    raw.write_text(json.dumps(report, indent=1, allow_nan=False) + "\n")


def write_segmented(settings: Settings) -> None:
    """Run every pair of the report with its labels withheld and add the section to the
    report written in ``settings.out``.

    Parameters
    ----------
    settings : Settings
        The report's settings (pairs, matchers, preset, folder).
    """
    start = time.perf_counter()
    records = segmented_records(settings, Params.from_preset(settings.preset))
    add_to_report(settings.out, section_segmented(records, settings.matcher_names, settings.preset), records)
    log(f"segmented objects: added to {settings.out / 'results.md'} in {time.perf_counter() - start:.0f} s")


def _number(value: float | None) -> float | None:
    """A finite float, or None (JSON null) when undefined."""
    return float(value) if value is not None and math.isfinite(value) else None


def _rates(record: dict, matchers: tuple[str, ...]) -> str:
    return JOIN.join(fmt(record["rate"][m]) for m in matchers)


def _where_height_loses(pairs: list[str], by: dict, matchers: tuple[str, ...], preset: str) -> str:
    """The preset's own objects method, and the pairs where ``height`` is more than
    :data:`LOSS` below ``mbi`` with a matcher."""
    method = Params.from_preset(preset).objects.method
    losses = []
    for pair in pairs:
        mbi, height = by.get((pair, "mbi")), by.get((pair, "height"))
        if not (mbi and height):
            continue
        worse = [
            f"{title(m)} {_signed(_difference(height['rate'][m], mbi['rate'][m]))}"
            for m in matchers
            if _difference(height["rate"][m], mbi["rate"][m]) < -LOSS
        ]
        if worse:
            losses.append(f"{pair} ({', '.join(worse)})")
    text = f"The `{preset}` preset's own method is `{method}`. "
    if not losses:
        return text + f"`height` is nowhere more than {LOSS:g} below `mbi`."
    return text + (
        f"Where `height` is more than {LOSS:g} below `mbi`: {'; '.join(losses)}. Where the height method keeps "
        "few objects or none (terrain without buildings), the refine stage has the background mapping alone, "
        "while each of the image-only index's many small regions gets its own fit."
    )


def _difference(a: float | None, b: float | None) -> float:
    return a - b if a is not None and b is not None else math.nan


def _signed(value: float | None) -> str:
    return f"{round(value, 3) + 0.0:+.3f}" if value is not None and math.isfinite(value) else "-"


def _objects(record: dict) -> str:
    return f"{record['objects']} ({record['associated']})"


def _seconds(record: dict) -> str:
    return f"{record['objects_seconds'] + record['association_seconds']:.2f}"


def _mean(values) -> float:
    finite = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.mean(finite)) if finite else math.nan
