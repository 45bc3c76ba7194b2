"""The whole report: run every evaluation, draw the figures, assemble ``results.md`` from its
sections and write the raw numbers to ``results.json``."""

from __future__ import annotations

import datetime
import json
import math
import os
import platform
import subprocess
import time
from dataclasses import asdict
from pathlib import Path

import cv2
import numpy as np

from bench_baselines import DEGRADATION
from radcons.params import Params

from .common import PAPER_MEANS, REPO, Entry, Settings, for_matcher, log
from .figures import draw_plots
from .matchers import JOIN, matcher_rows, section_consistency_buys, section_matcher_headline, side_by_side, title
from .multidate import multidate_records, section_multidate
from .real import section_pleiades, section_truth_pairs
from .run import run_demo, run_real_pairs
from .summary import section_headline, section_losses, section_paper, section_timings
from .synthetic import section_ablation, section_demo, section_stages_everywhere
from .tables import headline_rows


def write_report(settings: Settings, argv: list[str]) -> None:
    """Run every evaluation of the report and write ``results.md``, ``results.json`` and ``img/``.

    Parameters
    ----------
    settings : Settings
        What to evaluate and where to write (``settings.out``).
    argv : list of str
        The command's arguments, quoted in the report.
    """
    start, cpu_start = time.perf_counter(), time.process_time()
    params = Params.from_preset(settings.preset)
    img_dir = settings.out / "img"
    img_dir.mkdir(parents=True, exist_ok=True)

    demo, ceiling = run_demo(settings, params)
    truth_entries, skipped, pleiades, pleiades_note = run_real_pairs(settings, params)
    singles = truth_entries + ([pleiades] if pleiades else [])
    log("real multi-date pairs and randomised differences (held-out seeds) ...")
    multidate = {"us3d": [], "randomised": []} if settings.quick else multidate_records(settings.data)

    log("plots ...")
    plots = draw_plots([e for e in truth_entries if e.key == "cones"] + [demo["mixed"][0]], img_dir)

    def per_matcher(write) -> str:
        """One section written with each matcher's comparisons, merged side by side."""
        texts = {}
        for name in settings.matcher_names:
            seen_demo = {s: [for_matcher(e, name) for e in entries] for s, entries in demo.items()}
            seen = {
                "demo": seen_demo,
                "ceiling": [for_matcher(e, name) for e in ceiling],
                "truth": [for_matcher(e, name) for e in truth_entries],
                "pleiades": for_matcher(pleiades, name) if pleiades else None,
            }
            seen["singles"] = seen["truth"] + ([seen["pleiades"]] if pleiades else [])
            seen["rows"] = headline_rows(seen_demo, seen["singles"])
            seen["objects"] = seen["singles"] + [entries[0] for entries in seen_demo.values()]
            texts[name] = write(seen)
        return side_by_side(texts)

    rows = {name: matcher_rows(demo, singles, name) for name in settings.matcher_names}
    elapsed = (time.perf_counter() - start, time.process_time() - cpu_start, os.getloadavg()[0])
    heading = "# Results" + (" (quick smoke run)" if settings.quick else "")
    pairs_of = JOIN.join(title(name) for name in settings.matcher_names)
    sections = [
        heading,
        "This page is written by `benchmarks/make_results.py`; every number in it comes from that run "
        "(raw numbers: `results.json`). Regenerate it instead of editing it. Every method is matched by "
        f"each dense matcher; a table cell with two values reads **{pairs_of}**, a paragraph or table that "
        "differs otherwise between matchers is given once per matcher.",
        section_matcher_headline(rows),
        section_consistency_buys(rows),
        per_matcher(lambda seen: section_headline(seen["rows"])),
        section_setup(settings, params, elapsed, argv),
        per_matcher(lambda seen: section_demo(seen["demo"], seen["ceiling"], settings)),
        per_matcher(
            lambda seen: section_ablation(seen["demo"]["mixed"]) + "\n" + section_stages_everywhere(seen["demo"], seen["singles"])
        ),
        per_matcher(lambda seen: section_truth_pairs(seen["truth"], skipped)),
        per_matcher(lambda seen: section_pleiades(seen["pleiades"], pleiades_note)),
        section_multidate(multidate, "python benchmarks/bench_generalisation.py --split held-out --us3d"),
        per_matcher(lambda seen: section_paper(seen["rows"])),
        per_matcher(lambda seen: section_losses(seen["rows"], seen["demo"], seen["objects"])),
        section_plots(plots),
        section_timings(demo, singles),
    ]
    settings.out.mkdir(parents=True, exist_ok=True)
    (settings.out / "results.md").write_text("\n\n".join(sections) + "\n", encoding="utf-8")
    report = {
        "settings": {
            "size": settings.size, "seeds": list(settings.seeds), "preset": settings.preset,
            "params": params.to_dict(),
            "matchers": {n: asdict(m) for n, m in zip(settings.matcher_names, settings.matchers)},
            "degradation": asdict(DEGRADATION),
            "motorcycle_downsample": settings.motorcycle_downsample, "pleiades_crop": settings.pleiades_crop,
            "quick": settings.quick, "date": datetime.date.today().isoformat(), "cores": os.cpu_count(),
            "seconds": round(elapsed[0], 1), "cpu_seconds": round(elapsed[1], 1),
        },
        "demo": {
            scenario: {str(e.extra["metadata"]["seed"]): _entry_json(e) for e in entries}
            for scenario, entries in demo.items()
        },
        "demo_same_date_sensor": {str(e.extra["metadata"]["seed"]): _entry_json(e) for e in ceiling},
        "real": {e.key: _entry_json(e) for e in singles},
        "multidate": multidate,
        "paper_means": PAPER_MEANS,
    }
    (settings.out / "results.json").write_text(json.dumps(_plain(report), indent=1, allow_nan=False) + "\n")
    log(f"wrote {settings.out / 'results.md'} in {elapsed[0]:.0f} s ({elapsed[1]:.0f} s CPU)")


