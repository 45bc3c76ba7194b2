"""Scene mode against the in-memory pipeline: accuracy, seams, workers, memory, time per pixel.

Rows of the table (each run in a child process; its whole process tree, Dask workers
included, is sampled every 0.1 s for the peak resident memory):

* ``in-memory``: ``radcons process`` on the demo 'mixed' pair (``--size``, default 4096),
  default preset;
* ``scene, N workers x 1 thread``: the same pair in scene mode, forced, tiles of ``--tile``
  px, on a local cluster of N workers (``--workers``, default ``1,2``; set through
  ``--memory-limit``, one worker per 768 MiB at most), each running one task at a time with
  one thread in its native pools (OpenCV, BLAS), so that the rows measure the cluster's
  scaling, not the thread pools'; pass 1 (pair-wide quantities) and pass 2 (tiles,
  overviews) times from the run's summary;
* ``mosaic scene`` (``--mosaic``): the pair mosaicked 4 x 4 (every other tile flipped upside
  down and each tile's rows rolled by its own amount, which keeps the epipolar geometry and
  repeats no tile along the same rows; object ids made unique per tile), in scene mode
  with each of the ``--workers`` counts;
* ``--smoothness SIZE``: a SIZE px pair in scene mode with and without the smoothness stage
  (us / px is also s / Mpx).

Accuracy: the rms difference of each scene output from the in-memory output, relative to
the in-memory image's range (target < 0.5 %). Seams: the absolute grey-level step between
neighbouring pixels across tile borders (rows r-1, r and columns c-1, c at every multiple
of the tile size) against the steps everywhere else; the table gives the ratio of their
means and the two-sample Kolmogorov-Smirnov statistic D between the two samples (a seam
shows as a mean ratio above 1 and a D well above that of the in-memory output, whose
"borders" are the same rows and columns but were never cut).

Run: ``nice .venv/bin/python benchmarks/bench_scene.py [--size 4096] [--tile 1024]
[--workers 1,2] [--mosaic]``
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np


def _tree_rss(pid: int) -> int:
    import psutil

    try:
        root = psutil.Process(pid)
        procs = [root, *root.children(recursive=True)]
    except psutil.NoSuchProcess:
        return 0
    total = 0
    for proc in procs:
        try:
            total += proc.memory_info().rss
        except psutil.NoSuchProcess:
            pass
    return total


def pass_times(out: Path) -> tuple[str, str]:
    """Pass 1 and pass 2 seconds of a scene run, from its summary."""
    import json

    timings = json.loads((out / "summary.json").read_text())["timings_s"]
    return f"{timings['pass1']:.1f}", f"{timings['pass2']:.1f}"


def run_child(args: list[str]) -> tuple[float, int, str]:
    """Run ``radcons`` with ``args``; return wall seconds, peak tree RSS (bytes), stderr tail."""
    start = time.perf_counter()
    child = subprocess.Popen([sys.executable, "-m", "radcons.cli", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    peak = [0]

    def sample() -> None:
        while child.poll() is None:
            peak[0] = max(peak[0], _tree_rss(child.pid))
            time.sleep(0.1)

    thread = threading.Thread(target=sample, daemon=True)
    thread.start()
    out, err = child.communicate()
    thread.join()
    seconds = time.perf_counter() - start
    if child.returncode != 0:
        raise SystemExit(f"radcons {' '.join(args)} failed ({child.returncode}):\n{err[-3000:]}")
    return seconds, peak[0], out.strip().splitlines()[-1] if out.strip() else ""


def read(path: Path) -> np.ndarray:
    import rasterio

    with rasterio.open(path) as dataset:
        return dataset.read(1)


def seam_stats(image: np.ndarray, tile: int) -> tuple[float, float]:
    """Mean |step| across tile borders over mean |step| elsewhere, and the KS statistic D."""
    from scipy.stats import ks_2samp

    image = image.astype(np.float64)
    dx = np.abs(np.diff(image, axis=1))  # dx[:, c - 1] is the step between columns c - 1 and c
    dy = np.abs(np.diff(image, axis=0))
    cols = np.arange(tile, image.shape[1], tile) - 1
    rows = np.arange(tile, image.shape[0], tile) - 1
    across = np.concatenate([dx[:, cols].ravel(), dy[rows, :].ravel()])
    mask_x = np.ones(dx.shape[1], bool)
    mask_x[cols] = False
    mask_y = np.ones(dy.shape[0], bool)
    mask_y[rows] = False
    rng = np.random.default_rng(0)
    elsewhere = np.concatenate([dx[:, mask_x].ravel(), dy[mask_y, :].ravel()])
    elsewhere = rng.choice(elsewhere, size=min(elsewhere.size, 2_000_000), replace=False)
    return float(across.mean() / elsewhere.mean()), float(ks_2samp(across, elsewhere).statistic)


def make_mosaic(pair_folder: Path, out: Path, repeat: int = 4) -> Path:
    """The pair mosaicked ``repeat`` x ``repeat``, every other tile upside down and each tile's rows
    rolled by its own amount, as tiled TIFFs."""
    import rasterio
    import tomli_w
    from rasterio.windows import Window

    from radcons.io import load_pair

    pair = load_pair(pair_folder)
    out.mkdir(parents=True, exist_ok=True)
    rows, cols = pair.shape
    sources = {
        "reference": pair.reference.data, "target": pair.target.data,
        "reference_objects": pair.reference_objects, "target_objects": pair.target_objects,
    }
    for key, data in sources.items():
        dtype = np.uint32 if key.endswith("objects") else data.dtype
        profile = {"driver": "GTiff", "height": rows * repeat, "width": cols * repeat, "count": 1, "dtype": np.dtype(dtype).name,
                   "tiled": True, "blockxsize": 256, "blockysize": 256, "BIGTIFF": "IF_SAFER"}
        with rasterio.open(out / f"{key}.tif", "w", **profile) as dataset:
            for i in range(repeat):
                for j in range(repeat):
                    block = data[::-1] if (i + j) % 2 else data
                    # rows rolled by a different amount per tile (both images alike, which keeps
                    # the epipolar geometry): no two tiles repeat along the same rows, which
                    # would fail every match's ratio test against its copy one period away
                    block = np.roll(block, (i * repeat + j) * rows // (repeat * repeat), axis=0)
                    if key.endswith("objects"):
                        block = np.where(block > 0, block.astype(np.uint32) + (i * repeat + j) * 100_000, 0)
                    dataset.write(block.astype(dtype), 1, window=Window(j * cols, i * rows, cols, rows))
    manifest = {"name": "mosaic", "rectified": True, **{key: f"{key}.tif" for key in sources}}
    (out / "pair.toml").write_text(tomli_w.dumps(manifest))
    return out


def smoothness_rows(work: Path, size: int, tile: int, workers: int) -> list[tuple]:
    """Scene runs of a ``size`` px demo pair with and without the smoothness stage; the extra time per Mpx."""
    from demo_data_gen import generate
    from radcons.io import save_pair
    from radcons.params import Params

    folder = work / f"pair{size}"
    if not (folder / "pair.toml").is_file():
        save_pair(generate(size=size, seed=0, scenario="mixed"), folder)
    params = work / "smoothness.toml"
    Params.from_preset("radcons").with_stage("smoothness", enabled=True).save(params)
    tile = min(tile, size // 2)
    base, peak_base, _ = run_child(["process", str(folder), "--out", str(work / "plain"), "--tiles", str(tile), "--quiet",
                                    "--memory-limit", _budget(workers)])
    smooth, peak, _ = run_child(["process", str(folder), "--out", str(work / "smooth"), "--tiles", str(tile), "--quiet",
                                 "--memory-limit", _budget(workers), "--params", str(params)])
    mpx = size * size / 1e6
    return [
        (f"{size} px scene, no smoothness", base, peak_base, base / mpx, *pass_times(work / "plain"), "-", "-", "-"),
        (f"{size} px scene, smoothness on ({(smooth - base) / mpx:.1f} s/Mpx more)", smooth, peak, smooth / mpx,
         *pass_times(work / "smooth"), "-", "-", "-"),
    ]


class _Rows(list):
    """Table rows, each printed as soon as it is added."""

    def append(self, row: tuple) -> None:
        name, seconds, peak, per_px, pass1, pass2, rms, ratio, ks = row
        print(f"| {name} | {seconds:.1f} | {pass1} | {pass2} | {peak / 2**30:.2f} | {per_px:.3f} | {rms} | {ratio} | {ks} |",
              flush=True)
        super().append(row)

    def extend(self, rows: list) -> None:
        for row in rows:
            self.append(row)


def _budget(workers: int) -> str:
    """A ``--memory-limit`` that gives a local cluster of ``workers`` workers (1.5 GiB each, one at 1 GiB)."""
    return "1G" if workers == 1 else f"{1.5 * workers:g}G"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=4096)
    parser.add_argument("--tile", type=int, default=1024)
    parser.add_argument("--workers", default="1,2")
    parser.add_argument("--mosaic", action="store_true", help="also the 4 x 4 mosaic of the pair in scene mode")
    parser.add_argument("--smoothness", type=int, default=0, metavar="SIZE",
                        help="also a SIZE px pair in scene mode with and without the smoothness stage")
    parser.add_argument("--work", type=Path, help="folder for the pairs and outputs (default: a temporary one)")
    args = parser.parse_args()
    from demo_data_gen import generate
    from radcons.io import save_pair

    work = args.work or Path(tempfile.mkdtemp(prefix="bench_scene_"))
    folder = work / f"pair{args.size}"
    if not (folder / "pair.toml").is_file():
        save_pair(generate(size=args.size, seed=0, scenario="mixed"), folder)
    pixels = args.size * args.size
    print(f"\n## scene mode, demo 'mixed' {args.size} px, tiles {args.tile}, radcons preset, load {os.getloadavg()[0]:.1f}\n")
    print("| run | wall (s) | pass 1 (s) | pass 2 (s) | peak RSS, process tree (GiB) | us / px | rms diff / range "
          "| border step ratio | KS D border vs rest |")
    print("|---|---|---|---|---|---|---|---|---|", flush=True)
    rows = _Rows()
    seconds, peak, _ = run_child(["process", str(folder), "--out", str(work / "memory"), "--quiet"])
    reference = {key: read(work / "memory" / f"{key}.tif") for key in ("reference", "target")}
    ratio, ks = zip(*(seam_stats(reference[key], args.tile) for key in reference))
    rows.append(("in-memory", seconds, peak, seconds / pixels * 1e6, "-", "-", "-", f"{max(ratio):.3f}", f"{max(ks):.4f}"))
    for workers in (int(w) for w in args.workers.split(",")):
        out = work / f"scene{workers}"
        seconds, peak, _ = run_child(["process", str(folder), "--out", str(out), "--tiles", str(args.tile), "--quiet",
                                      "--memory-limit", _budget(workers)])
        rms = []
        seams = []
        for key in ("reference", "target"):
            scene = read(out / f"{key}.tif").astype(np.float64)
            base = reference[key].astype(np.float64)
            rms.append(np.sqrt(np.mean((scene - base) ** 2)) / (base.max() - base.min()))
            seams.append(seam_stats(scene, args.tile))
        rows.append((f"scene, {workers} worker(s) x 1 thread", seconds, peak, seconds / pixels * 1e6, *pass_times(out),
                     f"{100 * max(rms):.3f} %", f"{max(s[0] for s in seams):.3f}", f"{max(s[1] for s in seams):.4f}"))
    if args.mosaic:
        mosaic = make_mosaic(folder, work / "mosaic")
        big = pixels * 16
        for workers in (int(w) for w in args.workers.split(",")):
            out = work / f"mosaic_out{workers}"
            seconds, peak, _ = run_child(["process", str(mosaic), "--out", str(out), "--tiles", str(args.tile),
                                          "--quiet", "--memory-limit", _budget(workers)])
            rows.append((f"mosaic 4x4 scene, {workers} worker(s)", seconds, peak, seconds / big * 1e6, *pass_times(out),
                         "-", "-", "-"))
    if args.smoothness:
        rows.extend(smoothness_rows(work, args.smoothness, args.tile, max(int(w) for w in args.workers.split(","))))
    relative = [f"{row[0]} {row[3] / rows[0][3]:.2f}" for row in rows[1:] if row[0].startswith(("scene", "mosaic"))]
    print(f"\nload at the end {os.getloadavg()[0]:.1f}; time per pixel relative to the in-memory run: " + ", ".join(relative))
    for kind in (" x 1 thread", "mosaic"):
        scaled = [row for row in rows if kind in row[0]]
        if len(scaled) > 1:
            print(f"speed-up over {scaled[0][0]}: " + ", ".join(f"{row[0]} {scaled[0][1] / row[1]:.2f}x" for row in scaled[1:]))
    print(f"work folder: {work}")


if __name__ == "__main__":
    main()
