"""Smoothness consistency stage (union group sparse model, eq 13-19): figures and speed.

Sections (all by default, or the ones named with ``--only``):

``noise``
    Multi-sensor demo pair (reference: 11-bit, read noise 8 DN; target: 8-bit, read noise
    6 DN, wider blur). The target is first brought to the reference's grey range by a gain
    and offset (equal mean and standard deviation over valid pixels), which is what the
    illumination stages do before this one, and the objects are associated from the
    ground truth (same id in both images, D̄m the most frequent rounded true disparity).
    Estimated noise sigma of each image (:func:`radcons.noise.noise_sigma`) and
    their ratio before and after the stage, and the mean gradient magnitude (Sobel / 8) on
    building borders (one pixel inside and outside the true outlines) before and after.
``denoise``
    The single-image model (:func:`group_sparse_denoise`) as a denoiser on scikit-image's
    ``camera`` with Gaussian noise of sigma 10 and 20: PSNR and time against the named
    references ``bm3d`` (the ``bm3d`` package, if installed) and scikit-image's non-local
    means (``denoise_nl_means``, fast mode, its estimated sigma, ``h = 0.8 sigma``), in
    the same process. Rows for the paper's ``c`` (default) and for SAIST's published
    constants (``c = 5.6``, ``gamma = 0.65``).
``speed``
    The whole stage on the 1024 x 1024 multi-sensor pair against the named reference
    "bm3d on both images, one after the other" (each at its estimated sigma), interleaved
    in the same process, median of ``--repeat`` runs; the ratio must stay under 1/3. Also
    the first call of the stage in a fresh interpreter, with the compiled-code cache in
    place and with an empty cache (compilation).
``preview``
    :func:`smoothness_preview` on a 512 x 512 window of the 1024 x 1024 pair: time (median)
    and CPU time in fast mode and with the stage's own parameters, and how far the fast
    result lies from the full one (RMS, against the RMS change the stage makes).
``memory``
    Peak resident memory (``ru_maxrss``) of a fresh interpreter running the stage on a
    2048 x 2048 pair, and the part of it that the stage adds (``tracemalloc`` peak).
``matching``
    Mixed demo pair (different date and sensor): the whole pipeline (objects, association,
    illumination stages) with and without this stage, then OpenCV SGBM
    (:func:`radcons.evaluate.matching.dense_disparity`); correct-matching rate (error below
    1 px) against the true disparity, over all pixels and over building pixels.

The numba kernels run on ``NUMBA_NUM_THREADS`` threads (all cores by default). Timing
sections print the load average: on a shared machine wall times stretch with it, CPU
times much less.

Run: ``.venv/bin/python benchmarks/bench_smoothness.py [--only noise speed ...] [--repeat 3]``
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import tracemalloc

import cv2
import numba
import numpy as np
import scipy.ndimage
from skimage import data
from skimage.metrics import peak_signal_noise_ratio
from skimage.restoration import denoise_nl_means, estimate_sigma

from bench_illumination import table
from radcons.io import Pair
from radcons.noise import noise_sigma
from radcons.results import Association, Matches, ObjectAssociation
from radcons.stages.smoothness.run import SmoothnessParams, group_sparse_denoise, smoothness_consistency, smoothness_preview

try:
    import bm3d
except ImportError:  # optional reference, not a project dependency
    bm3d = None

SAIST = SmoothnessParams(c=5.6, gamma=0.65)


def demo(size: int, scenario: str, seed: int = 0) -> Pair:
    from demo_data_gen import generate

    return generate(size=size, seed=seed, scenario=scenario)


def aligned_pair(pair: Pair) -> tuple[np.ndarray, np.ndarray]:
    """Reference, and target with the reference's mean and standard deviation."""
    reference = pair.reference.data.astype(np.float32)
    target = pair.target.data.astype(np.float32)
    ok_r, ok_t = np.isfinite(reference), np.isfinite(target)
    gain = reference[ok_r].std() / target[ok_t].std()
    target = (target - target[ok_t].mean()) * gain + reference[ok_r].mean()
    return reference, target.astype(np.float32)


