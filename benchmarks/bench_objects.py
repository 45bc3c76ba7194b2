"""Objects from height against the demo generator's buildings, its speed, and the real pairs.

Sections (all by default, or the ones named with ``--only``):

``demo``
    Demo pairs (``--scenarios``, ``--seeds``, ``--sizes``), their label rasters withheld,
    objects by :func:`radcons.stages.objects.run.height_objects` with the pair's GSD and
    base-to-height ratio. Per pair and in total: mean best-match IoU per reference
    building (the IoU with the object covering most of it, 0 if none), recall at IoU 0.5,
    the share of objects of 100 px or more that are a building at IoU 0.5, and the same
    IoU for the image-only MBI path (``method = "mbi"``, today's). Associations
    (:func:`radcons.stages.association.height.associate_by_height` on SIFT matches): an
    association of an object whose reference pixels are mostly one building is correct
    when its target object's pixels are mostly that building in the target's own
    labels; ``D̄m within 1 px``: share of associated objects whose D̄m is within 1 px of
    the modal ground-truth disparity over the object (:func:`modal_disparity`); then the
    same share over the objects not mostly on ground changed between the dates (the
    generator's ``change_mask``), an object without a dominant disparity
    (:func:`dominant_disparity`) counted right within 1 px of its median too; and D̄m on
    the flat roofs (objects over 90 % on one building whose true disparities spread less
    than 0.5 px) and on the pitched ones (no dominant disparity), where the 1 px mode of
    disparities spread evenly from eaves to ridge is decided by bins a few per cent
    apart. Then the mean IoU and recall by the buildings' footprint (m²): where the
    method falls short; and the IoU and recall over the buildings the target shows too
    (:func:`in_both_images`), the ones a pair's objects can be.
``misses``
    The demo buildings of ``demo`` that no object finds (IoU < 0.5), each counted once,
    by the first cause that fits: the target does not show it (:func:`in_both_images`);
    under 100 m² and cut by the image frame; left out by a rule (the rule of
    :attr:`radcons.stages.objects.regions.HeightObjects.left_out` that covers most of
    it, when the rules cover over 30 % of it); partly found (objects cover over 30 %
    of it); no object there. And how many misses a recall of 0.85 allows: what is left
    to find, and where.
``trees``
    The elevated regions of the 512 px pairs before the tree rule, each called a
    building when its pixels are mostly one building: how many the rule removes, of
    which how many were buildings, and the medians of texture, rectangularity, height
    roughness (plane residual) and hull rectangularity of buildings and others.
``timing``
    Objects + association (census disparity, regions, transfer, SIFT matches,
    association) on the 1024 x 1024 ``mixed`` pair, median of ``--repeat`` runs, after a
    first run that pays Pandora's compile time: the two functions one after the other,
    and the ``radcons`` preset's pipeline up to the association (a new
    :class:`radcons.pipeline.Pipeline` each run, so nothing cached), which matches SIFT
    beside the objects; the image-only path (MBI of both images, SIFT, template
    association) measured in the same process as the reference. Two more rows say
    where the time goes: the height method's census disparity alone, and the SIFT
    matching alone with OpenCV on one thread, as it runs beside the objects on the
    other core. And the objects stage run again by one pipeline with a rule's threshold
    changed each time (``tree_texture``), as an analyst tuning it in the inspector does:
    the pipeline keeps the pair's census matching
    (:class:`radcons.stages.objects.matching.PairMatching`). Each row also gives the CPU time of
    all the process's threads (median), and the preset's first run's CPU time over the
    machine's cores: the least wall time any overlap of its threads could reach.
``real``
    The real pairs of ``../shared/data`` (Gizeh, Kahramanmaras pre/post, Mont Ventoux:
    wooded slopes without a building, La Reunion: rectified, a road on steep wooded
    volcanic slopes without a building, US3D Jacksonville) through the ``radcons`` preset with ``objects.method = "height"`` (and
    the pairs' own labels, if any, not used) up to the association: method, note,
    object counts, median height of the objects; for US3D, the share of object pixels
    whose lidar disparity stands more than 2 px above the lidar's own ground (from
    :func:`ground_disparity`) against that share over the whole image, and the share of
    the built pixels (lidar-elevated and not green: green leaf index at most
    ``tree_greenness``) that an object covers, a recall, and the share of them in the
    regions each rule left out (:attr:`radcons.stages.objects.regions.HeightObjects.
    left_out`): where the recall is lost. Overlays (objects on the reference, height
    map) are written to ``--out``.

Run: ``nice .venv/bin/python benchmarks/bench_objects.py [--only demo timing ...]``
"""

