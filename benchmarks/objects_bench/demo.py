"""The ``demo``, ``misses`` and ``trees`` sections: objects from height against the demo generator's buildings."""

from __future__ import annotations

import argparse

import numpy as np

from radcons.numerics.modal import modal_disparity
from radcons.stages.association.height import associate_by_height
from radcons.stages.association.params import AssociationParams
from radcons.stages.association.run import match_features
from radcons.stages.objects.features import object_features
from radcons.stages.objects.regions import segment_elevated
from radcons.stages.objects.rules import is_tree
from radcons.stages.objects.run import ObjectsParams, extract_objects

from .common import (
    HEIGHT,
    RULE_NAMES,
    building_ious,
    demo_objects,
    dominant_disparity,
    in_both_images,
    majority,
    object_precision,
)


def demo(args: argparse.Namespace) -> None:
    """The ``demo`` section: objects from height against the demo generator's buildings."""
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
                pair, found = demo_objects(size, scenario, seed)
                _pair_figures(pair, found, totals)
    _print_totals(totals)


def _pair_figures(pair, found, totals: dict) -> None:
    """One demo pair's row of the ``demo`` table; its figures are added to ``totals``."""
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
        building = majority(pair.reference_objects, mask)
        if building:
            judged += 1
            correct += int(majority(pair.target_objects, found.target == obj.tgt_id) == building)
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


def _print_totals(totals: dict) -> None:
    """The ``demo`` section's figures over all its pairs, and by the buildings' footprint."""
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


def misses(args: argparse.Namespace) -> None:
    """The ``misses`` section: the demo buildings no object finds, by cause."""
    from collections import Counter

    print("\n## demo buildings without an object at IoU 0.5, by cause (labels withheld)\n")
    for size in args.sizes:
        causes: Counter[str] = Counter()
        buildings = 0
        for scenario in args.scenarios:
            for seed in args.seeds:
                pair, found = demo_objects(size, scenario, seed)
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


def trees(args: argparse.Namespace) -> None:
    """The ``trees`` section: what the tree rule removes of the 512 px pairs' elevated regions."""
    print("\n## tree rule on the elevated regions (512 px pairs)\n")
    rows = []
    for scenario in args.scenarios:
        for seed in args.seeds:
            pair, found = demo_objects(512, scenario, seed)
            ref = pair.reference.as_float32()
            gsd = pair.metadata["gsd_m"]
            area = (HEIGHT.min_area_m2 / gsd**2, HEIGHT.max_area_m2 / gsd**2)
            regions = segment_elevated(
                ref, found.height, HEIGHT.min_height_m, HEIGHT.split_jump_m, area, HEIGHT.min_elevated_share, HEIGHT.flat_edges
            )
            for ident, feature in object_features(ref, regions, found.height, max(1.0, 0.5 / gsd)).items():
                building = majority(pair.reference_objects, regions == ident) > 0
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


