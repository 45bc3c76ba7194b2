"""The ``real`` section: the real pairs through the ``radcons`` preset, objects from height."""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

from .common import DATA, RULE_NAMES, US3D, US3D_TILES, lidar_truth


def _overlay(path: Path, image: np.ndarray, labels: np.ndarray, height: np.ndarray | None) -> None:
    """The objects' outlines on the reference, beside the height map when there is one, written to ``path``."""
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


def real(args: argparse.Namespace) -> None:
    """The ``real`` section: the real pairs through the ``radcons`` preset, and the US3D tiles against their lidar."""
    from radcons.geometry import settle_geometry
    from radcons.io import Pair, load_pair_files
    from radcons.params import Params
    from radcons.pipeline import Pipeline

    if not DATA.is_dir():
        print(f"\n(real pairs skipped: {DATA} is absent)")
        return
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
    for tile in US3D_TILES:
        pairs.append((f"US3D {tile}", [US3D / f"{tile}_LEFT_RGB.tif", US3D / f"{tile}_RIGHT_RGB.tif"], US3D / f"{tile}_LEFT_DSP.tif", True))
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
            known, elevated, built = lidar_truth(pair, lidar, params.objects.tree_greenness)
            inside = (objects.reference > 0) & known
            share = f"{elevated[inside].mean():.2f} / {elevated[known].mean():.2f}" if inside.any() else f"- / {elevated[known].mean():.2f}"
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