from __future__ import annotations

import argparse
import functools
import os
import statistics
import time
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

from radcons.stages.association.params import AssociationParams
from radcons.stages.association.run import associate_objects, match_features
from radcons.numerics.modal import modal_disparity
from radcons.stages.association.height import associate_by_height
from radcons.numerics.census import CensusParams
from radcons.numerics.coarse_disparity import census_factor, coarse_disparity
from radcons.stages.objects.ground import ground_disparity
from radcons.stages.objects.run import ObjectsParams, extract_objects, height_objects
from radcons.stages.objects.features import object_features
from radcons.stages.objects.rules import is_tree
from radcons.stages.objects.regions import segment_elevated

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
HEIGHT = ObjectsParams(method="height")
#: Short names of the rules of :data:`radcons.stages.objects.rules.LEFT_OUT_RULES`, for the real pairs' table.
RULE_NAMES = {1: "tree", 2: "low", 3: "contrast", 4: "shadow", 5: "no edge", 6: "dark and low", 7: "green", 8: "crowns"}


def _majority(labels: np.ndarray, mask: np.ndarray) -> int:
    under = labels[mask]
    return int(np.bincount(under).argmax()) if under.size else 0


def building_ious(truth: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """For each true building, the IoU with the object that covers most of it (0 if none)."""
    out = []
    for ident in np.unique(truth[truth > 0]):
        mask = truth == ident
        under = labels[mask]
        under = under[under > 0]
        if under.size == 0:
            out.append(0.0)
            continue
        other = labels == np.bincount(under).argmax()
        out.append((mask & other).sum() / (mask | other).sum())
    return np.array(out)


def in_both_images(pair) -> np.ndarray:
    """For each true building, whether the target shows it too.

    A building the target cannot show is no object of the pair: one demolished or built
    between the dates (more than half of it in the generator's ``change_mask``), or one
    of which the target sees less than 70 % at its true disparity: pixels outside the
    target's frame (the reference's left strip, ``x - d < 0``) or hidden there (the
    generator's disparity is NaN where the target does not see the point).
    """
    truth = pair.reference_objects
    columns = np.arange(truth.shape[1])[None, :].repeat(truth.shape[0], axis=0)
    shown = []
    for ident in np.unique(truth[truth > 0]):
        mask = truth == ident
        disparity = pair.disparity[mask]
        inside = columns[mask] - np.nan_to_num(disparity, nan=np.inf) >= 0
        shown.append(pair.change_mask[mask].mean() <= 0.5 and inside.mean() >= 0.7)
    return np.array(shown, bool)


def dominant_disparity(disparities: np.ndarray) -> bool:
    """Whether at least half of an object's true disparities lie within 1 px of their mode (:func:`modal_disparity`).

    A pitched roof spreads its disparities evenly from eaves to ridge: its 1 px mode is
    then one of several near-equal bins, and its median says where the roof stands.
    """
    return bool(np.mean(np.abs(disparities - modal_disparity(disparities)) <= 1.0) >= 0.5)


def object_precision(truth: np.ndarray, labels: np.ndarray, min_px: int = 100) -> tuple[int, int]:
    """(objects of >= min_px that are a building at IoU 0.5, objects of >= min_px)."""
    good = total = 0
    for ident in np.unique(labels[labels > 0]):
        mask = labels == ident
        if mask.sum() < min_px:
            continue
        total += 1
        building = _majority(truth, mask)
        if building:
            other = truth == building
            good += int((mask & other).sum() / (mask | other).sum() >= 0.5)
    return good, total


@functools.lru_cache(maxsize=None)
def _demo_objects(size: int, scenario: str, seed: int):
    """A demo pair and its height objects (labels withheld, the pair's GSD and base-to-height ratio).

    Kept for the run: the ``demo``, ``misses`` and ``trees`` sections read the same objects, found once.
    """
    from demo_data_gen import generate

    pair = generate(size=size, seed=seed, scenario=scenario)
    meta = pair.metadata
    found = height_objects(
        pair.reference.as_float32(), pair.target.as_float32(), HEIGHT,
        gsd_m=meta["gsd_m"], base_to_height=meta["base_to_height"],
    )
    return pair, found


def _demo(args: argparse.Namespace) -> None:
    print("\n## demo pairs, labels withheld (height method; MBI = today's image-only path)\n")
    print("| pair | buildings | objects | IoU | recall@0.5 | objects that are buildings | MBI IoU | assoc. precision | D̄m within 1 px | trees out |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    totals = {
        "iou": [], "shown": [], "area_m2": [], "mbi": [], "good": 0, "found": 0, "correct": 0, "judged": 0, "d1": 0,
        "dn": 0, "changed": 0, "spread": 0, "d1_either": 0, "flat_error": [], "pitched": [],
    }
    for size in args.sizes:
        for scenario in args.scenarios:
            for seed in args.seeds:
                pair, found = _demo_objects(size, scenario, seed)
                ref, tgt = pair.reference.as_float32(), pair.target.as_float32()
                meta = pair.metadata
                matches = match_features(ref, tgt, AssociationParams())
                association = associate_by_height(
                    found.reference, found.target, found.modal_disparity, matches, AssociationParams(), found.match_score
                )
                ious = building_ious(pair.reference_objects, found.reference)
                areas = np.bincount(pair.reference_objects.ravel())[np.unique(pair.reference_objects[pair.reference_objects > 0])]
                totals["area_m2"].extend(areas * meta["gsd_m"] ** 2)
                mbi = building_ious(pair.reference_objects, extract_objects(ref, ObjectsParams()))
                good, total = object_precision(pair.reference_objects, found.reference)
                correct = judged = d1 = dn = changed = spread = d1_either = 0
                for obj in association.objects:
                    mask = found.reference == obj.ref_id
                    building = _majority(pair.reference_objects, mask)
                    if building:
                        judged += 1
                        correct += int(_majority(pair.target_objects, found.target == obj.tgt_id) == building)
                    truth = pair.disparity[mask]
                    truth = truth[np.isfinite(truth)]
                    if truth.size:
                        dn += 1
                        error = obj.modal_disparity - modal_disparity(truth)
                        near_mode = abs(error) <= 1.0
                        d1 += int(near_mode)
                        if pair.change_mask[mask].mean() > 0.5:
                            changed += 1
                            continue
                        dominant = dominant_disparity(truth)
                        spread += int(not dominant)
                        near_median = abs(obj.modal_disparity - np.median(truth)) <= 1.0
                        d1_either += int(near_mode or (not dominant and near_median))
                        on_roof = np.mean(pair.reference_objects[mask] == building) > 0.9 if building else False
                        if on_roof and np.subtract(*np.percentile(truth, (90, 10))) < 0.5:
                            totals["flat_error"].append(error)
                        elif on_roof and not dominant:
                            totals["pitched"].append((near_mode, near_median))
                print(
                    f"| {pair.name} | {ious.size} | {int(found.reference.max())} | {ious.mean():.3f} | "
                    f"{np.mean(ious >= 0.5):.2f} | {good}/{total} | {mbi.mean():.3f} | {correct}/{judged} | "
                    f"{d1}/{dn} | {found.trees} |",
                    flush=True,
                )
                totals["iou"].extend(ious)
                totals["shown"].extend(in_both_images(pair))
                totals["mbi"].extend(mbi)
                for key, value in (
                    ("good", good), ("found", total), ("correct", correct), ("judged", judged), ("d1", d1), ("dn", dn),
                    ("changed", changed), ("spread", spread), ("d1_either", d1_either),
                ):
                    totals[key] += value
    iou = np.array(totals["iou"])
    print(
        f"\n**all**: mean IoU per building {iou.mean():.3f} (MBI {np.mean(totals['mbi']):.3f}), recall@0.5 "
        f"{np.mean(iou >= 0.5):.3f}, objects that are buildings {totals['good'] / max(totals['found'], 1):.3f}, "
        f"association precision {totals['correct'] / max(totals['judged'], 1):.3f}, "
        f"D̄m within 1 px {totals['d1'] / max(totals['dn'], 1):.3f}"
    )
    others = totals["dn"] - totals["changed"]
    print(
        f"\nD̄m, read two ways more: of the {totals['dn']} associated objects, {totals['changed']} lie mostly on "
        f"ground changed between the dates (the generator's change_mask: a building built or demolished there, "
        f"so the reference's truth is not what the target shows); of the other {others}, {totals['spread']} have "
        f"no dominant disparity (under half of their true disparities within 1 px of the mode: pitched roofs, "
        f"objects spilling onto the ground). D̄m within 1 px of the mode, or of the median where no disparity "
        f"dominates, over those {others}: {totals['d1_either'] / max(others, 1):.3f}"
    )
    flat = np.abs(totals["flat_error"])
    pitched = np.array(totals["pitched"], bool).reshape(-1, 2)
    if flat.size:
        print(
            f"\nflat roofs (objects over 90 % on one building whose true disparities spread less than 0.5 px, "
            f"10th to 90th percentile): {flat.size}, D̄m off the truth by a median {np.median(flat):.2f} px, "
            f"more than 1 px for {int(np.sum(flat > 1.0))}"
        )
    if pitched.size:
        print(
            f"pitched roofs (objects over 90 % on one building, no dominant disparity): {len(pitched)}, D̄m within "
            f"1 px of the mode {int(pitched[:, 0].sum())}, of the median {int(pitched[:, 1].sum())}"
        )
    shown = np.array(totals["shown"], bool)
    print(
        f"\nbuildings the target shows too (not built or demolished between the dates, 70 % seen): "
        f"{int(shown.sum())} of {shown.size}; mean IoU {iou[shown].mean():.3f}, recall@0.5 {np.mean(iou[shown] >= 0.5):.3f}"
    )
    area = np.array(totals["area_m2"])
    print("\n| building footprint | buildings | mean IoU | recall@0.5 |\n| --- | --- | --- | --- |")
    for low, high in ((0, 100), (100, 200), (200, 400), (400, np.inf)):
        inside = (area >= low) & (area < high)
        if inside.any():
            label = f"{low:g}-{high:g} m²" if np.isfinite(high) else f">= {low:g} m²"
            print(f"| {label} | {int(inside.sum())} | {iou[inside].mean():.3f} | {np.mean(iou[inside] >= 0.5):.3f} |")


def _miss_cause(pair, found, building: int, shown: bool, gsd_m: float) -> str:
    """Why ``building`` of a demo pair has no object at IoU 0.5 (one cause, the first that fits)."""
    mask = pair.reference_objects == building
    rows, cols = np.nonzero(mask)
    height, width = mask.shape
    on_border = rows.min() == 0 or cols.min() == 0 or rows.max() == height - 1 or cols.max() == width - 1
    codes = np.bincount(found.left_out[mask], minlength=max(RULE_NAMES) + 1)
    if not shown:
        return "the target does not show it"
    if on_border and mask.sum() * gsd_m**2 < 100:
        return "under 100 m², cut by the frame"
    if codes[1:].sum() > 0.3 * mask.sum():
        return f"left out: {RULE_NAMES[int(np.argmax(codes[1:])) + 1]}"
    if np.mean(found.reference[mask] > 0) > 0.3:
        return "partly found"
    return "no object there"


def _misses(args: argparse.Namespace) -> None:
    from collections import Counter

    print("\n## demo buildings without an object at IoU 0.5, by cause (labels withheld)\n")
    for size in args.sizes:
        causes: Counter[str] = Counter()
        buildings = 0
        for scenario in args.scenarios:
            for seed in args.seeds:
                pair, found = _demo_objects(size, scenario, seed)
                gsd_m = pair.metadata["gsd_m"]
                ious = building_ious(pair.reference_objects, found.reference)
                shown = in_both_images(pair)
                idents = np.unique(pair.reference_objects[pair.reference_objects > 0])
                buildings += idents.size
                for ident, iou, seen in zip(idents, ious, shown):
                    if iou < 0.5:
                        causes[_miss_cause(pair, found, int(ident), bool(seen), gsd_m)] += 1
        missed = sum(causes.values())
        allowed = int(np.floor(0.15 * buildings))
        print(f"**{size} px, seeds {' '.join(map(str, args.seeds))}**: {buildings} buildings, {missed} missed "
              f"(recall {1 - missed / buildings:.3f}); a recall of 0.85 allows {allowed} misses\n")
        print("| cause | buildings |\n| --- | --- |")
        for cause, count in causes.most_common():
            print(f"| {cause} | {count} |")
        print()


def _trees(args: argparse.Namespace) -> None:
    print("\n## tree rule on the elevated regions (512 px pairs)\n")
    rows = []
    for scenario in args.scenarios:
        for seed in args.seeds:
            pair, found = _demo_objects(512, scenario, seed)
            ref = pair.reference.as_float32()
            gsd = pair.metadata["gsd_m"]
            area = (HEIGHT.min_area_m2 / gsd**2, HEIGHT.max_area_m2 / gsd**2)
            regions = segment_elevated(
                ref, found.height, HEIGHT.min_height_m, HEIGHT.split_jump_m, area, HEIGHT.min_elevated_share, HEIGHT.flat_edges
            )
            for ident, feature in object_features(ref, regions, found.height, max(1.0, 0.5 / gsd)).items():
                building = _majority(pair.reference_objects, regions == ident) > 0
                tree = is_tree(feature, HEIGHT, found.height.unit == "m")
                rows.append((
                    building, tree, feature["texture"], feature["rectangularity"], feature["roughness"],
                    feature["hull_rectangularity"],
                ))
    table = np.array(rows, dtype=float)
    building, tree = table[:, 0] > 0, table[:, 1] > 0
    print(f"regions {len(rows)}: buildings {int(building.sum())}, others {int((~building).sum())}")
    print(f"removed by the rule: {int(tree.sum())}, of which buildings {int((tree & building).sum())}; "
          f"others removed {int((tree & ~building).sum())}/{int((~building).sum())}")
    for name, column in (("texture", 2), ("rectangularity", 3), ("roughness", 4), ("hull rectangularity", 5)):
        print(f"median {name}: buildings {np.nanmedian(table[building, column]):.2f}, others {np.nanmedian(table[~building, column]):.2f}")


def _timing(args: argparse.Namespace) -> None:
    from demo_data_gen import generate
    from radcons.params import Params
    from radcons.pipeline import Pipeline

    pair = generate(size=1024, seed=0, scenario="mixed")
    ref, tgt = pair.reference.as_float32(), pair.target.as_float32()
    meta = pair.metadata

    def height_path() -> None:
        found = height_objects(ref, tgt, HEIGHT, gsd_m=meta["gsd_m"], base_to_height=meta["base_to_height"])
        matches = match_features(ref, tgt, AssociationParams())
        associate_by_height(found.reference, found.target, found.modal_disparity, matches, AssociationParams())

    def objects_only() -> None:
        height_objects(ref, tgt, HEIGHT, gsd_m=meta["gsd_m"], base_to_height=meta["base_to_height"])

    def mbi_path() -> None:
        labels_ref, labels_tgt = extract_objects(ref), extract_objects(tgt)
        matches = match_features(ref, tgt, AssociationParams())
        associate_objects(ref, tgt, labels_ref, labels_tgt, matches, AssociationParams())

    preset = Params.from_preset("radcons")
    params = replace(preset, objects=replace(preset.objects, method="height", use_supplied=False))

    def pipeline_path() -> None:
        Pipeline(params).run(pair, until="association")

    kept = Pipeline(params)
    kept.run(pair, until="objects")
    steps = iter(range(1, 10_000))

    def retuned_path() -> None:  # a rule's threshold changed, as in the inspector: the census matching is kept
        tuned = params.with_stage("objects", tree_texture=params.objects.tree_texture + 0.001 * next(steps))
        kept.run(pair, tuned, until="objects")

    def census_only() -> None:  # the height method's census disparity, as height_objects runs it
        factor = census_factor(ref.shape, HEIGHT.census_cell_m / meta["gsd_m"], HEIGHT.census_side)
        coarse_disparity(ref, tgt, factor, HEIGHT.search_share, CensusParams(cross_check=HEIGHT.census_cross_check))

    def sift_one_thread() -> None:  # as the pipeline runs it beside the objects
        threads = cv2.getNumThreads()
        cv2.setNumThreads(1)
        try:
            match_features(ref, tgt, AssociationParams())
        finally:
            cv2.setNumThreads(threads)

    height_path()  # Pandora's numba compile time
    print(f"\n## timing, 1024 x 1024 mixed pair, median of {args.repeat}\n")
    print("| what | median s | ratio to MBI path | CPU s, all threads |\n| --- | --- | --- | --- |")
    medians, cpu = {}, {}
    for name, call in (
        ("MBI + SIFT + template association (reference)", mbi_path),
        ("height objects only", objects_only),
        ("height objects, then SIFT association", height_path),
        ("radcons preset to the association (SIFT beside the objects)", pipeline_path),
        ("radcons preset's objects again, a rule's threshold changed (census matching kept)", retuned_path),
        ("of which: the census disparity (range-finding and final runs, cross-checked)", census_only),
        ("beside it: SIFT matches, OpenCV on one thread", sift_one_thread),
    ):
        times, used = [], []
        for _ in range(args.repeat):
            start, start_cpu = time.perf_counter(), time.process_time()
            call()
            times.append(time.perf_counter() - start)
            used.append(time.process_time() - start_cpu)
        medians[name], cpu[name] = statistics.median(times), statistics.median(used)
    reference = medians["MBI + SIFT + template association (reference)"]
    for name, value in medians.items():
        print(f"| {name} | {value:.2f} | {value / reference:.2f} | {cpu[name]:.2f} |")
    cores = os.cpu_count() or 1
    first = cpu["radcons preset to the association (SIFT beside the objects)"]
    print(
        f"\nThe preset's first run needs {first:.2f} CPU-s over all its threads: on the {cores} cores here no "
        f"overlap of its threads brings it under {first / cores:.2f} s of wall time."
    )


def _overlay(path: Path, image: np.ndarray, labels: np.ndarray, height: np.ndarray | None) -> None:
    valid = np.isfinite(image)
    low, high = np.percentile(image[valid], (1, 99))
    grey = np.clip((np.where(valid, image, low) - low) / max(high - low, 1e-9) * 255, 0, 255).astype(np.uint8)
    colour = cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)
    edges = cv2.dilate(labels.astype(np.float32), np.ones((3, 3))) != cv2.erode(labels.astype(np.float32), np.ones((3, 3)))
    colour[edges & (labels > 0)] = (0, 0, 255)
    panels = [colour]
    if height is not None:
        h = np.nan_to_num(cv2.resize(height, labels.shape[::-1], interpolation=cv2.INTER_NEAREST), nan=0.0)
        top = max(float(np.percentile(h, 99)), 1e-6)
        panels.append(cv2.applyColorMap(np.clip(h / top * 255, 0, 255).astype(np.uint8), cv2.COLORMAP_JET))
    cv2.imwrite(str(path), np.hstack(panels))