def section_setup(settings: Settings, params: Params, elapsed: tuple[float, float, float], argv: list[str]) -> str:
    """What was run, with what, where.

    Parameters
    ----------
    settings : Settings
        The run's settings.
    params : Params
        Parameters of ours.
    elapsed : tuple of float
        Wall seconds, CPU seconds and the 1-minute load average at the end of the run.
    argv : list of str
        The command's arguments.

    Returns
    -------
    str
        The markdown section.
    """
    commit = _git("rev-parse", "--short", "HEAD")
    out = settings.out.resolve()
    dirty = [  # the report's own files, written before this section, do not count
        line for line in _git("status", "--porcelain").splitlines()
        if not (REPO / line.split(maxsplit=1)[-1]).resolve().is_relative_to(out)
    ]
    version = f"{commit}{' with uncommitted changes' if dirty else ''}" if commit else "unknown"
    described = [
        f"{title(name)} ({', '.join(f'{k}={v}' for k, v in asdict(m).items())})"
        for name, m in zip(settings.matcher_names, settings.matchers)
    ]
    degradation = ", ".join(f"{k}={v}" for k, v in asdict(DEGRADATION).items() if v is not None)
    lines = [
        "## What was run",
        "",
        f"- Command: `python benchmarks/make_results.py{' ' + ' '.join(argv) if argv else ''}` "
        f"(from the repository root; it writes this page, `results.json` and `img/`).",
        f"- Date: {datetime.date.today().isoformat()}; code: {version}.",
        f"- Machine: {os.cpu_count()} cores ({platform.machine()}, {platform.system()}), Python "
        f"{platform.python_version()}, numpy {np.__version__}, OpenCV {cv2.__version__}; "
        f"the whole script ran in {elapsed[0]:.0f} s wall time, {elapsed[1]:.0f} s CPU time (all threads; "
        f"load average {elapsed[2]:.1f} when it ended).",
        f"- Parameters of ours: preset `{params.preset}` (`Params.from_preset({params.preset!r})`), stages "
        f"switched off: {', '.join(sorted(params.disabled)) or 'none'}; \"ours\" is the image pair after "
        "the last stage. \"paper\" is the pipeline with the `paper` preset: the paper's stages, "
        "equations and values as printed.",
        f"- Dense matchers (each for every method, over the same disparity search range = the ground "
        f"truth's range with a 2 px margin): {'; '.join(described)}. SGBM is OpenCV's semi-global matching; "
        "both images are mapped to 8 bits with one linear mapping, the reference's 0.5-99.5 percentile range, "
        "clipped. Census is CNES Pandora's census cost with libsgm's semi-global matching (the configuration "
        "of CNES' CARS); each image is mapped on its own, as census sees only the order of grey levels. "
        "Correct match: |d - d_gt| < 1 px; a failed match (census: also a pixel its left-right check "
        "rejects) counts as wrong (the paper's Figure 5). The Pleiades pair's reference disparity is the "
        f"left-right checked disparity of {title(settings.matcher_names[0])}, which favours that matcher there. "
        f"Figures show {title(settings.matcher_names[0])}.",
        "- Metrics: eq 20 similarity per object pair (256 levels over the pair's common range, object "
        "bounding boxes with background 0), its mean over the objects; the correct-matching rate over "
        "every pixel with ground truth and its mean over the objects (the paper's Table 2 mean).",
        f"- Simulated date / sensor difference of the real pairs' targets (`bench_baselines.DEGRADATION`, "
        f"`radcons.evaluate.simulate.degrade`): {degradation}. In that order: gamma on the image's range, "
        "gain and offset, object `saturate_label` brightened and clipped (the paper's over-exposed "
        "Object 1), Gaussian blur, Gaussian noise, clip to the original range.",
        f"- Demo pairs: `demo_data_gen.generate(size={settings.size}, seed, scenario)`, seeds "
        f"{', '.join(map(str, settings.seeds))}; objects are the generator's building labels; the pipeline "
        "uses the same labels as its objects.",
    ]
    if settings.quick:
        lines.append("- **Quick smoke run** (`--quick`): small images and one seed; not the report's numbers.")
    return "\n".join(lines)