def truth_association(pair: Pair) -> Association:
    """Buildings seen in both images, D̄m the most frequent rounded true disparity."""
    objects = []
    empty = np.zeros(0, np.int64)
    for ident in np.unique(pair.reference_objects):
        if ident == 0 or not (pair.target_objects == ident).any():
            continue
        disparity = pair.disparity[(pair.reference_objects == ident) & np.isfinite(pair.disparity)]
        if disparity.size == 0:
            continue
        values, counts = np.unique(np.rint(disparity), return_counts=True)
        objects.append(ObjectAssociation(int(ident), int(ident), "sift", float(values[counts.argmax()]), empty, empty))
    return Association(Matches.empty(), tuple(objects))


def border_gradient(image: np.ndarray, labels: np.ndarray) -> float:
    """Mean Sobel gradient magnitude (/ 8) on the one-pixel band around object outlines."""
    inside = labels > 0
    band = scipy.ndimage.binary_dilation(inside) & ~scipy.ndimage.binary_erosion(inside)
    filled = np.where(np.isfinite(image), image, np.nanmean(image)).astype(np.float32)
    gx = cv2.Sobel(filled, cv2.CV_32F, 1, 0, ksize=3) / 8
    gy = cv2.Sobel(filled, cv2.CV_32F, 0, 1, ksize=3) / 8
    return float(np.hypot(gx, gy)[band & np.isfinite(image)].mean())


def cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def run_stage(reference, target, pair, association, params=SmoothnessParams()):
    return smoothness_consistency(reference, target, pair.reference_objects, pair.target_objects, association, params)


# ---------------------------------------------------------------------------- sections


def section_noise(size: int) -> None:
    pair = demo(size, "multi-sensor")
    reference, target = aligned_pair(pair)
    association = truth_association(pair)
    rows = []
    for name, params in (("paper c (default)", SmoothnessParams()), ("SAIST constants", SAIST)):
        start = time.perf_counter()
        result = run_stage(reference, target, pair, association, params)
        seconds = time.perf_counter() - start
        info = result.info
        rows.append([
            name, f"{info['sigma_initial'][0]:.2f} / {info['sigma_initial'][1]:.2f}", info["noise_ratio_initial"],
            f"{info['sigma_final'][0]:.2f} / {info['sigma_final'][1]:.2f}", info["noise_ratio_final"],
            _before_after(border_gradient, reference, result.reference, pair.reference_objects),
            _before_after(border_gradient, target, result.target, pair.target_objects),
            seconds,
        ])
    table(
        f"noise: multi-sensor demo pair {size} x {size}, {len(association.objects)} associated buildings",
        ["params", "sigma ref / tgt before", "ratio before", "sigma ref / tgt after", "ratio after",
         "border gradient ref", "border gradient tgt", "time s"],
        rows,
    )


def _before_after(measure, before: np.ndarray, after: np.ndarray, labels: np.ndarray) -> str:
    return f"{measure(before, labels):.1f} -> {measure(after, labels):.1f}"


def section_denoise() -> None:
    clean = data.camera().astype(np.float64)
    rows = []
    for sigma in (10.0, 20.0):
        noisy = clean + np.random.default_rng(int(sigma)).normal(0.0, sigma, clean.shape)
        methods = [
            ("group sparse, paper c", lambda: group_sparse_denoise(noisy, sigma)),
            ("group sparse, SAIST constants", lambda: group_sparse_denoise(noisy, sigma, SAIST)),
            ("skimage nl-means (fast)", lambda: _nl_means(noisy)),
        ]
        if bm3d is not None:
            methods.append(("bm3d", lambda: bm3d.bm3d(noisy, sigma)))
        results = {}
        for name, method in methods:
            start = time.perf_counter()
            out = np.asarray(method(), np.float64)
            results[name] = (peak_signal_noise_ratio(clean, out, data_range=255), time.perf_counter() - start)
        best = results.get("bm3d", (math.nan, math.nan))[0]
        for name, (psnr, seconds) in results.items():
            rows.append([f"{sigma:g}", name, psnr, psnr - best, seconds])
    table("denoise: camera 512 x 512, PSNR dB (reference bm3d)", ["sigma", "method", "PSNR", "vs bm3d", "time s"], rows)


