"""The ``heldout`` section: objects as ``radcons process`` finds them, on pairs no value was chosen on.

Demo pairs of seeds never used to choose anything (``--split heldout``: 1000-1009; the
seeds the objects' values were chosen and checked on, ``--split tuning``, are 0-9),
each scenario at each size, and the US3D tiles, through the ``radcons`` preset up to
the objects with ``use_supplied = False`` (the pairs' own labels withheld), once for
each ground of ``--ground``
(:attr:`radcons.stages.objects.params.ObjectsParams.ground`), each run on a new
pipeline so that each pays its own census matching. Demo pairs: buildings, objects,
mean best IoU per building, recall at IoU 0.5, share of the objects of 100 px or more
that are a building at IoU 0.5, pooled over the seeds; US3D: share of the built pixels
(lidar-elevated, not green) an object covers and share of the object pixels the lidar
shows elevated (:func:`~.common.lidar_truth`), and share of the lidar's ground pixels
that stand above the objects' ground by more than the height threshold (raised: where
false objects can grow). Times: the objects stage's (census matching included) and the
ground's alone, run again on the stage's census disparity. Then where the figures fall
short of :data:`TARGETS`.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections import defaultdict

import numpy as np

from .common import DATA, US3D, US3D_TILES, building_ious, lidar_truth, object_precision, radcons_preset

#: Seeds of each split: ``tuning``, where the objects' values were chosen and checked; ``heldout``, used once to
#: measure them; ``fresh``, for the rule ablations (:mod:`.ablation`).
SPLITS = {"tuning": tuple(range(10)), "heldout": tuple(range(1000, 1010)), "fresh": tuple(range(2000, 2010))}
#: The figures the objects should reach: demo mean best IoU, recall at IoU 0.5, share of
#: objects that are buildings; US3D share of object pixels the lidar shows elevated.
TARGETS = {"mean IoU": 0.70, "recall@0.5": 0.85, "objects that are buildings": 0.70, "object pixels elevated": 0.85}


def _params(ground: str, settings: list[str] | tuple[str, ...] = ()):
    """The ``radcons`` preset as ``radcons process`` runs it, labels withheld, with ``ground``.

    ``settings`` are the ``--set`` changes (``STAGE.KEY=VALUE``), applied first.
    """
    return radcons_preset(settings).with_stage("objects", method="height", use_supplied=False, ground=ground)


def _objects(pair, params):
    """The objects stage's result on ``pair`` with ``params`` and its seconds, on a new pipeline."""
    from radcons.pipeline import Pipeline

    run = Pipeline(params).run(pair, until="objects")
    return run.objects, run.timings["objects"]


def _ground_seconds(objects, pair, params, repeat: int = 1) -> float:
    """Seconds of the ground alone (:func:`radcons.stages.objects.ground.ground_under`), median of ``repeat``.

    On the census disparity the objects stage found the ground under, as the stage
    computes it (NaN when the stage fell back to the image-only path).
    """
    from radcons.stages.objects.ground import ground_under
    from radcons.stages.objects.matching import resolved_gsd
    from radcons.stages.objects.step import height_geometry

    height = getattr(objects, "height", None)
    if height is None:
        return float("nan")
    params = params.objects
    gsd = resolved_gsd(height_geometry(pair)["gsd_m"], params)
    px_per_m = height.px_per_unit if height.unit == "m" else None
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        ground_under(height.disparity, params, gsd, height.factor, px_per_m)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def _demo_tallies(args: argparse.Namespace, seeds: tuple[int, ...]) -> dict:
    """Figures of every demo pair, pooled by (ground, size, scenario)."""
    from demo_data_gen import generate
    from radcons.geometry import settle_geometry

    tallies: dict = defaultdict(
        lambda: {"iou": [], "objects": 0, "good": 0, "judged": 0, "seconds": [], "ground_seconds": []}
    )
    for size in args.sizes:
        for scenario in args.scenarios:
            for seed in seeds:
                pair = settle_geometry(generate(size=size, seed=seed, scenario=scenario))
                for ground in args.ground:
                    params = _params(ground, args.set)
                    objects, seconds = _objects(pair, params)
                    labels = objects.reference
                    tally = tallies[ground, size, scenario]
                    tally["iou"].extend(building_ious(pair.reference_objects, labels))
                    tally["objects"] += int(len(np.unique(labels[labels > 0])))
                    good, judged = object_precision(pair.reference_objects, labels)
                    tally["good"] += good
                    tally["judged"] += judged
                    tally["seconds"].append(seconds)
                    tally["ground_seconds"].append(_ground_seconds(objects, pair, params))
    return tallies


