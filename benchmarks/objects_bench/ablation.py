"""The ``ablation`` section: what each rule of the height method buys, the rule switched off.

Each rule of the objects stage, the physical tests included, is switched off in turn
(:data:`RULES`: its switch, or the threshold at the end of its range that disables it)
in the ``radcons`` preset as ``radcons process`` runs it (``use_supplied = False``, the
pairs' own labels withheld, ``--set`` changes applied first), on demo pairs of the
seeds of ``--split`` (``fresh``, 2000-2009, for rule ablations: neither tuned nor
measured on before), each scenario of ``--scenarios`` at each size of ``--sizes``, and
on the US3D tiles against their lidar. One pipeline a pair keeps the pair's census
matching, so that each configuration pays only for its rules (a rule that changes the
census matching, ``census_cross_check``, pays for its own). Per scenario, pooled over
the seeds: mean best IoU per building, recall at IoU 0.5 and the share of the objects
of 100 px or more that are a building at IoU 0.5 (:mod:`.heldout`'s figures), then on
the target: the mean best IoU of the target's buildings with the objects moved into it,
and the share of those objects, of 100 px or more, that are a building at IoU 0.5 in the
target's labels (an object moved by a wrong D̄m is none; the left-right check,
``cross_check_objects``, keeps such objects out of the target); per tile: the share of
object pixels the lidar shows elevated and the share of the built pixels an object
covers (:func:`~.common.lidar_truth`). The first table gives the defaults' figures, the
second each rule's difference, off minus on: a positive difference is a gain without
the rule.
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from typing import TYPE_CHECKING

import numpy as np

from .common import DATA, US3D, US3D_TILES, building_ious, lidar_truth, object_precision, radcons_preset
from .heldout import SPLITS

if TYPE_CHECKING:
    from radcons.params import Params

#: Each rule the ablation switches off, by the ``[objects]`` field that switches it -> the
#: setting that does (a switch off, or a threshold at the end of its range that no object
#: passes or every object passes).
RULES: dict[str, dict[str, object]] = {
    name: {name: value}
    for name, value in (
        # searches and joins
        ("find_missed", False), ("find_in_removed", False), ("find_clipped", False),
        ("textured_roof_rectangularity", 0.0), ("join_roof_halves", False), ("complete_gables", False),
        ("join_wings", False),
        # left-right checks, seeds, outlines
        ("cross_check_objects", False), ("census_cross_check", "none"), ("flat_edges", 0.0),
        ("shadow_trim", 0.0), ("outline_band", 0.0), ("disparity_radius", 0),
        # rules on the first regions: tree and its exemptions, low objects, match contrast
        ("tree_texture", 100.0), ("roof_rectangularity", 2.0), ("tree_rectangularity", 0.0),
        ("tree_alignment", 0.0), ("spilled_roof_texture", 0.0), ("tall_roof_height_m", 0.0),
        ("min_object_height", 0.05), ("min_match_score", -2.0),
        # rules on the final objects
        ("shadow_texture", 0.0), ("outline_edge", 0.0), ("dark_height", 0.0), ("crown_alignment", 0.0),
        ("tree_greenness", 1.0),
    )
}
#: Names of the demo and US3D figures, in the tables' order.
DEMO_FIGURES = ("mean IoU", "recall@0.5", "buildings", "target IoU", "target buildings")
US3D_FIGURES = ("elevated", "covered")


def _configurations(args: argparse.Namespace) -> dict[str, Params]:
    """The defaults (name ``defaults``) and each rule of ``--rules`` off, as :class:`radcons.params.Params`."""
    base = radcons_preset(args.set).with_stage("objects", method="height", use_supplied=False)
    names = args.rules or list(RULES)
    return {"defaults": base, **{name: base.with_stage("objects", **RULES[name]) for name in names}}


def _demo_figures(
    args: argparse.Namespace, seeds: tuple[int, ...], configurations: dict[str, Params]
) -> dict[tuple[str, int, str], tuple[float, ...]]:
    """(configuration, size, scenario) -> the demo figures, pooled over ``seeds``."""
    from demo_data_gen import generate
    from radcons.geometry import settle_geometry
    from radcons.pipeline import Pipeline

    tallies: dict = defaultdict(
        lambda: {"iou": [], "good": 0, "judged": 0, "target_iou": [], "target_good": 0, "target_judged": 0}
    )
    for size in args.sizes:
        for scenario in args.scenarios:
            for seed in seeds:
                pair = settle_geometry(generate(size=size, seed=seed, scenario=scenario))
                pipeline = Pipeline(configurations["defaults"])
                for name, params in configurations.items():
                    objects = pipeline.run(pair, params, until="objects").objects
                    tally = tallies[name, size, scenario]
                    tally["iou"].extend(building_ious(pair.reference_objects, objects.reference))
                    good, judged = object_precision(pair.reference_objects, objects.reference)
                    tally["good"] += good
                    tally["judged"] += judged
                    tally["target_iou"].extend(building_ious(pair.target_objects, objects.target))
                    good, judged = object_precision(pair.target_objects, objects.target)
                    tally["target_good"] += good
                    tally["target_judged"] += judged
            print(f"(demo {size} px {scenario} done)", flush=True)
    figures = {}
    for key, tally in tallies.items():
        iou = np.array(tally["iou"])
        figures[key] = (
            float(iou.mean()), float(np.mean(iou >= 0.5)), tally["good"] / max(tally["judged"], 1),
            float(np.mean(tally["target_iou"])), tally["target_good"] / max(tally["target_judged"], 1),
        )
    return figures


def _us3d_figures(configurations: dict[str, Params]) -> dict[tuple[str, str], tuple[float, float]]:
    """(configuration, tile) -> the share of object pixels elevated and of built pixels covered."""
    from radcons.geometry import settle_geometry
    from radcons.io import load_pair_files
    from radcons.pipeline import Pipeline

    figures = {}
    greenness = configurations["defaults"].objects.tree_greenness
    for tile in US3D_TILES:
        files = [US3D / f"{tile}_LEFT_RGB.tif", US3D / f"{tile}_RIGHT_RGB.tif"]
        pair = settle_geometry(load_pair_files(*files, rectified=True))
        known, elevated, built = lidar_truth(pair, US3D / f"{tile}_LEFT_DSP.tif", greenness)
        pipeline = Pipeline(configurations["defaults"])
        for name, params in configurations.items():
            labels = pipeline.run(pair, params, until="objects").objects.reference
            inside = (labels > 0) & known
            share = float(elevated[inside].mean()) if inside.any() else float("nan")
            figures[name, tile] = (share, float(np.mean(labels[built] > 0)))
        print(f"(US3D {tile} done)", flush=True)
    return figures


def _cell(values: tuple[float, ...], base: tuple[float, ...] | None) -> str:
    """The figures, or their differences from ``base`` (signed), joined by slashes."""
    if base is None:
        return " / ".join(f"{value:.3f}" for value in values)
    return " / ".join(f"{value - ref:+.3f}" for value, ref in zip(values, base))


def ablation(args: argparse.Namespace) -> None:
    """The ``ablation`` section (see the module's description)."""
    seeds = SPLITS[args.split]
    configurations = _configurations(args)
    print(f"\n## rule ablation, {args.split} split (seeds {seeds[0]}-{seeds[-1]}), settings: {args.set or 'defaults'}")
    demo = _demo_figures(args, seeds, configurations)
    us3d = _us3d_figures(configurations) if US3D.is_dir() else {}
    if not us3d:
        print(f"\n(US3D tiles skipped: {DATA} holds no {US3D.name})")
    columns = [(size, scenario) for size in args.sizes for scenario in args.scenarios]
    tiles = [tile for tile in US3D_TILES if us3d]
    header = [f"{size} px {scenario}: {' / '.join(DEMO_FIGURES)}" for size, scenario in columns]
    header += [f"US3D {tile}: {' / '.join(US3D_FIGURES)}" for tile in tiles]
    rule = f"|{' --- |' * (len(header) + 1)}"
    cells = [_cell(demo[("defaults", *column)], None) for column in columns]
    cells += [_cell(us3d["defaults", tile], None) for tile in tiles]
    print(f"\n### figures with every rule on\n\n| | {' | '.join(header)} |\n{rule}\n| defaults | {' | '.join(cells)} |")
    print(f"\n### difference, rule off minus on\n\n| rule off | {' | '.join(header)} |\n{rule}")
    for name in list(configurations)[1:]:
        cells = [_cell(demo[(name, *column)], demo[("defaults", *column)]) for column in columns]
        cells += [_cell(us3d[name, tile], us3d["defaults", tile]) for tile in tiles]
        setting = ", ".join(f"{key} = {value}" for key, value in RULES[name].items())
        print(f"| {setting} | {' | '.join(cells)} |", flush=True)