def _nl_means(noisy: np.ndarray) -> np.ndarray:
    sigma = float(estimate_sigma(noisy))
    return denoise_nl_means(
        noisy, h=0.8 * sigma, sigma=sigma, fast_mode=True, patch_size=5, patch_distance=6, preserve_range=True
    )


def section_speed(repeat: int) -> None:
    pair = demo(1024, "multi-sensor")
    reference, target = aligned_pair(pair)
    association = truth_association(pair)
    run_stage(reference[:128, :128], target[:128, :128], _crop(pair, 128), association)  # compile / load
    ours, ours_cpu, ref, ref_cpu = [], [], [], []
    load = f"{os.getloadavg()[0]:.1f}"
    for _ in range(repeat):
        start, cpu = time.perf_counter(), cpu_seconds()
        result = run_stage(reference, target, pair, association)
        ours.append(time.perf_counter() - start)
        ours_cpu.append(cpu_seconds() - cpu)
        if bm3d is not None:
            sigma_ref, sigma_tgt = result.info["sigma_initial"]
            start, cpu = time.perf_counter(), cpu_seconds()
            bm3d.bm3d(reference, sigma_ref)
            bm3d.bm3d(target, sigma_tgt)
            ref.append(time.perf_counter() - start)
            ref_cpu.append(cpu_seconds() - cpu)
    rows = [["smoothness_consistency (both images)", statistics.median(ours), statistics.median(ours_cpu), "", ""]]
    print(f"\nload average before/after: {load}, {os.getloadavg()[0]:.1f}")
    if ref:
        rows.append(
            ["bm3d on both images, one after the other", statistics.median(ref), statistics.median(ref_cpu), "", ""]
        )
        rows[0][3] = statistics.median(ours) / statistics.median(ref)
        rows[0][4] = statistics.median(ours_cpu) / statistics.median(ref_cpu)
    table(
        f"speed: multi-sensor pair 1024 x 1024, {numba.get_num_threads()} threads, median of {repeat}",
        ["", "wall s", "cpu s", "wall ratio", "cpu ratio"],
        rows,
    )
    rows = []
    for label, env in (("cache in place", {}), ("empty cache (compiles)", {"NUMBA_CACHE_DIR": tempfile.mkdtemp()})):
        rows.append([label, _fresh_first_call(env)])
    table("first call in a fresh interpreter (256 x 256 pair)", ["numba cache", "import + first call s"], rows)


_FIRST_CALL = """
import time, numpy as np
start = time.perf_counter()
from radcons.results import Association, Matches
from radcons.stages.smoothness.run import smoothness_consistency
image = np.random.default_rng(0).normal(100, 10, (256, 256)).astype(np.float32)
labels = np.zeros(image.shape, np.int32)
smoothness_consistency(image, image, labels, labels, Association(Matches.empty()))
print(time.perf_counter() - start)
"""


def _fresh_first_call(env: dict) -> float:
    out = subprocess.run(
        [sys.executable, "-c", _FIRST_CALL], env={**os.environ, **env}, capture_output=True, text=True, check=True
    )
    return float(out.stdout.strip().splitlines()[-1])


def _crop(pair: Pair, size: int) -> Pair:
    from dataclasses import replace

    return replace(
        pair, reference_objects=pair.reference_objects[:size, :size], target_objects=pair.target_objects[:size, :size]
    )


