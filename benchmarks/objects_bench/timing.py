"""The ``timing`` section: what objects from height cost against the image-only path."""

from __future__ import annotations

import argparse
import os
import statistics
import time
from dataclasses import replace

import cv2

from radcons.numerics.census import CensusParams
from radcons.numerics.coarse_disparity import census_factor, coarse_disparity
from radcons.stages.association.height import associate_by_height
from radcons.stages.association.params import AssociationParams
from radcons.stages.association.run import associate_objects, match_features
from radcons.stages.objects.run import extract_objects, height_objects

from .common import HEIGHT


def timing(args: argparse.Namespace) -> None:
    """The ``timing`` section: objects and association of the 1024 px ``mixed`` pair, against the image-only path."""
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
