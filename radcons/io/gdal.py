"""GDAL formats through rasterio: JPEG, JPEG 2000, NITF and the rest GDAL reads.

PNG and TIFF are read by :mod:`radcons.io.raster` directly (their TIFF tags are carried
verbatim); every other suffix listed in :data:`GDAL_SUFFIXES` comes through rasterio, with
its georeferencing (CRS, affine transform), RPCs and nodata. An image read this way keeps
that georeferencing in :attr:`radcons.io.Raster.gdal` and is written back as a GeoTIFF by
rasterio, tiled and with overviews when it is large.
"""

from __future__ import annotations

import logging
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from radcons.io.bands import MAX_BANDS

__all__ = [
    "GDAL_SUFFIXES", "read_gdal", "header_gdal", "write_gdal", "read_window_gdal", "read_decimated_gdal",
    "georeferencing_gdal", "georeferencing_profile", "data_bands_gdal",
]

#: File suffixes read through rasterio (GDAL).
GDAL_SUFFIXES = frozenset({".jpg", ".jpeg", ".jp2", ".j2k", ".jpx", ".ntf", ".nitf", ".vrt", ".img"})
_TILE = 256
_OVERVIEW_FROM = 4096


def read_gdal(path: Path) -> tuple[np.ndarray, float | None, dict[str, Any], bool]:
    """Read every band of a GDAL image.

    Returns
    -------
    data : ndarray
        ``(rows, columns)`` for one band, else ``(rows, columns, bands)``.
    nodata : float or None
        The file's nodata value.
    gdal : dict
        ``crs`` (WKT or None), ``transform`` (6 affine coefficients, GDAL order), ``rpcs``
        (RPC00B coefficients as rasterio's dict, or None).
    alpha : bool
        The last band is an alpha band.
    """
    import rasterio
    import rasterio.errors
    from rasterio.enums import ColorInterp

    logging.getLogger("rasterio").setLevel(logging.ERROR)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)  # a JPEG has no georeferencing
        dataset = rasterio.open(path)
    with dataset:
        if dataset.count > MAX_BANDS:
            raise ValueError(f"{dataset.count} bands; radcons reads 1 to {MAX_BANDS}")
        data = dataset.read()
        info = {
            "crs": dataset.crs.to_wkt() if dataset.crs is not None else None,
            "transform": tuple(dataset.transform.to_gdal()),
            "rpcs": dataset.rpcs.to_dict() if dataset.rpcs else None,
        }
        alpha = dataset.colorinterp[-1] == ColorInterp.alpha if dataset.count > 1 else False
        nodata = dataset.nodata
    data = data[0] if data.shape[0] == 1 else np.moveaxis(data, 0, -1)
    return data, nodata, info, alpha


def header_gdal(path: Path) -> tuple[tuple[int, int], int, np.dtype]:
    """``(rows, columns)``, band count and dtype of a GDAL image, from its header."""
    import rasterio
    import rasterio.errors

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        dataset = rasterio.open(path)
    with dataset:
        return (dataset.height, dataset.width), dataset.count, np.dtype(dataset.dtypes[0])


def write_gdal(path: Path, data: np.ndarray, gdal: dict[str, Any], nodata: float | None) -> None:
    """Write one band as a GeoTIFF with the georeferencing of :func:`read_gdal`.

    Tiled (256 px) once a side passes 256 px, BigTIFF when needed, with overviews (2, 4,
    8, ...) once a side passes 4096 px.
    """
    import rasterio
    import rasterio.errors

    rows, columns = data.shape
    profile: dict[str, Any] = {
        "driver": "GTiff",
        "height": rows,
        "width": columns,
        "count": 1,
        "dtype": data.dtype.name,
        "BIGTIFF": "IF_SAFER",
        "compress": "deflate",
        **georeferencing_profile(gdal, nodata),
    }
    if max(rows, columns) > _TILE:
        profile.update(tiled=True, blockxsize=_TILE, blockysize=_TILE)
    with warnings.catch_warnings():
        # An image located by its RPCs alone has no geotransform; rasterio warns about it.
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        _write(path, data, gdal, profile)


