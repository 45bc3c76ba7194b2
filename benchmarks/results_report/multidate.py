"""Report section "real multi-date pairs, lidar truth": the US3D tiles, and the held-out
split of the randomised differences, measured by ``bench_generalisation``.

:func:`multidate_records` evaluates (or reads from its cache) every method on the US3D
tiles and on the held-out seeds; :func:`section_multidate` turns the records into markdown.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from bench_generalisation import (
    COMPARED_BASELINES,
    ELEVATED_MARGIN,
    MATCHERS,
    METHODS,
    US3D_FOLDER,
    ZERO,
    Cache,
    base_pairs,
    mean_rate,
    randomised_table,
    run_randomised,
    run_us3d,
    us3d_gain,
)
from radcons.evaluate.simulate import split_seeds
from radcons.params import Params

from .tables import bold_best, fmt, md_table

#: How the report names the methods of ``bench_generalisation``.
LABELS = {
    "original": "as given", "histmatch": "histogram matching", "irmad": "IR-MAD", "zhang": "Zhang",
    "zhong": "Zhong", "paper": "`paper`", "radcons": "`radcons` (ours)",
}


def multidate_records(
    data: Path, *, crop: int | None = None, blocks: int = 1, demo_size: int = 256, cache: str | None = None
) -> dict[str, list[dict]]:
    """Measure every method with both matchers on the US3D tiles and the held-out seeds.

    Parameters
    ----------
    data : Path
        The shared data folder (US3D tiles and Middlebury Cones).
    crop : int, optional
        Central crop of the US3D tiles, px (default the whole 1024 x 1024 tile).
    blocks : int
        Held-out blocks of seeds (9 seeds each).
    demo_size : int
        Side of the demo pair of the randomised benchmark.
    cache : str, optional
        JSON cache of ``bench_generalisation``.

    Returns
    -------
    dict
        ``{"us3d": [...], "randomised": [...]}`` records (empty list for US3D where absent).
    """
    presets = {name: Params.from_preset(name) for name in ("paper", "radcons")}
    store = Cache(cache)
    folder = Path(data) / US3D_FOLDER
    us3d = run_us3d(folder, METHODS, list(MATCHERS), presets, store, crop) if folder.is_dir() else []
    pairs = base_pairs(("cones", "motorcycle", "demo"), Path(data), demo_size)
    seeds = split_seeds("held-out", blocks)
    randomised = run_randomised(pairs, seeds, METHODS, list(MATCHERS), presets, store)
    return {"us3d": us3d, "randomised": randomised}


#: The US3D tables' columns, per matcher: record key -> header (after the matcher's name).
US3D_COLUMNS = {
    "rate1": "1 px", "rate3": "3 px", "objects3": "objects 3 px", "elevated1": "elevated 1 px",
    "elevated3": "elevated 3 px",
}


def _us3d_table(records: list[dict], tile: str | None) -> str:
    where = {} if tile is None else {"pair": tile}
    columns = [(matcher, key) for matcher in MATCHERS for key in US3D_COLUMNS]
    header = ["method", *[f"{m} {US3D_COLUMNS[k]}" for m, k in columns]]
    values = [[mean_rate(records, key, method=method, matcher=matcher, **where) for matcher, key in columns] for method in METHODS]
    by_column = [bold_best([row[i] for row in values]) for i in range(len(columns))]
    rows = [[LABELS[method], *[by_column[i][j] for i in range(len(columns))]] for j, method in enumerate(METHODS)]
    return md_table(header, rows)


def section_multidate(records: dict[str, list[dict]], command: str = "") -> str:
    """The markdown section "Real multi-date pairs, lidar truth".

    Parameters
    ----------
    records : dict
        As returned by :func:`multidate_records` (or the ``--json`` of ``bench_generalisation``).
    command : str
        The command that reproduces the numbers, quoted under the title.

    Returns
    -------
    str
        Markdown, starting with the section's title.
    """
    lines = ["## Real multi-date pairs, lidar truth", ""]
    if command:
        lines += [f"Reproduce: `{command}`", ""]
    us3d = records.get("us3d") or []
    if not us3d:
        lines += ["The US3D tiles were not found (shared data folder absent); nothing to report.", ""]
    else:
        lines += [
            "US3D / DFC2019 Jacksonville tiles (Bosch et al. 2019): WorldView-3 images of two dates, "
            "epipolar-rectified, airborne-lidar disparity (integers, so 3 px beside the paper's 1 px). "
            "Correct-matching rate over all pixels with lidar truth, and the mean over objects "
            "(connected 3 px disparity layers of at least 1500 px) at 3 px; *elevated*: the rate over the "
            f"pixels whose lidar disparity lies more than {ELEVATED_MARGIN:g} px from zero, where a constant zero "
            "disparity is always wrong (`radcons.evaluate.rates.elevated_mask`). The target's rows are levelled "
            "first (`radcons.geometry.level_rows`, as `radcons process` does; JAX_072 keeps a vertical offset "
            "of about 2.5 px, JAX_122 none to speak of), so every method, the pair as given included, is "
            "matched on the levelled pair.",
            "",
        ]
        for tile in sorted({r["pair"] for r in us3d}):
            lines += [f"**{tile}**", "", _us3d_table(us3d, tile), ""]
        lines += ["**mean over tiles**", "", _us3d_table(us3d, None), ""]
        lines += [
            f"Ours minus as given at 3 px, mean over tiles and matchers: {us3d_gain(us3d, 'rate3', MATCHERS):+.3f}; "
            f"at 3 px over the pixels more than {ELEVATED_MARGIN:g} px from zero: "
            f"{us3d_gain(us3d, 'elevated3', MATCHERS):+.3f}. The lidar "
            "disparity is offset from the images' correspondences (signed median over SIFT matches +0.9 px on "
            "JAX_072, -2.1 px on JAX_122; see `radcons.evaluate.truth_pairs`), so 1 px counts most correct "
            "matches of JAX_122 as wrong for every method; 3 px is the tolerance that compares methods.",
            "",
        ]
        zero_tiles = sorted({r["pair"] for r in us3d if r["method"] == ZERO})
        floors = [
            f"{fmt(mean_rate(us3d, 'rate3', method=ZERO, pair=tile))} ({tile}, 1 px "
            f"{fmt(mean_rate(us3d, 'rate1', method=ZERO, pair=tile))})"
            for tile in zero_tiles
        ]
        shares = [f"{fmt(mean_rate(us3d, 'elevated_share', method=ZERO, pair=tile))} ({tile})" for tile in zero_tiles]
        if floors:
            lines += [
                "A constant zero disparity, no matching at all, is correct at 3 px on " + " and ".join(floors)
                + " of the lidar pixels: most of each tile lies within 3 px of zero disparity, so the 3 px rate "
                "is decided on the few elevated and sloped areas, and a method that pulls a matcher's disparities "
                "toward zero raises it whatever it does to the radiometry. The *elevated* columns count only the "
                f"pixels more than {ELEVATED_MARGIN:g} px from zero, " + " and ".join(shares)
                + " of the lidar pixels, where zero disparity scores 0.",
                "",
            ]
    randomised = [r for r in records.get("randomised") or [] if r["split"] == "held-out"]
    if randomised:
        seeds = sorted({r["seed"] for r in randomised})
        lines += [
            f"Held-out split of the randomised differences (seeds {seeds[0]}-{seeds[-1]}, one difference kind "
            "per seed, applied to Cones, Motorcycle and the demo pair): correct-matching rate at 1 px, mean "
            "over seeds and pairs; best baseline among as given, "
            + ", ".join(LABELS[b] for b in COMPARED_BASELINES) + ".",
            "",
        ]
        for matcher in MATCHERS:
            table = randomised_table(randomised, METHODS, matcher)
            header = ["kind", *[LABELS[m] for m in METHODS], "best baseline", "ours - best"]
            rows = [[row[0], *[fmt(v) for v in row[1:-1]], f"{row[-1]:+.3f}" if math.isfinite(row[-1]) else "-"] for row in table]
            lines += [f"*{matcher}*", "", md_table(header, rows), ""]
        ratios = [r["noise_ratio"] for r in randomised if r["method"] == "radcons" and r["matcher"] == "sgbm"]
        if ratios:
            lines += [f"Noise ratio of ours on the held-out split: median {np.median(ratios):.2f}.", ""]
    return "\n".join(lines)
