"""Writing a scene result: two tiled GeoTIFFs filled tile by tile, swapped in whole.

The output folder is assembled beside its final name (:func:`radcons.io.staged_folder`):
``reference.tif`` and ``target.tif`` (tiled, deflate, BigTIFF when needed, the inputs'
georeferencing, overviews), ``summary.json`` and the ``pair.toml`` manifest last. A run
stopped half-way leaves nothing under the final name; a run killed outright leaves a
staging folder that the next run removes before it starts.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from radcons.io import MANIFEST, atomic_write_bytes, staged_folder
from radcons.io.gdal import finish_tiled_gdal, open_tiled_gdal
from radcons.scene.cluster import SceneCluster
from radcons.scene.source import ScenePair, Window
from radcons.scene.tiles import SceneQuantities, output_tile
from radcons.summary import json_safe

__all__ = ["write_scene"]


def _manifest(pair: ScenePair, final_stage: str) -> bytes:
    import tomli_w

    manifest: dict[str, Any] = {"name": pair.name, "reference": "reference.tif", "target": "target.tif", "rectified": True}
    nodata = pair.reference.nodata
    if nodata is not None and not math.isnan(float(nodata)):
        manifest["nodata"] = int(nodata) if float(nodata).is_integer() else float(nodata)
    manifest["metadata"] = json_safe({**(pair.metadata or {}), "processed_by": "radcons (scene mode)", "final_stage": final_stage})
    return tomli_w.dumps(manifest).encode("utf-8")


def write_scene(
    out: Path,
    pair: ScenePair,
    q: SceneQuantities,
    cluster: SceneCluster,
    tiles: Sequence[Window],
    dtypes: tuple[np.dtype, np.dtype],
    summary: dict[str, Any],
    progress: Callable[[str, int, int], None],
) -> Path:
    """Process every tile on the cluster and write the consistent pair folder ``out``.

    ``summary`` is written as ``summary.json`` with its ``timings_s`` given ``pass2``
    (the tiles and overviews, seconds).

    Returns
    -------
    Path
        The written manifest.

    Raises
    ------
    StageError
        A tile failed twice (named in the message); ``out`` is left as it was.
    """
    started = time.perf_counter()
    shared = cluster.scatter(q)
    with staged_folder(out) as staging:
        datasets = [
            open_tiled_gdal(staging / f"{key}.tif", pair.shape, dtype, image.gdal, image.nodata)
            for key, image, dtype in (("reference", pair.reference, dtypes[0]), ("target", pair.target, dtypes[1]))
        ]
        try:
            from rasterio.windows import Window as RasterWindow

            for done, (index, images) in enumerate(
                cluster.as_completed(output_tile, tiles, pair, shared, dtypes, what="tile"), start=1
            ):
                r0, r1, c0, c1 = tiles[index]
                for dataset, image in zip(datasets, images):
                    dataset.write(image, 1, window=RasterWindow(c0, r0, c1 - c0, r1 - r0))
                progress("tiles", done, len(tiles))
            progress("overviews", len(tiles), len(tiles))
            for dataset in datasets:
                finish_tiled_gdal(dataset)
        finally:
            for dataset in datasets:
                if not dataset.closed:
                    dataset.close()
        summary.setdefault("timings_s", {})["pass2"] = round(time.perf_counter() - started, 3)
        atomic_write_bytes(staging / "summary.json", json.dumps(json_safe(summary), indent=2).encode("utf-8"))
        atomic_write_bytes(staging / MANIFEST, _manifest(pair, q.stages[-1] if q.stages else "original"))
    return out / MANIFEST
