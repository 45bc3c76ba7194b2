"""Object extraction, association and illumination stages: accuracy and speed.

Sections (all by default, or the ones named with ``--only``):

``objects``
    Matched-object IoU of :func:`extract_objects` against the demo ground-truth building
    labels: for each true building, the IoU with the extracted object that covers most of
    it (0 if none); mean IoU and share of buildings above 0.5, per scenario, both images.
``association``
    Object pairs of :func:`associate_objects` against the ground truth (the demo gives a
    building the same id in both images), with the ground-truth labels as input and with
    extracted labels (an extracted object stands for the true building covering most of
    it). Precision: correct pairs / pairs with a target object; recall: correct pairs /
    buildings seen in both images (extracted labels: / extracted reference objects whose
    building is seen in the target). ``D within 1 px``: share of correct pairs whose D̄m
    is within 1 px of the median true disparity inside the reference object.
``consistency``
    Mean absolute grey difference between reference and target inside associated
    buildings (ground-truth labels), pixel to pixel through the true disparity, outside
    the change mask and occlusions, per building then averaged, after each stage:
    original, uniformity, global, refine (paper: invariant match points) and refine with
    ``RefineParams(points="dense")``. Also in units of the reference's standard
    deviation inside buildings (so the original's range difference does not dominate).
``timing``
    Median of several runs of each stage on 1024 x 1024 and 2048 x 2048 demo pairs, the
    whole chain, and the 2048 / 1024 ratio.
``global``
    :func:`largest_singular_value` and :func:`global_normalisation` on an 8192 x 8192
    float32 image: time and extra memory (``tracemalloc``, which numpy reports to), against
    the named reference "numpy full SVD" on a 1024 x 1024 image measured in the same
    process (also its agreement with the full SVD).
``real``
    Each stage on the real pairs of ``shared/data``: objects found, matches, associations,
    timings, and the mean absolute difference of the images at the matches after each
    stage (the matches are the only correspondences without ground truth).

Run: ``.venv/bin/python benchmarks/bench_illumination.py [--only objects timing ...]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
import tracemalloc
from pathlib import Path

import numpy as np

from radcons.io import Pair, read_raster
from radcons.pipeline import pair_images
from radcons.results import Association
from radcons.stages.association.params import AssociationParams
from radcons.stages.association.run import associate_objects, match_features
from radcons.stages.global_norm.run import global_normalisation, largest_singular_value, pair_mean
from radcons.stages.objects.run import ObjectsParams, extract_objects
from radcons.stages.refine.run import RefineParams, refine_target
from radcons.stages.uniformity.run import UniformityParams, illumination_uniformity

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def demo(size: int, seed: int, scenario: str) -> Pair:
    from demo_data_gen import generate

    return generate(size=size, seed=seed, scenario=scenario)


def table(title: str, header: list[str], rows: list[list]) -> None:
    print(f"\n## {title}\n")
    print("| " + " | ".join(header) + " |")
    print("|" + "|".join("---" for _ in header) + "|")
    for row in rows:
        cells = [f"{c:.3f}" if isinstance(c, float) else str(c) for c in row]
        print("| " + " | ".join(cells) + " |", flush=True)


# ------------------------------------------------------------------------ the chain


def chain(reference, target, labels_ref, labels_tgt, rectified=True, params=None):
    """Run objects-free chain: association, uniformity, global, refine; images and times."""
    params = params or {}
    times = {}
    t = time.perf_counter()
    matches = match_features(reference, target, params.get("association", AssociationParams()), rectified)
    association = associate_objects(
        reference, target, labels_ref, labels_tgt, matches, params.get("association", AssociationParams())
    )
    times["association"] = time.perf_counter() - t
    t = time.perf_counter()
    uparams = params.get("uniformity", UniformityParams())
    uni = (illumination_uniformity(reference, uparams), illumination_uniformity(target, uparams))
    times["uniformity"] = time.perf_counter() - t
    t = time.perf_counter()
    a = pair_mean(*uni)
    glob = (global_normalisation(uni[0], a)[0], global_normalisation(uni[1], a)[0])
    times["global"] = time.perf_counter() - t
    t = time.perf_counter()
    refined, fits = refine_target(glob[0], glob[1], labels_tgt, association, params.get("refine", RefineParams()))
    times["refine"] = time.perf_counter() - t
    stages = {"original": (reference, target), "uniformity": uni, "global": glob, "refine": (glob[0], refined)}
    if "refine_dense" in params:
        dense, _ = refine_target(glob[0], glob[1], labels_tgt, association, params["refine_dense"])
        stages["refine (dense points)"] = (glob[0], dense)
    return stages, association, fits, times


# ---------------------------------------------------------------------- objects IoU


def matched_iou(truth: np.ndarray, labels: np.ndarray) -> np.ndarray:
    t, p = truth.ravel().astype(np.int64), labels.ravel().astype(np.int64)
    width = int(p.max()) + 1
    counts = np.bincount(t * width + p, minlength=(int(t.max()) + 1) * width).reshape(-1, width)
    area_t, area_p = counts.sum(1), counts.sum(0)
    ious = []
    for i in range(1, counts.shape[0]):
        if area_t[i] == 0:
            continue
        row = counts[i, 1:]
        if row.max() == 0:
            ious.append(0.0)
            continue
        j = int(np.argmax(row)) + 1
        ious.append(counts[i, j] / (area_t[i] + area_p[j] - counts[i, j]))
    return np.array(ious)


def section_objects(seeds, size):
    rows = []
    for scenario in ("mixed", "multi-temporal", "none"):
        ious, count, truth_count, secs = [], [], [], []
        for seed in seeds:
            pair = demo(size, seed, scenario)
            for image, truth in zip(pair_images(pair), (pair.reference_objects, pair.target_objects)):
                t = time.perf_counter()
                labels = extract_objects(image)
                secs.append(time.perf_counter() - t)
                ious.append(matched_iou(truth, labels))
                count.append(labels.max())
                truth_count.append(len(np.unique(truth)) - 1)
        iou = np.concatenate(ious)
        rows.append([scenario, size, len(seeds), float(iou.mean()), float((iou > 0.5).mean()),
                     float(np.mean(count)), float(np.mean(truth_count)), float(np.median(secs))])
    table("objects: matched IoU against the demo building labels",
          ["scenario", "size", "seeds", "mean IoU", "share IoU>0.5", "objects/image", "buildings/image", "s/image"], rows)


# ------------------------------------------------------------------ association P/R


def _majority(labels: np.ndarray, truth: np.ndarray) -> dict[int, int]:
    """Extracted id -> the true id covering most of it (0 if mostly background)."""
    out = {}
    lab, tru = labels.ravel(), truth.ravel()
    sel = lab > 0
    width = int(tru.max()) + 1
    counts = np.bincount(lab[sel].astype(np.int64) * width + tru[sel], minlength=(int(lab.max()) + 1) * width)
    counts = counts.reshape(-1, width)
    for i in range(1, counts.shape[0]):
        if counts[i].sum():
            out[i] = int(np.argmax(counts[i]))
    return out


def score_association(association: Association, labels_ref, labels_tgt, pair: Pair):
    gt_ref, gt_tgt = pair.reference_objects, pair.target_objects
    ref_to_true = _majority(labels_ref, gt_ref)
    tgt_to_true = _majority(labels_tgt, gt_tgt)
    in_target = set(np.unique(gt_tgt)) - {0}
    candidates = {i for i, t in ref_to_true.items() if t in in_target and t > 0}
    claimed = [o for o in association.objects if o.tgt_id > 0]
    correct = [o for o in claimed if ref_to_true.get(o.ref_id, 0) > 0
               and ref_to_true[o.ref_id] == tgt_to_true.get(o.tgt_id, -1)]
    disparity_ok = []
    for o in correct:
        d = pair.disparity[labels_ref == o.ref_id]
        d = d[np.isfinite(d)]
        if d.size:
            disparity_ok.append(abs(o.modal_disparity - float(np.median(d))) <= 1.0)
    precision = len(correct) / len(claimed) if claimed else float("nan")
    recall = len({o.ref_id for o in correct} & candidates) / len(candidates) if candidates else float("nan")
    sift = sum(o.method == "sift" for o in association.objects)
    return precision, recall, float(np.mean(disparity_ok)) if disparity_ok else float("nan"), sift, len(association.objects)


def section_association(seeds, size):
    rows = []
    for scenario in ("mixed", "multi-temporal"):
        for source in ("truth labels", "extracted labels"):
            scores = []
            for seed in seeds:
                pair = demo(size, seed, scenario)
                reference, target = pair_images(pair)
                if source == "truth labels":
                    labels_ref, labels_tgt = pair.reference_objects, pair.target_objects
                else:
                    labels_ref, labels_tgt = extract_objects(reference), extract_objects(target)
                matches = match_features(reference, target)
                association = associate_objects(reference, target, labels_ref, labels_tgt, matches)
                scores.append(score_association(association, labels_ref, labels_tgt, pair))
            s = np.array(scores, float)
            rows.append([scenario, source, float(np.nanmean(s[:, 0])), float(np.nanmean(s[:, 1])),
                         float(np.nanmean(s[:, 2])), f"{int(s[:, 3].sum())}/{int(s[:, 4].sum())}"])
    table(f"association against ground-truth building ids ({size} px, seeds {list(seeds)})",
          ["scenario", "input labels", "precision", "recall", "D within 1 px", "sift / all pairs"], rows)


# ----------------------------------------------------------------- consistency MAD


def object_mad(reference, target, pair: Pair, ids) -> tuple[float, float]:
    """Mean over buildings of the mean |ref(x, y) - tgt(x - d, y)| (and / ref std)."""
    gt_ref, gt_tgt = pair.reference_objects, pair.target_objects
    rows, cols = np.indices(gt_ref.shape)
    d = pair.disparity
    ok = np.isfinite(d) & ~pair.change_mask
    tx = np.rint(cols - np.where(ok, d, 0)).astype(int)
    ok &= (tx >= 0) & (tx < gt_ref.shape[1])
    tx = np.clip(tx, 0, gt_ref.shape[1] - 1)
    same = ok & (gt_tgt[rows, tx] == gt_ref)
    inside = np.isin(gt_ref, list(ids)) & same
    spread = float(np.nanstd(reference[inside])) or 1.0
    values = []
    for i in ids:
        m = same & (gt_ref == i)
        diff = np.abs(reference[m] - target[rows[m], tx[m]])
        diff = diff[np.isfinite(diff)]
        if diff.size:
            values.append(float(diff.mean()))
    mad = float(np.mean(values))
    return mad, mad / spread


def section_consistency(seeds, size):
    rows = []
    for scenario in ("mixed", "multi-temporal", "multi-sensor"):
        per_stage = {}
        for seed in seeds:
            pair = demo(size, seed, scenario)
            reference, target = pair_images(pair)
            stages, association, fits, _ = chain(
                reference, target, pair.reference_objects, pair.target_objects,
                params={"refine_dense": RefineParams(points="dense")},
            )
            ids = {o.ref_id for o in association.objects if o.tgt_id == o.ref_id}
            for name, (ref, tgt) in stages.items():
                per_stage.setdefault(name, []).append(object_mad(ref, tgt, pair, ids))
        for name, values in per_stage.items():
            v = np.array(values)
            rows.append([scenario, name, float(v[:, 0].mean()), float(v[:, 1].mean())])
    table(f"consistency inside associated buildings, truth labels ({size} px, seeds {list(seeds)})",
          ["scenario", "after stage", "mean |ref - tgt|", "in ref std units"], rows)


# -------------------------------------------------------------------------- timing


def section_timing(runs):
    rows, totals = [], {}
    for size in (1024, 2048):
        pair = demo(size, 0, "mixed")
        reference, target = pair_images(pair)
        samples = {}
        for _ in range(runs):
            t = time.perf_counter()
            labels_ref, labels_tgt = extract_objects(reference), extract_objects(target)
            objects_time = time.perf_counter() - t
            _, association, _, times = chain(reference, target, labels_ref, labels_tgt)
            times = {"objects": objects_time, **times}
            times["chain"] = sum(times.values())
            for k, v in times.items():
                samples.setdefault(k, []).append(v)
        medians = {k: statistics.median(v) for k, v in samples.items()}
        totals[size] = medians
        for k, v in medians.items():
            rows.append([size, k, v])
    for k in totals[1024]:
        rows.append(["2048/1024", k, totals[2048][k] / totals[1024][k]])
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    table(f"timing, median of {runs} runs (s), demo 'mixed' seed 0, {os.cpu_count()} cores, "
          f"load average at the end {load}", ["size", "stage", "seconds"], rows)


# ------------------------------------------------------------------- global 8192


def section_global():
    rng = np.random.default_rng(0)
    size = 8192
    image = np.empty((size, size), np.float32)
    for start in range(0, size, 1024):  # smooth-ish positive content, built in strips
        block = rng.random((1024, size), dtype=np.float32)
        image[start : start + 1024] = 200 + 100 * block
    rows = []
    times, peaks = [], []
    for _ in range(3):
        tracemalloc.start()
        t = time.perf_counter()
        sigma = largest_singular_value(image)
        out, lam = global_normalisation(image, 250.0, sigma)
        times.append(time.perf_counter() - t)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
        del out
    rows.append(["radcons sigma_max + lambda*I", "8192x8192", statistics.median(times),
                 f"{max(peaks) / 2**20:.0f} MiB (output {size * size * 4 / 2**20:.0f})"])
    small = image[:1024, :1024].copy()
    t = time.perf_counter()
    full = np.linalg.svd(small, compute_uv=False)[0]
    svd_time = time.perf_counter() - t
    t = time.perf_counter()
    ours = largest_singular_value(small)
    ours_time = time.perf_counter() - t
    rows.append(["numpy full SVD (reference)", "1024x1024", svd_time, f"sigma {full:.6g}"])
    rows.append(["radcons sigma_max", "1024x1024", ours_time,
                 f"sigma {ours:.6g}, rel. diff {abs(ours - full) / full:.1e}, {svd_time / ours_time:.0f}x faster"])
    table("global step: time and memory", ["what", "size", "seconds", "memory / note"], rows)


# ------------------------------------------------------------------------ real data


def _mad_at_matches(reference, target, matches) -> float:
    from radcons.stages.refine.run import sample_bilinear

    a = sample_bilinear(reference, matches.ref_xy)
    b = sample_bilinear(target, matches.tgt_xy)
    ok = np.isfinite(a) & np.isfinite(b)
    return float(np.mean(np.abs(a[ok] - b[ok]))) if ok.any() else float("nan")


def section_real():
    pairs = [
        ("pleiades_reunion_rectified", "a.tif", "b.tif", True),
        ("middlebury_cones", "left.tif", "right.tif", True),
        ("pleiades_gizeh", "img1.tif", "img2.tif", False),
    ]
    rows = []
    for folder, a, b, rectified in pairs:
        if not (DATA / folder).is_dir():
            rows.append([folder, "absent", "", "", "", "", ""])
            continue
        reference = read_raster(DATA / folder / a).data.astype(np.float32)
        target = read_raster(DATA / folder / b).data.astype(np.float32)
        t = time.perf_counter()
        labels_ref, labels_tgt = extract_objects(reference), extract_objects(target)
        objects_time = time.perf_counter() - t
        if reference.shape != target.shape:  # unrectified pair of different sizes: crop to common
            h, w = min(reference.shape[0], target.shape[0]), min(reference.shape[1], target.shape[1])
            reference, target = reference[:h, :w], target[:h, :w]
            labels_ref, labels_tgt = labels_ref[:h, :w], labels_tgt[:h, :w]
        stages, association, fits, times = chain(reference, target, labels_ref, labels_tgt, rectified)
        mads = " / ".join(f"{_mad_at_matches(r, g, association.matches):.1f}" for r, g in stages.values())
        methods = f"{sum(o.method == 'sift' for o in association.objects)} sift, " \
                  f"{sum(o.method == 'template' for o in association.objects)} template, " \
                  f"{len(association.unassociated_ref)} none"
        rows.append([folder, f"{labels_ref.max()} / {labels_tgt.max()}", len(association.matches), methods,
                     f"{sum(f.applied for f in fits)}/{len(fits)}", mads,
                     f"{objects_time:.2f} + " + " + ".join(f"{v:.2f}" for v in times.values())])
    table("real pairs (shared/data)",
          ["pair", "objects ref / tgt", "matches", "associations", "fits applied",
           "MAD at matches: orig / unif / global / refine", "s: objects + assoc + unif + global + refine"], rows)


def main() -> None:
    sections = ["objects", "association", "consistency", "timing", "global", "real"]
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--only", nargs="*", choices=sections, default=sections)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--size", type=int, default=512, help="demo size for the accuracy sections")
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    seeds = range(args.seeds)
    for name in args.only:
        if name == "objects":
            section_objects(seeds, args.size)
        elif name == "association":
            section_association(seeds, args.size)
        elif name == "consistency":
            section_consistency(seeds, args.size)
        elif name == "timing":
            section_timing(args.runs)
        elif name == "global":
            section_global()
        elif name == "real":
            section_real()


if __name__ == "__main__":
    main()
