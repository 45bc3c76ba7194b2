"""Epipolar rectification of the unrectified Pleiades pairs: accuracy, dense matching, speed.

For each pair of ``shared/data`` (``pleiades_gizeh``, ``pleiades_ventoux``) the script runs
:func:`radcons.stages.rectify.run.rectify_pair` and prints:

* the residual vertical parallax at the inlier matches (median, 90th percentile) and the
  numbers of matches and inliers;
* an independent check of the row alignment: the vertical shift between the rectified
  images measured by phase correlation (``cv2.phaseCorrelate``) on 64 px tiles (16 px
  apart) that are valid in both images, each target tile shifted horizontally by the
  median disparity of the matches inside it, median and 90th percentile of ``|dy|``;
* dense matching: the share of the overlap (pixels valid in both rectified images) that
  ``cv2.StereoSGBM`` (8-bit over the pair's common range, search range from the matches)
  gives a disparity; disparities pointing at an invalid target pixel are dropped;
* speed, median of 3 runs (the two methods alternate), against the named reference "opencv-projective": the same SIFT
  matches, ``cv2.findFundamentalMat`` (FM_RANSAC, projective F) and
  ``cv2.stereoRectifyUncalibrated`` with two ``cv2.warpPerspective``, measured in the same
  process; its residual parallax at its own inliers is printed beside ours.

It also writes, per pair, ``/tmp/rectify_<pair>_pair.png`` (the rectified pair side by
side), ``/tmp/rectify_<pair>_disparity.png`` (SGBM disparity, colour-mapped, black =
unknown) and ``/tmp/rectify_<pair>_disparity_original.png`` (the same map taken back to the
original reference geometry).

Run: ``.venv/bin/python benchmarks/bench_rectify.py [--data DIR]``
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import tifffile

from radcons.stages.rectify.run import RectifyParams, Rectification, match_sift, rectify_pair

PAIRS = {
    "gizeh": ("pleiades_gizeh", "img1.tif", "img2.tif"),
    "ventoux": ("pleiades_ventoux", "left_image.tif", "right_image.tif"),
}
REPEATS = 3
TILE = 64


def _default_data() -> Path:
    return Path(__file__).resolve().parents[1].parent / "shared" / "data"


def to_uint8_common(reference: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both images as 8 bits over their common range (0.5th-99.5th percentile of both)."""
    values = np.concatenate([reference[np.isfinite(reference)], target[np.isfinite(target)]])
    lo, hi = np.percentile(values, [0.5, 99.5])
    scale = 255.0 / max(hi - lo, 1e-6)
    return tuple(
        np.clip((np.nan_to_num(im, nan=lo) - lo) * scale, 0, 255).astype(np.uint8) for im in (reference, target)
    )


def sgbm(rect: Rectification, margin: int = 8, block: int = 5) -> np.ndarray:
    """SGBM disparity of the rectified pair in the reference frame, NaN where unknown."""
    left, right = to_uint8_common(rect.reference, rect.target)
    low, high = rect.disparity_range
    min_disp = int(np.floor(low)) - margin
    num = int(np.ceil((high - min_disp + margin) / 16.0)) * 16
    matcher = cv2.StereoSGBM_create(
        minDisparity=min_disp,
        numDisparities=num,
        blockSize=block,
        P1=8 * block**2,
        P2=32 * block**2,
        uniquenessRatio=10,
        speckleWindowSize=100,
        speckleRange=2,
        disp12MaxDiff=1,
        mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY,
    )
    raw = matcher.compute(left, right).astype(np.float32) / 16.0
    disparity = np.where(raw < min_disp, np.nan, raw).astype(np.float32)
    rows, cols = np.indices(rect.shape)
    matched_col = np.round(cols - np.nan_to_num(disparity)).astype(int)
    inside = (matched_col >= 0) & (matched_col < rect.shape[1])
    target_valid = np.zeros(rect.shape, bool)
    target_valid[inside] = np.isfinite(rect.target[rows[inside], matched_col[inside]])
    disparity[~(np.isfinite(rect.reference) & target_valid)] = np.nan
    return disparity