def _demo_table(args: argparse.Namespace, seeds: tuple[int, ...]) -> list[str]:
    """Print the demo pairs' table; return the figures that fall short of :data:`TARGETS`."""
    print(f"\n### demo pairs, seeds {seeds[0]}-{seeds[-1]} ({len(seeds)} a scenario and size)\n")
    print(
        "| ground | size | scenario | buildings | objects | mean IoU | recall@0.5 | objects that are buildings "
        "| s a pair: objects stage | of which ground |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    short = []
    for (ground, size, scenario), tally in _demo_tallies(args, seeds).items():
        iou = np.array(tally["iou"])
        figures = {
            "mean IoU": iou.mean(), "recall@0.5": np.mean(iou >= 0.5),
            "objects that are buildings": tally["good"] / max(tally["judged"], 1),
        }
        print(
            f"| {ground} | {size} | {scenario} | {iou.size} | {tally['objects']} | {figures['mean IoU']:.3f} | "
            f"{figures['recall@0.5']:.3f} | {tally['good']}/{tally['judged']} = "
            f"{figures['objects that are buildings']:.3f} | {np.mean(tally['seconds']):.2f} | "
            f"{np.mean(tally['ground_seconds']):.2f} |",
            flush=True,
        )
        short += [
            f"{ground}, {size} px {scenario}: {name} {value:.4f} < {TARGETS[name]:.2f}"
            for name, value in figures.items() if value < TARGETS[name]
        ]
    return short


def _us3d_table(args: argparse.Namespace) -> list[str]:
    """Print the US3D tiles' table; return the figures that fall short of :data:`TARGETS`."""
    from radcons.geometry import settle_geometry
    from radcons.io import load_pair_files

    print("\n### US3D tiles (lidar truth; heights in disparity px, no geometry known)\n")
    print(
        "| ground | tile | objects | built pixels covered | object pixels elevated | lidar-ground pixels raised "
        "| s: objects stage | ground, median of 3 |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    short = []
    greenness = _params("windows", args.set).objects.tree_greenness
    for tile in US3D_TILES:
        files = [US3D / f"{tile}_LEFT_RGB.tif", US3D / f"{tile}_RIGHT_RGB.tif"]
        pair = settle_geometry(load_pair_files(*files, rectified=True))
        known, elevated, built = lidar_truth(pair, US3D / f"{tile}_LEFT_DSP.tif", greenness)
        for ground in args.ground:
            params = _params(ground, args.set)
            objects, seconds = _objects(pair, params)
            labels = objects.reference
            inside = (labels > 0) & known
            share = float(elevated[inside].mean()) if inside.any() else float("nan")
            covered = float(np.mean(labels[built] > 0))
            count = int(len(np.unique(labels[labels > 0])))
            raised = _raised_ground(objects.height, known & ~elevated, pair.reference.data.shape[:2], params)
            alone = _ground_seconds(objects, pair, params, repeat=3)
            print(
                f"| {ground} | {tile} | {count} | {covered:.2f} | {share:.2f} | {raised:.2f} | {seconds:.2f} "
                f"| {alone:.2f} |",
                flush=True,
            )
            if not share >= TARGETS["object pixels elevated"]:
                short.append(f"{ground}, US3D {tile}: object pixels elevated {share:.4f} < 0.85")
    return short


def _raised_ground(height, ground: np.ndarray, shape: tuple[int, int], params) -> float:
    """Share of the lidar's ground pixels (``ground``) whose height above the objects' ground exceeds the threshold.

    The threshold is ``params``' ``min_height_px`` or ``min_height_m``, in the unit of
    ``height`` (:class:`radcons.stages.objects.ground.HeightMap`).
    """
    objects = params.objects
    threshold = objects.min_height_m if height.unit == "m" else objects.min_height_px
    above = height.full(shape)[ground]
    return float(np.mean(np.nan_to_num(above, nan=0.0) > threshold))


def heldout(args: argparse.Namespace) -> None:
    """The ``heldout`` section (see the module's description)."""
    seeds = SPLITS[args.split]
    print(
        f"\n## objects as radcons process finds them, {args.split} split, ground: {', '.join(args.ground)}, "
        f"settings: {args.set or 'defaults'}"
    )
    print("\ntargets: " + ", ".join(f"{name} >= {value:.2f}" for name, value in TARGETS.items()))
    short = _demo_table(args, seeds)
    if US3D.is_dir():
        short += _us3d_table(args)
    else:
        print(f"\n(US3D tiles skipped: {DATA} holds no {US3D.name})")
    print("\nshort of the targets:" + "".join(f"\n- {line}" for line in short) if short else "\nevery target met")
