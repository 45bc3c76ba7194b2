"""Writing a scene result: two tiled GeoTIFFs filled tile by tile, swapped in whole.

The output folder is assembled beside its final name (:func:`radcons.io.staged_folder`):
``reference.tif`` and ``target.tif`` (tiled, deflate, BigTIFF when needed, the inputs'
georeferencing, overviews), ``summary.json`` and the ``pair.toml`` manifest last. A run
stopped half-way leaves nothing under the final name; a run killed outright leaves a
staging folder that the next run removes before it starts.

Each worker processes its tile and encodes it for the file (deflated blocks of every
overview level within the tile, :func:`radcons.io.tiled_tiff.encode_tile`); this
process only stores the blocks and lays the files out
(:class:`radcons.io.tiled_tiff.TiledGeoTiffWriter`), so that adding workers is not
held back by one process compressing the whole scene.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from radcons.io import MANIFEST, atomic_write_bytes, staged_folder
from radcons.io.tiled_tiff import EncodedTile, Pyramid, TiledGeoTiffWriter, encode_tile
from radcons.scene.cluster import SceneCluster
from radcons.scene.source import ScenePair, Window
from radcons.scene.tiles import SceneQuantities, output_tile, tile_grid
from radcons.summary import json_safe

__all__ = ["write_scene", "encoded_tile"]


def _manifest(pair: ScenePair, final_stage: str) -> bytes:
    import tomli_w

    manifest: dict[str, Any] = {"name": pair.name, "reference": "reference.tif", "target": "target.tif", "rectified": True}
    nodata = pair.reference.nodata
    if nodata is not None and not math.isnan(float(nodata)):
        manifest["nodata"] = int(nodata) if float(nodata).is_integer() else float(nodata)
    manifest["metadata"] = json_safe({**(pair.metadata or {}), "processed_by": "radcons (scene mode)", "final_stage": final_stage})
    return tomli_w.dumps(manifest).encode("utf-8")


def encoded_tile(window: Window, pair: ScenePair, q: SceneQuantities, dtypes: tuple[np.dtype, np.dtype],
                 pyramid: Pyramid) -> tuple[EncodedTile, EncodedTile]:
    """One tile of the consistent pair, processed and encoded for the two files (a worker's task)."""
    images = output_tile(window, pair, q, dtypes)
    origin = (window[0], window[2])
    return tuple(  # type: ignore[return-value]
        encode_tile(image, origin, pyramid, source.nodata) for image, source in zip(images, (pair.reference, pair.target))
    )


def write_scene(
    out: Path,
    pair: ScenePair,
    q: SceneQuantities,
    cluster: SceneCluster,
    tile: int,
    dtypes: tuple[np.dtype, np.dtype],
    summary: dict[str, Any],
    progress: Callable[[str, int, int], None],
) -> Path:
    """Process every tile on the cluster and write the consistent pair folder ``out``.

    ``tile`` is the side of the tiles, px. ``summary`` is written as ``summary.json`` with
    its ``timings_s`` given ``pass2`` (the tiles and the files, seconds).

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
    tiles = tile_grid(pair.shape, tile)
    pyramid = Pyramid.plan(pair.shape, tile)
    with staged_folder(out) as staging:
        with (
            TiledGeoTiffWriter(staging / "reference.tif", pyramid, dtypes[0], pair.reference.gdal, pair.reference.nodata) as reference,
            TiledGeoTiffWriter(staging / "target.tif", pyramid, dtypes[1], pair.target.gdal, pair.target.nodata) as target,
        ):
            for done, (_, parts) in enumerate(
                cluster.as_completed(encoded_tile, tiles, pair, shared, dtypes, pyramid, what="tile"), start=1
            ):
                reference.add(parts[0])
                target.add(parts[1])
                progress("tiles", done, len(tiles))
            progress("overviews", len(tiles), len(tiles))
            reference.finish()
            target.finish()
        summary.setdefault("timings_s", {})["pass2"] = round(time.perf_counter() - started, 3)
        atomic_write_bytes(staging / "summary.json", json.dumps(json_safe(summary), indent=2).encode("utf-8"))
        atomic_write_bytes(staging / MANIFEST, _manifest(pair, q.stages[-1] if q.stages else "original"))
    return out / MANIFEST