def _git(*args: str) -> str:
    """Standard output of a git command run in the checkout.

    Parameters
    ----------
    *args : str
        The git command's arguments.

    Returns
    -------
    str
        Its stripped output; empty when git is missing, fails or takes over 20 s.
    """
    try:
        done = subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True, timeout=20)
    except (OSError, subprocess.SubprocessError):
        return ""
    return done.stdout.strip() if done.returncode == 0 else ""


def section_plots(images: list[tuple[str, str, str]]) -> str:
    """The figures, each with its title and caption.

    Parameters
    ----------
    images : list of (str, str, str)
        Per figure: title, caption and path relative to the report.

    Returns
    -------
    str
        The markdown section.
    """
    lines = ["## Plots", ""]
    for title, caption, path in images:
        lines += [f"**{title}.** {caption}", "", f"![{title}]({path})", ""]
    return "\n".join(lines).rstrip()


def _entry_json(entry: Entry) -> dict:
    """One evaluated pair for ``results.json``.

    Parameters
    ----------
    entry : Entry
        The evaluated pair.

    Returns
    -------
    dict
        Each matcher's comparison (``matchers.NAME``), pipeline seconds, how it was built
        and its extra facts.
    """
    out = {"matchers": {name: comparison.to_json_dict() for name, comparison in entry.comparisons.items()}}
    out["pipeline_seconds"] = {k: round(v, 4) for k, v in entry.timings.items()}
    out["built"] = entry.built
    out["objects"] = entry.objects
    out["extra"] = dict(entry.extra)
    return out


def _plain(value: object) -> object:
    """JSON-ready copy: numpy scalars to Python, tuples to lists, NaN to None.

    Parameters
    ----------
    value : object
        Nested dicts, sequences, numbers, paths and strings.

    Returns
    -------
    object
        The same structure with JSON types only (dict keys as strings).
    """
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, set, frozenset)):
        return [_plain(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, Path):
        return str(value)
    return value