def tile_dy(rect: Rectification) -> np.ndarray:
    """|dy| between the rectified images by phase correlation on fully valid 64 px tiles, 16 px apart."""
    ref_xy, disp = rect.matches.ref_xy, rect.matches.disparity
    window = cv2.createHanningWindow((TILE, TILE), cv2.CV_64F)
    rows, cols = rect.shape
    out = []
    for y0 in range(0, rows - TILE + 1, TILE // 4):
        for x0 in range(0, cols - TILE + 1, TILE // 4):
            inside = np.all((ref_xy >= (x0, y0)) & (ref_xy < (x0 + TILE, y0 + TILE)), axis=1)
            if not inside.any():
                continue
            shift = int(round(float(np.median(disp[inside]))))
            xt = x0 - shift
            if xt < 0 or xt + TILE > cols:
                continue
            a = rect.reference[y0 : y0 + TILE, x0 : x0 + TILE].astype(np.float64)
            b = rect.target[y0 : y0 + TILE, xt : xt + TILE].astype(np.float64)
            if not (np.isfinite(a).all() and np.isfinite(b).all()):
                continue
            (_, dy), response = cv2.phaseCorrelate(a, b, window)
            if response > 0.1:
                out.append(abs(dy))
    return np.asarray(out)


def opencv_projective(
    reference: np.ndarray, target: np.ndarray, params: RectifyParams
) -> tuple[float, float, int]:
    """The reference route: projective F, Hartley's uncalibrated rectification, warps."""
    matches = match_sift(reference, target, params)
    f, mask = cv2.findFundamentalMat(
        matches.ref_xy, matches.tgt_xy, cv2.FM_RANSAC, params.ransac_threshold, 0.999, params.ransac_trials
    )
    keep = mask.ravel().astype(bool)
    ok, h_ref, h_tgt = cv2.stereoRectifyUncalibrated(
        matches.ref_xy[keep], matches.tgt_xy[keep], f, reference.shape[::-1]
    )
    if not ok:
        raise RuntimeError("cv2.stereoRectifyUncalibrated failed")
    size = (reference.shape[1], reference.shape[0])
    for image, h in ((reference, h_ref), (target, h_tgt)):
        cv2.warpPerspective(np.nan_to_num(image), h, size, flags=cv2.INTER_CUBIC)
    ref_r = cv2.perspectiveTransform(matches.ref_xy[keep][None].astype(np.float64), h_ref)[0]
    tgt_r = cv2.perspectiveTransform(matches.tgt_xy[keep][None].astype(np.float64), h_tgt)[0]
    parallax = np.abs(ref_r[:, 1] - tgt_r[:, 1])
    return float(np.median(parallax)), float(np.percentile(parallax, 90)), int(keep.sum())


def _colour(disparity: np.ndarray) -> np.ndarray:
    valid = np.isfinite(disparity)
    lo, hi = np.percentile(disparity[valid], [2, 98])
    scaled = np.clip((np.nan_to_num(disparity, nan=lo) - lo) / max(hi - lo, 1e-6) * 255, 0, 255).astype(np.uint8)
    colour = cv2.applyColorMap(scaled, cv2.COLORMAP_TURBO)
    colour[~valid] = 0
    return colour


def _timed_pair(ours, reference, *args) -> tuple[float, float, object, object]:
    """Median seconds of two functions run alternately (fair under a varying load), and results."""
    times: dict[int, list[float]] = {0: [], 1: []}
    results = [None, None]
    for _ in range(REPEATS):
        for index, function in enumerate((ours, reference)):
            start = time.perf_counter()
            results[index] = function(*args)
            times[index].append(time.perf_counter() - start)
    return statistics.median(times[0]), statistics.median(times[1]), results[0], results[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=_default_data(), help="the shared data folder")
    args = parser.parse_args(argv)
    if not args.data.is_dir():
        print(f"data folder {args.data} not found", file=sys.stderr)
        return 1
    params = RectifyParams()
    header = (
        f"{'pair':8} {'shape':>10} {'matches':>7} {'inliers':>7} {'par.med':>7} {'par.p90':>7} "
        f"{'tile|dy|med':>11} {'tile|dy|p90':>11} {'tiles':>5} {'disp.range':>14} {'sgbm.valid':>10} "
        f"{'t.ours s':>8} {'t.ref s':>7} {'ratio':>6} {'ref.par.med':>11} {'ref.par.p90':>11}"
    )
    print(header)
    for name, (folder, left, right) in PAIRS.items():
        reference = tifffile.imread(args.data / folder / left).astype(np.float32)
        target = tifffile.imread(args.data / folder / right).astype(np.float32)
        t_ours, t_ref, rect, (ref_med, ref_p90, _) = _timed_pair(
            rectify_pair, opencv_projective, reference, target, params
        )
        dy = tile_dy(rect)
        disparity = sgbm(rect)
        overlap = np.isfinite(rect.reference) & np.isfinite(rect.target)
        sgbm_valid = np.isfinite(disparity[overlap]).mean()
        low, high = rect.disparity_range
        print(
            f"{name:8} {f'{rect.shape[0]}x{rect.shape[1]}':>10} {rect.n_matches:7d} {rect.n_inliers:7d} "
            f"{rect.residual_parallax_median:7.3f} {rect.residual_parallax_p90:7.3f} "
            f"{np.median(dy):11.3f} {np.percentile(dy, 90):11.3f} {dy.size:5d} {f'{low:.1f}..{high:.1f}':>14} "
            f"{sgbm_valid:10.3f} {t_ours:8.2f} {t_ref:7.2f} {t_ours / t_ref:6.2f} {ref_med:11.3f} {ref_p90:11.3f}"
        )
        left8, right8 = to_uint8_common(rect.reference, rect.target)
        cv2.imwrite(f"/tmp/rectify_{name}_pair.png", np.hstack([left8, right8]))
        cv2.imwrite(f"/tmp/rectify_{name}_disparity.png", _colour(disparity))
        cv2.imwrite(f"/tmp/rectify_{name}_disparity_original.png", _colour(rect.disparity_to_original(disparity)))
    print("par = |y_ref - y_tgt| at inlier matches, px; tile |dy| = phase correlation on 64 px tiles, px;")
    print("ratio = t.ours / t.ref, reference 'opencv-projective' (findFundamentalMat + stereoRectifyUncalibrated)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
