"""Scene-sized pairs in the inspector: told from their headers, tuned on a decimated read.

A pair whose in-memory run would pass the memory budget (:func:`radcons.preflight.needs_scene`,
the budget ``radcons process`` uses) is never loaded whole. :func:`scene_source` recognises
it from the image headers; :func:`read_preview` reads a copy reduced by an integer factor
(GDAL's decimated read, ``out_shape=``, which takes the file's overviews when it has them)
and :func:`read_region` a full-resolution window. Both return an ordinary
:class:`radcons.io.Pair` that the pipeline tunes on like any preview or region; the whole
scene is processed by :func:`radcons.scene.run_scene` ("Apply to full resolution").
Both read the target with its rows levelled (:attr:`SceneSource.levelled`), as the
whole-scene run and a pair loaded whole get it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from radcons.errors import InputError
from radcons.io import Pair, Raster, read_manifest

__all__ = ["SceneSource", "scene_source", "read_preview", "read_region", "preview_factor", "PREVIEW_CACHE"]

#: GDAL block cache, bytes, while a preview is read: a file without overviews is streamed
#: whole, and GDAL's default cache (5 % of the machine's memory) would keep 1.2 GB of it
#: on a 24 GB machine (peak RSS 1.4 GB against 0.3 GB, 40000 px scene).
PREVIEW_CACHE = 128 * 2**20


@dataclass(frozen=True)
class SceneSource:
    """A pair too large to load whole: where it is and what its headers say.

    Attributes
    ----------
    args : tuple of Path
        A pair folder, or the reference and target image files (as ``radcons process`` takes them).
    shape : (int, int)
        Rows and columns of the reference image.
    dtype : numpy.dtype
        Sample type of the reference image.
    name : str
        The pair's name.
    reading : dict
        ``band`` and ``rectified`` as :func:`radcons.scene.open_scene_pair` takes them.
    """

    args: tuple[Path, ...]
    shape: tuple[int, int]
    dtype: np.dtype
    name: str
    reading: dict[str, Any] = field(default_factory=dict)

    def open(self) -> Any:
        """The :class:`radcons.scene.ScenePair` (headers only; pixels are read by window)."""
        from radcons.scene import open_scene_pair

        return open_scene_pair(self.args, band=self.reading.get("band"), rectified=self.reading.get("rectified"))

    @cached_property
    def levelled(self) -> Any:
        """The scene pair with its target's rows levelled, measured once per source.

        :func:`radcons.scene.levelling.level_scene_rows`, the step
        :func:`radcons.scene.run_scene` takes before the whole scene is processed (and
        :func:`radcons.geometry.level_rows` for a pair loaded whole): the previews and
        regions tuned on show the target that run will process, and "Apply to full
        resolution" runs on this pair, so the offset is measured once. What was
        measured is in the pair's metadata (``rows``).
        """
        from radcons.scene.levelling import level_scene_rows

        return level_scene_rows(self.open())


def scene_source(args: Sequence[Path], scene_pixels: int | None, reading: dict[str, Any] | None = None,
                 memory_limit: int | None = None) -> SceneSource | None:
    """The pair as a :class:`SceneSource` when it is scene-sized, else None.

    Parameters
    ----------
    args : sequence of Path
        A pair folder or two image files.
    scene_pixels : int or None
        Pixels per image above which a pair is a scene; None: its in-memory run would
        pass the memory budget (:func:`radcons.preflight.needs_scene`).
    reading : dict, optional
        ``band`` and ``rectified``.
    memory_limit : int, optional
        The memory budget, bytes (``--memory-limit``; default: that of ``radcons process``).

    Returns
    -------
    SceneSource or None
        None also when the headers cannot be read: the ordinary loader then says what is
        wrong with the pair.
    """
    from radcons import preflight

    paths = [Path(p) for p in args]
    try:
        headers = preflight.headers_of(preflight.image_files(paths))
    except (InputError, OSError, ValueError):
        return None
    if len(headers) != 2:
        return None
    if scene_pixels is None:
        large = preflight.needs_scene(headers, memory_limit or preflight.memory_budget())
    else:
        large = max(header.pixels for header in headers) > scene_pixels
    if not large:
        return None
    name = paths[0].name if len(paths) == 1 else paths[0].stem
    if len(paths) == 1:
        name = str(read_manifest(paths[0]).data.get("name", name))
    return SceneSource(tuple(paths), tuple(headers[0].shape), headers[0].dtype, name, dict(reading or {}))


def preview_factor(shape: tuple[int, int], side: int) -> int:
    """The integer reduction that brings the longest side of ``shape`` to at most ``side``."""
    if side < 16:
        raise InputError(f"preview side must be at least 16 px, got {side}")
    return max(1, math.ceil(max(shape) / side))


def read_preview(source: SceneSource, side: int) -> tuple[Pair, int]:
    """Read the scene reduced by an integer factor so that its longest side is at most ``side``.

    The images are block means read by GDAL (from the file's overviews where it has
    them) as float32 with NaN at nodata, the object labels and change mask the nearest
    pixel, the ground-truth disparity the nearest pixel divided by the factor, as
    :func:`inspector.state.preview_pair` makes a preview of a loaded pair.

    Returns
    -------
    pair : Pair
        The preview.
    factor : int
    """
    import rasterio

    from radcons.io.gdal import read_decimated_gdal

    scene = source.levelled
    factor = preview_factor(scene.shape, side)
    with rasterio.Env(GDAL_CACHEMAX=PREVIEW_CACHE):
        images = [image.to_float(image.read_decimated(factor)) for image in (scene.reference, scene.target)]
    shape = images[0].shape

    def labels(image: Any) -> np.ndarray | None:
        return None if image is None else image.read_decimated(factor, labels=True).astype(np.int32)

    truth = _truth_files(source)
    disparity = truth.get("disparity")
    change = truth.get("change_mask")
    pair = _pair(
        scene, images,
        disparity=None if disparity is None else read_decimated_gdal(disparity, shape, labels=True).astype(np.float32) / factor,
        reference_objects=labels(scene.reference_objects),
        target_objects=labels(scene.target_objects),
        change_mask=None if change is None else read_decimated_gdal(change, shape, labels=True) != 0,
        name=f"{scene.name} (1/{factor})",
    )
    return pair, factor


def read_region(source: SceneSource, box: tuple[int, int, int, int]) -> Pair:
    """Read the same full-resolution region ``(x, y, width, height)`` of both images and
    their ground truth (as :func:`inspector.state.region_pair` cuts it from a loaded pair).

    Raises
    ------
    InputError
        A region that does not fit in the scene.
    """
    from radcons.io.gdal import read_window_gdal

    scene = source.levelled
    x, y, width, height = (int(v) for v in box)
    rows, cols = scene.shape
    if width < 16 or height < 16 or x < 0 or y < 0 or x + width > cols or y + height > rows:
        raise InputError(f"region {box} does not fit in the {cols}x{rows} scene")
    window = (y, y + height, x, x + width)

    def labels(image: Any) -> np.ndarray | None:
        return None if image is None else image.read(window).astype(np.int32)

    truth = _truth_files(source)
    disparity = truth.get("disparity")
    change = truth.get("change_mask")
    images = [image.read(window) for image in (scene.reference, scene.target)]
    return _pair(
        scene, images,
        nodata=(scene.reference.nodata, scene.target.nodata),
        disparity=None if disparity is None else read_window_gdal(disparity, window[:2], window[2:]).astype(np.float32),
        reference_objects=labels(scene.reference_objects),
        target_objects=labels(scene.target_objects),
        change_mask=None if change is None else read_window_gdal(change, window[:2], window[2:]) != 0,
        name=f"{scene.name} [{x}:{x + width}, {y}:{y + height}]",
    )


def _pair(
    scene: Any, images: list[np.ndarray], *, name: str,
    nodata: tuple[float | None, float | None] = (None, None), **truth: Any,
) -> Pair:
    """A rectified in-memory pair of two arrays read from ``scene`` (no file or
    georeferencing behind them: they are a part or a reduction of the scene)."""
    metadata = dict(scene.metadata or {})
    metadata.setdefault("geometry", "rectified (scene mode takes rectified pairs only)")
    reference, target = (Raster(data, nodata=value) for data, value in zip(images, nodata))
    return Pair(reference, target, rectified=True, metadata=metadata, name=name, **truth)


def _truth_files(source: SceneSource) -> dict[str, Path]:
    """The ground-truth rasters a pair folder names (disparity, change mask), each checked
    to lie inside the folder (:func:`radcons.io.read_manifest`)."""
    if len(source.args) != 1:
        return {}
    files = read_manifest(source.args[0]).files
    return {key: files[key] for key in ("disparity", "change_mask") if key in files}