def section_preview(repeat: int) -> None:
    pair = demo(1024, "multi-sensor")
    reference, target = aligned_pair(pair)
    association = truth_association(pair)
    args = (reference, target, pair.reference_objects, pair.target_objects, association)
    sigma = (noise_sigma(reference), noise_sigma(target))
    smoothness_preview(*args, sigma=sigma, size=64)  # compile / load
    full = smoothness_preview(*args, sigma=sigma, fast=False)
    cut = full.info["window"]
    rows = []
    for fast in (True, False):
        times, cpus = [], []
        for _ in range(max(repeat, 3) if fast else 1):
            start, cpu = time.perf_counter(), cpu_seconds()
            result = smoothness_preview(*args, sigma=sigma, fast=fast)
            times.append(time.perf_counter() - start)
            cpus.append(cpu_seconds() - cpu)
        window = (slice(cut[1], cut[3]), slice(cut[0], cut[2]))
        change = math.sqrt(np.nanmean((full.target - target[window]) ** 2))
        off = math.sqrt(np.nanmean((result.target - full.target) ** 2))
        rows.append(["fast (preview_params)" if fast else "same params as the stage", statistics.median(times),
                     statistics.median(cpus), result.info["noise_ratio_final"], f"{off:.1f} / {change:.1f}"])
    table(
        f"preview: window {cut} of the 1024 x 1024 pair (load average {os.getloadavg()[0]:.1f})",
        ["mode", "median wall s", "cpu s", "noise ratio after", "target: rms off full / rms change"],
        rows,
    )


_MEMORY = """
import json, resource, tracemalloc, numpy as np
from demo_data_gen import generate
from radcons.results import Association, Matches
from radcons.stages.smoothness.run import smoothness_consistency
pair = generate(size=2048, seed=0, scenario="multi-sensor")
reference = pair.reference.data.astype(np.float32)
target = (pair.target.data.astype(np.float32) * 8.0)
labels = np.zeros(reference.shape, np.int32)
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
tracemalloc.start()
smoothness_consistency(reference, target, labels, labels, Association(Matches.empty()))
_, peak = tracemalloc.get_traced_memory()
peak_rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"rss_before": before, "rss_peak": peak_rss, "traced_peak": peak}))
"""


def section_memory() -> None:
    out = subprocess.run([sys.executable, "-c", _MEMORY], capture_output=True, text=True, check=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    table(
        "memory: the stage on a 2048 x 2048 pair (fresh interpreter)",
        ["peak RSS of the process GB", "RSS before the stage GB", "tracemalloc peak during the stage GB"],
        [[result["rss_peak"] / 2**20, result["rss_before"] / 2**20, result["traced_peak"] / 2**30]],
    )


def section_matching(size: int) -> None:
    from radcons.evaluate.matching import dense_disparity, disparity_range_from_truth
    from radcons.evaluate.rates import correct_matching_rate
    from radcons.params import Params
    from radcons.pipeline import Pipeline

    rows = []
    for seed in (0, 1, 2):
        pair = demo(size, "mixed", seed)
        search = disparity_range_from_truth(pair.disparity)
        buildings = pair.reference_objects > 0
        pipeline = Pipeline(Params())
        run = pipeline.run(pair)
        for stage, label in (
            ("original", "original"),
            ("refine", "illumination stages"),
            ("smoothness", "illumination + smoothness"),
        ):
            reference, target = run.images(stage)
            disparity = dense_disparity(reference, target, disparity_range=search)
            rows.append([seed, label, correct_matching_rate(disparity, pair.disparity),
                         correct_matching_rate(disparity, pair.disparity, buildings)])
    table(f"matching: mixed demo pairs {size} x {size}, SGBM, correct rate (< 1 px)",
          ["seed", "images", "all pixels", "building pixels"], rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=["noise", "denoise", "speed", "preview", "memory", "matching"])
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--size", type=int, default=512, help="size of the noise and matching demo pairs")
    args = parser.parse_args()
    sections = args.only or ["noise", "denoise", "speed", "preview", "memory", "matching"]
    print("bm3d:", "installed" if bm3d is not None else "not installed (its rows and ratios are skipped)")
    for name in sections:
        if name == "noise":
            section_noise(args.size)
        elif name == "denoise":
            section_denoise()
        elif name == "speed":
            section_speed(args.repeat)
        elif name == "preview":
            section_preview(args.repeat)
        elif name == "memory":
            section_memory()
        elif name == "matching":
            section_matching(args.size)


if __name__ == "__main__":
    main()
