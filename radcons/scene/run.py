"""A whole scene through the stages on Dask: pass 1, then tiles written into GeoTIFFs.

:func:`run_scene` is what ``radcons process`` calls in scene mode, and what an
application (the inspector's "apply to full resolution") calls with tuned parameters:
it takes a progress callback and reports the Dask dashboard's address through it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from radcons.errors import ParamsError
from radcons.params import STAGES, Params
from radcons.preflight import check_scene_options
from radcons.scene.cluster import SceneCluster
from radcons.scene.levelling import LevelledImage, level_scene_rows
from radcons.scene.pass1 import pair_quantities
from radcons.scene.source import ScenePair, open_scene_pair
from radcons.scene.tiles import TILE_STAGES, tile_grid
from radcons.scene.writer import write_scene

__all__ = ["SceneOptions", "SceneResult", "run_scene", "scene_stages", "DEFAULT_TILE"]

#: Tile side, px, of pass 2 unless asked otherwise.
DEFAULT_TILE = 1024

#: ``progress(step, done, total)``; step ``"dashboard"`` carries the address in ``done``.
Progress = Callable[[str, Any, int], None]


@dataclass(frozen=True)
class SceneOptions:
    """How a scene run is executed.

    Attributes
    ----------
    tile : int
        Tile side, px, a multiple of 64 (so that tiles are whole blocks of the output files;
        multiples of 256 give the files 256 px blocks).
    scheduler : str or None
        Address of an existing Dask scheduler; None starts a local cluster.
    workers : int or None
        Local workers (default: the cores available).
    threads : int
        Tasks each local worker runs at a time, and the threads of its native pools
        (OpenCV, BLAS, OpenMP, numba): N workers use N x ``threads`` cores.
    memory_limit : int
        Bytes the local cluster may use in all (0: Dask's default).
    processes : bool
        Local workers as processes (False: threads of this process).
    level_rows : bool
        Take the target's vertical offset out first
        (:func:`radcons.scene.levelling.level_scene_rows`, as the in-memory route does).
    """

    tile: int = DEFAULT_TILE
    scheduler: str | None = None
    workers: int | None = None
    threads: int = 1
    memory_limit: int = 0
    processes: bool = True
    level_rows: bool = True

    def __post_init__(self) -> None:
        check_scene_options(self.tile, self.scheduler)
        if self.threads < 1:
            raise ParamsError(f"threads per worker must be at least 1, got {self.threads}")


@dataclass(frozen=True)
class SceneResult:
    """What a scene run wrote and measured."""

    manifest: Path
    summary: dict[str, Any]
    dashboard: str | None


def scene_stages(params: Params, until: str | None = None) -> tuple[str, ...]:
    """The image stages a scene run does, in order.

    Raises
    ------
    ParamsError
        The uniformity stage is on (its Poisson reconstruction spans the whole image and
        has no tiled form), or a smoothed refine background (``background_smoothing``).
    """
    last = STAGES.index(until) if until is not None else len(STAGES) - 1
    if params.enabled("uniformity") and STAGES.index("uniformity") <= last:
        raise ParamsError(
            "scene mode cannot run the uniformity stage (its Poisson reconstruction spans the whole image); "
            "switch it off ([uniformity] enabled = false, as the radcons preset does)"
        )
    stages = tuple(s for s in TILE_STAGES if params.enabled(s) and STAGES.index(s) <= last)
    if "refine" in stages and params.refine.background_smoothing > 0:
        raise ParamsError(
            "scene mode has no tiled form of the smoothed background mapping "
            f"([refine] background_smoothing = {params.refine.background_smoothing:g}); set it to 0"
        )
    return stages


def _dtypes(pair: ScenePair, output_dtype: str) -> tuple[np.dtype, np.dtype]:
    ref, tgt = pair.reference.dtype, pair.target.dtype
    if ref != tgt and output_dtype == "common":
        wide = np.promote_types(ref, tgt)
        return wide, wide
    return ref, tgt


def run_scene(
    pair: ScenePair | Sequence[Path],
    out: Path,
    params: Params,
    options: SceneOptions = SceneOptions(),
    *,
    until: str | None = None,
    output_dtype: str = "own",
    progress: Progress | None = None,
) -> SceneResult:
    """Run the stages on a whole scene, tile by tile, and write the consistent pair folder.

    Parameters
    ----------
    pair : ScenePair or sequence of Path
        The scene, or a pair folder / two image files (:func:`open_scene_pair`).
    out : Path
        Output pair folder (written whole at the end, or not at all).
    params : Params
    options : SceneOptions
    until : str, optional
        Last stage to run.
    output_dtype : str
        ``"own"`` or ``"common"`` for pairs of two dtypes (as the in-memory run).
    progress : callable, optional
        ``progress(step, done, total)``: ``("dashboard", address or None, 0)`` once the
        cluster is up, the steps of pass 1, then ``("tiles", done, total)`` and
        ``("overviews", total, total)``. An exception raised by it cancels the run (the
        tasks are cancelled, ``out`` keeps its old content); an application runs
        :func:`run_scene` in a thread of its own and stays responsive.

    Returns
    -------
    SceneResult

    Raises
    ------
    InputError, ParamsError
        Bad input, an image that is blank (all nodata or one value) or not enough disk
        for the output (checked before the cluster starts), or a stage scene mode cannot run.
    StageError
        A task failed twice (the tile or block is named) or the scheduler is unreachable.
    """
    from radcons import preflight

    report = progress or (lambda step, done, total: None)
    if not isinstance(pair, ScenePair):
        pair = open_scene_pair(pair)
    for image in (pair.reference, pair.target):  # before the rows are levelled: that reads and matches
        preflight.check_scene_content(image.path, image.shape, image.band, image.nodata)
    if options.level_rows and not isinstance(pair.target, LevelledImage):
        pair = level_scene_rows(pair)
    stages = scene_stages(params, until)
    inputs = [image.path for image in (pair.reference, pair.target, pair.reference_objects, pair.target_objects) if image]
    headers = preflight.headers_of([pair.reference.path, pair.target.path])
    preflight.check_output_folder(Path(out), inputs, None, preflight.scene_output_bytes(headers))
    started = time.perf_counter()
    with SceneCluster(options.scheduler, workers=options.workers, threads=options.threads,
                      memory_limit=options.memory_limit, processes=options.processes) as cluster:
        report("dashboard", cluster.dashboard, 0)
        q, found = pair_quantities(pair, params, stages, cluster, report)
        pass1 = time.perf_counter() - started
        summary = {
            "pair": pair.name,
            "mode": "scene",
            "shape": list(pair.shape),
            "dtype": str(pair.reference.dtype),
            "rows": (pair.metadata or {}).get("rows", "not checked"),
            "stages": ["original", *stages],
            "tile": options.tile,
            "tiles": len(tile_grid(pair.shape, options.tile)),
            "workers": cluster.workers,
            "threads_per_worker": options.threads if options.scheduler is None else None,
            "global": {k: v for k, v in found["info"].items() if k in ("A",) or k.startswith(("sigma_max", "lambda"))},
            "scene": found["info"],
            "associations": [
                {"ref_id": o.ref_id, "tgt_id": o.tgt_id, "method": o.method, "modal_disparity": o.modal_disparity}
                for o in found["association"].objects
            ],
            "fits": [
                {"ref_id": f.ref_id, "tgt_id": f.tgt_id, "gain": f.gain, "offset": f.offset, "points": f.n_points,
                 "clipped_points": f.clipped, "applied": f.applied, "note": f.note}
                for f in found["fits"]
            ],
            "params": params.to_dict(),
            "timings_s": {"pass1": round(pass1, 3)},
        }
        manifest = write_scene(out, pair, q, cluster, options.tile, _dtypes(pair, output_dtype), summary, report)
        summary["timings_s"]["total"] = round(time.perf_counter() - started, 3)
        return SceneResult(manifest, summary, cluster.dashboard)
