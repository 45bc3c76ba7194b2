"""Windowed reading of a scene pair: headers, georeferencing, windows and a decimated copy.

A scene is never read whole: :class:`SceneImage` keeps the file's path and header, and
each reader opens the file, decodes the blocks one window touches and closes it again, so
that Dask workers on other machines can read the same files by path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from radcons.errors import InputError
from radcons.io import read_header, read_manifest
from radcons.io.bands import grey_band
from radcons.io.gdal import (
    data_bands_gdal,
    georeferencing_gdal,
    read_decimated_gdal,
    read_window_gdal,
)

__all__ = ["SceneImage", "ScenePair", "open_scene_pair", "Window"]

#: ``(row_start, row_stop, column_start, column_stop)`` of a window, stops exclusive.
Window = tuple[int, int, int, int]


@dataclass(frozen=True)
class SceneImage:
    """One single-band image of a scene, read window by window.

    Attributes
    ----------
    path : Path
    shape : (int, int)
        Rows and columns.
    dtype : numpy.dtype
    nodata : float or None
        Value marking missing pixels (NaN pixels of float images are always missing).
    gdal : dict
        CRS, affine transform and RPCs (as :func:`radcons.io.gdal.georeferencing_gdal`).
    band : int or tuple of int
        1-based band read; a tuple: the bands whose grey value is read, by the rule of
        the in-memory reader (:func:`radcons.io.bands.grey_band`: the luminance of three
        bands, else their mean).
    """

    path: Path
    shape: tuple[int, int]
    dtype: np.dtype
    nodata: float | None
    gdal: dict[str, Any]
    band: int | tuple[int, ...] = 1

    def read(self, window: Window) -> np.ndarray:
        """The window in the file's dtype."""
        r0, r1, c0, c1 = window
        return self._grey(read_window_gdal(self.path, (r0, r1), (c0, c1), self.band))

    def _grey(self, data: np.ndarray) -> np.ndarray:
        return grey_band(data, None, self.path)[0] if isinstance(self.band, tuple) else data

    def read_float(self, window: Window) -> np.ndarray:
        """The window as float32, NaN where a pixel is nodata (as :meth:`radcons.io.Raster.as_float32`)."""
        return self.to_float(self.read(window))

    def to_float(self, data: np.ndarray) -> np.ndarray:
        """``data`` of this image as float32 with NaN at nodata."""
        out = data.astype(np.float32)
        if self.nodata is not None and not math.isnan(self.nodata):
            out[data == self.nodata] = np.nan
        return out

    def read_decimated(self, factor: int, *, labels: bool = False) -> np.ndarray:
        """The image reduced ``factor`` times along each side (block means; labels: nearest)."""
        shape = (-(-self.shape[0] // factor), -(-self.shape[1] // factor))
        if factor == 1:
            return self.read((0, self.shape[0], 0, self.shape[1]))
        return self._grey(read_decimated_gdal(self.path, shape, self.band, labels=labels))


@dataclass(frozen=True)
class ScenePair:
    """The two images of a rectified scene pair, and their optional object label rasters."""

    reference: SceneImage
    target: SceneImage
    reference_objects: SceneImage | None = None
    target_objects: SceneImage | None = None
    name: str = "scene"
    metadata: dict[str, Any] | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """Rows and columns of the pair (both images have them)."""
        return self.reference.shape


def _image(path: Path, nodata: float | None, band: int | None, what: str, *, labels: bool = False) -> SceneImage:
    """One image of the pair; without ``band``, a multiband image is read as its grey value."""
    header = read_header(path)
    if band is not None and not 1 <= band <= header.bands:
        raise InputError(f"--band {band} is not a band of this {header.bands}-band image", path)
    if labels and header.bands > 1:
        raise InputError(f"{what} has {header.bands} bands; an object label raster has one", path)
    try:
        gdal, file_nodata = georeferencing_gdal(path)
        bands = data_bands_gdal(path) if band is None and header.bands > 1 else (band or 1,)
    except Exception as exc:  # noqa: BLE001 - any GDAL failure is the file's problem
        raise InputError(f"GDAL cannot open the image for windowed reading ({exc})", path) from exc
    read = bands[0] if len(bands) == 1 else bands
    return SceneImage(path, header.shape, header.dtype, nodata if nodata is not None else file_nodata, gdal, read)


def open_scene_pair(
    pair_args: Sequence[Path], *, nodata: float | None = None, band: int | None = None, rectified: bool | None = None
) -> ScenePair:
    """Open a pair folder (manifest) or two image files for windowed reading.

    Raises
    ------
    InputError
        Missing files, an unrectified pair, images of different sizes, label rasters
        of several bands.
    """
    paths = [Path(p) for p in pair_args]
    labels: dict[str, Path] = {}
    name, metadata = paths[0].stem, None
    if len(paths) == 1:
        checked = read_manifest(paths[0])
        manifest = checked.data
        paths = [checked.files["reference"], checked.files["target"]]
        labels = {key: path for key, path in checked.files.items() if key in ("reference_objects", "target_objects")}
        if nodata is None and isinstance(manifest.get("nodata"), (int, float)):
            nodata = float(manifest["nodata"])
        if "rectified" in manifest:
            rectified = bool(manifest["rectified"])
        name, metadata = str(manifest.get("name", checked.folder.name)), dict(manifest.get("metadata", {}))
    elif len(paths) != 2:
        raise InputError("give one pair folder or two image files (reference, target)")
    reference = _image(paths[0], nodata, band, "the reference")
    target = _image(paths[1], nodata, band, "the target")
    if reference.shape != target.shape or rectified is False:
        raise InputError(
            "scene mode processes epipolar-rectified pairs of one size "
            f"({reference.shape} and {target.shape}{', marked unrectified' if rectified is False else ''}); "
            "rectify the scene first or process a crop in memory",
            paths[0],
        )
    objects = {key: _image(path, None, None, key, labels=True) for key, path in labels.items()}
    for key, image in objects.items():
        if image.shape != reference.shape:
            raise InputError(f"{key} is {image.shape}, the images {reference.shape}", image.path)
    return ScenePair(
        reference, target, objects.get("reference_objects"), objects.get("target_objects"), name, metadata
    )