def _real(args: argparse.Namespace) -> None:
    from radcons.geometry import settle_geometry
    from radcons.io import Pair, load_pair_files, read_raster
    from radcons.params import Params
    from radcons.pipeline import Pipeline

    if not DATA.is_dir():
        print(f"\n(real pairs skipped: {DATA} is absent)")
        return
    jax = DATA / "us3d_jacksonville_multidate"
    kah = DATA / "pleiades_kahramanmaras_prepost"
    giz = DATA / "pleiades_gizeh"
    reunion = DATA / "pleiades_reunion_rectified"
    pairs = [  # name, files, lidar disparity, rectified as given
        ("Gizeh", sorted(giz.glob("*.tif"))[:2], None, None),
        ("Kahramanmaras pre1/post1", [next(kah.glob("pre_event_img1*.tif")), next(kah.glob("post_event_img1*.tif"))], None, None),
        ("Kahramanmaras pre1/pre2", [next(kah.glob("pre_event_img1*.tif")), next(kah.glob("pre_event_img2*.tif"))], None, None),
        ("Ventoux", [DATA / "pleiades_ventoux" / "left_image.tif", DATA / "pleiades_ventoux" / "right_image.tif"], None, None),
        ("Reunion", [reunion / "a.tif", reunion / "b.tif"], None, True),
    ]
    for tile in ("JAX_072_011_022", "JAX_122_019_005"):
        pairs.append((f"US3D {tile}", [jax / f"{tile}_LEFT_RGB.tif", jax / f"{tile}_RIGHT_RGB.tif"], jax / f"{tile}_LEFT_DSP.tif", True))
    args.out.mkdir(parents=True, exist_ok=True)
    print("\n## real pairs (radcons preset up to the association)\n")
    print(
        "| pair | geometry | method | objects ref / tgt | trees out | median object height | "
        "lidar-elevated share: objects / image | built pixels covered | built pixels left out, by rule | s | note |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    preset = Params.from_preset("radcons")
    params = replace(preset, objects=replace(preset.objects, method="height", use_supplied=False))
    for name, files, lidar, rectified in pairs:
        pair: Pair = settle_geometry(load_pair_files(*files, rectified=rectified))
        start = time.perf_counter()
        run = Pipeline(params).run(pair, until="association")
        seconds = time.perf_counter() - start
        objects = run.objects
        ref = run.images("original")[0]
        height = getattr(objects, "height", None)
        median = "-"
        if height is not None and objects.reference.any():
            full = height.full(ref.shape)
            median = f"{np.nanmedian(full[objects.reference > 0]):.1f} {height.unit}"
        share = covered = lost = "-"
        if lidar is not None:
            dsp = read_raster(lidar, check=False).data.astype(np.float32)
            dsp[dsp <= -999] = np.nan
            ground = ground_disparity(dsp, 400, 10.0, 2.0)
            elevated = (dsp - ground) > 2.0
            known = np.isfinite(dsp)
            inside = (objects.reference > 0) & known
            share = f"{elevated[inside].mean():.2f} / {elevated[known].mean():.2f}" if inside.any() else f"- / {elevated[known].mean():.2f}"
            green = pair.reference.greenness
            built = elevated & known & ~(np.nan_to_num(green, nan=0.0) > params.objects.tree_greenness)
            covered = f"{np.mean(objects.reference[built] > 0):.2f}" if built.any() else "-"
            codes = getattr(objects, "left_out", None)
            if codes is not None and built.any():
                shares = {RULE_NAMES[code]: np.mean(codes[built] == code) for code in RULE_NAMES}
                lost = ", ".join(f"{rule} {value:.2f}" for rule, value in shares.items() if value >= 0.005) or "-"
        count_ref, count_tgt = int(len(np.unique(objects.reference)) - 1), int(len(np.unique(objects.target)) - 1)
        print(
            f"| {name} | {getattr(run.rectification, 'method', 'affine') if run.rectification is not None else 'given'} | "
            f"{getattr(objects, 'method', objects.source)} | {count_ref} / {count_tgt} | "
            f"{getattr(objects, 'trees', '-')} | {median} | {share} | {covered} | {lost} | {seconds:.1f} | {getattr(objects, 'note', '')} |",
            flush=True,
        )
        _overlay(args.out / f"{name.replace(' ', '_').replace('/', '-')}.png", ref, objects.reference, None if height is None else height.height)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=("demo", "misses", "trees", "timing", "real"))
    parser.add_argument("--scenarios", nargs="+", default=["mixed", "multi-sensor", "multi-temporal"])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4])
    parser.add_argument("--sizes", nargs="+", type=int, default=[512, 1024])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--out", type=Path, default=Path("/tmp/bench_objects"))
    args = parser.parse_args()
    sections = args.only or ["demo", "misses", "trees", "timing", "real"]
    for name, run in (("demo", _demo), ("misses", _misses), ("trees", _trees), ("timing", _timing), ("real", _real)):
        if name in sections:
            run(args)


if __name__ == "__main__":
    main()