def georeferencing_profile(gdal: dict[str, Any], nodata: float | None) -> dict[str, Any]:
    """rasterio profile entries of :func:`read_gdal`'s georeferencing (CRS, transform) and nodata.

    An identity transform without a CRS is left out (a plain image; RPCs are set apart).
    """
    from affine import Affine

    profile: dict[str, Any] = {}
    transform = Affine.from_gdal(*gdal["transform"])
    if gdal.get("crs") or not transform.is_identity:
        profile.update(crs=gdal.get("crs"), transform=transform)
    if nodata is not None:
        profile["nodata"] = nodata
    return profile


def _write(path: Path, data: np.ndarray, gdal: dict[str, Any], profile: dict[str, Any]) -> None:
    import rasterio
    from rasterio.rpc import RPC

    rows, columns = data.shape
    with rasterio.open(path, "w", **profile) as dataset:
        dataset.write(data, 1)
        if gdal.get("rpcs"):
            dataset.rpcs = RPC(**gdal["rpcs"])
        if max(rows, columns) > _OVERVIEW_FROM:
            factors = [2**k for k in range(1, 12) if max(rows, columns) / 2**k >= _TILE]
            dataset.build_overviews(factors, rasterio.enums.Resampling.average)


# ------------------------------------------------------------------ windowed access (scene mode)


def read_window_gdal(path: Path, rows: tuple[int, int], columns: tuple[int, int],
                     band: int | tuple[int, ...] = 1) -> np.ndarray:
    """Read a window, ``rows = (start, stop)`` and ``columns = (start, stop)``, of one band
    (2-D) or of the bands ``band`` (a tuple: bands last).

    Only the file blocks the window touches are decoded, so a whole scene is never in memory.
    """
    import rasterio
    import rasterio.errors
    from rasterio.windows import Window

    logging.getLogger("rasterio").setLevel(logging.ERROR)
    window = Window(columns[0], rows[0], columns[1] - columns[0], rows[1] - rows[0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(path) as dataset:
            if isinstance(band, tuple):
                return np.moveaxis(dataset.read(list(band), window=window), 0, -1)
            return dataset.read(band, window=window)


def read_decimated_gdal(path: Path, shape: tuple[int, int], band: int | tuple[int, ...] = 1, *,
                        labels: bool = False) -> np.ndarray:
    """Read one band (or the bands of a tuple, bands last) resampled to ``shape``: block
    averages (labels: nearest pixel).

    GDAL reads the file's overviews where it has them and streams the image otherwise.
    """
    import rasterio
    import rasterio.errors
    from rasterio.enums import Resampling

    logging.getLogger("rasterio").setLevel(logging.ERROR)
    resampling = Resampling.nearest if labels else Resampling.average
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(path) as dataset:
            if isinstance(band, tuple):
                data = dataset.read(list(band), out_shape=(len(band), *shape), resampling=resampling)
                return np.moveaxis(data, 0, -1)
            return dataset.read(band, out_shape=shape, resampling=resampling)


def data_bands_gdal(path: Path) -> tuple[int, ...]:
    """The 1-based bands of an image that hold data: all but an alpha band."""
    import rasterio
    import rasterio.errors
    from rasterio.enums import ColorInterp

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        with rasterio.open(path) as dataset:
            return tuple(i for i, kind in enumerate(dataset.colorinterp, start=1)
                         if not (kind == ColorInterp.alpha and dataset.count > 1))


def georeferencing_gdal(path: Path) -> tuple[dict[str, Any], float | None]:
    """CRS, affine transform and RPCs of any image GDAL reads (as :func:`read_gdal`), and its nodata."""
    import rasterio
    import rasterio.errors

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
        dataset = rasterio.open(path)
    with dataset:
        info = {
            "crs": dataset.crs.to_wkt() if dataset.crs is not None else None,
            "transform": tuple(dataset.transform.to_gdal()),
            "rpcs": dataset.rpcs.to_dict() if dataset.rpcs else None,
        }
        return info, dataset.nodata
