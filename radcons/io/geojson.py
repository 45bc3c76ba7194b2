"""Object label rasters as GeoJSON polygons, in map coordinates when the image is georeferenced.

Each object becomes one Feature (a Polygon, or a MultiPolygon when it is in pieces) traced
along pixel edges (:func:`rasterio.features.shapes`), with the properties the caller gives
for its id. Coordinates are map coordinates through the image's affine transform (from
rasterio, or from the GeoTIFF tags ModelTransformationTag or ModelPixelScaleTag +
ModelTiepointTag) when it has one, else pixel coordinates ``(column, row)`` of pixel
corners; the FeatureCollection says which in ``"coordinates"`` and names the CRS when it
is known (``"crs"``, the pre-RFC 7946 member QGIS and GDAL read).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from radcons.errors import InputError
from radcons.io.atomic import atomic_write_bytes
from radcons.io.raster import Raster

__all__ = ["raster_transform", "label_features", "write_geojson", "read_geojson"]

_PIXEL_SCALE, _TIEPOINT, _TRANSFORMATION, _GEO_KEYS = 33550, 33922, 34264, 34735


def raster_transform(raster: Raster | None) -> tuple[tuple[float, ...] | None, str | None]:
    """The affine transform ``(a, b, c, d, e, f)`` (x = a col + b row + c, y = d col + e row + f)
    and the CRS name of a raster, or ``(None, None)`` when it has no georeferencing."""
    if raster is None:
        return None, None
    gdal = raster.gdal or {}
    if gdal.get("transform"):
        c, a, b, f, d, e = (float(v) for v in gdal["transform"])
        identity = (a, b, c, d, e, f) == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
        if not identity or gdal.get("crs"):
            return (a, b, c, d, e, f), _crs_name(gdal.get("crs"))
    tags = raster.georef or {}
    crs = _geokeys_crs(tags.get(_GEO_KEYS))
    if _TRANSFORMATION in tags:
        m = [float(v) for v in tags[_TRANSFORMATION][2]]
        return (m[0], m[1], m[3], m[4], m[5], m[7]), crs
    if _PIXEL_SCALE in tags and _TIEPOINT in tags:
        sx, sy = (float(v) for v in tags[_PIXEL_SCALE][2][:2])
        i, j, _, x, y, _ = (float(v) for v in tags[_TIEPOINT][2][:6])
        return (sx, 0.0, x - i * sx, 0.0, -sy, y + j * sy), crs
    return None, None


def _crs_name(wkt: str | None) -> str | None:
    if not wkt:
        return None
    try:
        from rasterio.crs import CRS

        epsg = CRS.from_wkt(wkt).to_epsg()
    except Exception:  # an unusual WKT is still named, as it is
        return wkt
    return f"EPSG:{epsg}" if epsg else wkt


def _geokeys_crs(entry: Any) -> str | None:
    """EPSG code of a GeoKeyDirectoryTag's projected or geographic CRS key, if any."""
    if not entry:
        return None
    keys = [int(v) for v in entry[2]]
    for start in range(4, len(keys) - 3, 4):
        key, location, _, value = keys[start : start + 4]
        if key in (3072, 2048) and location == 0 and 0 < value < 32767:
            return f"EPSG:{value}"
    return None


def label_features(
    labels: np.ndarray,
    properties: dict[int, dict[str, Any]] | None = None,
    transform: tuple[float, ...] | None = None,
) -> list[dict[str, Any]]:
    """GeoJSON Features of a label raster, one per object id, in increasing id.

    Parameters
    ----------
    labels : ndarray of int
        0 = background.
    properties : dict, optional
        Object id -> properties added to its Feature (``id`` is always set).
    transform : tuple, optional
        Affine ``(a, b, c, d, e, f)``; None for pixel coordinates.
    """
    from rasterio.features import shapes
    from rasterio.transform import Affine

    labels = np.asarray(labels)
    if labels.ndim != 2 or labels.dtype.kind not in "iu":
        raise InputError(f"object labels must be a 2-D integer raster, got {labels.dtype} {labels.shape}")
    affine = Affine(*transform) if transform is not None else Affine.identity()
    pieces: dict[int, list] = {}
    for geometry, value in shapes(labels.astype(np.int32), mask=labels > 0, connectivity=4, transform=affine):
        pieces.setdefault(int(value), []).append(geometry["coordinates"])
    features = []
    for ident in sorted(pieces):
        rings = pieces[ident]
        geometry = {"type": "Polygon", "coordinates": rings[0]} if len(rings) == 1 else {
            "type": "MultiPolygon", "coordinates": rings
        }
        props = {"id": ident, **(properties or {}).get(ident, {})}
        features.append({"type": "Feature", "id": ident, "geometry": geometry, "properties": props})
    return features


def write_geojson(
    path: str | Path,
    labels: np.ndarray,
    properties: dict[int, dict[str, Any]] | None = None,
    raster: Raster | None = None,
) -> Path:
    """Write the objects of a label raster as a GeoJSON FeatureCollection (atomically).

    Parameters
    ----------
    path : str or Path
        Destination ``.geojson``.
    labels : ndarray of int
        0 = background.
    properties : dict, optional
        Object id -> JSON-serialisable properties.
    raster : Raster, optional
        The image the labels lie on; its georeferencing, if any, gives map coordinates.
    """
    transform, crs = raster_transform(raster)
    collection: dict[str, Any] = {
        "type": "FeatureCollection",
        "coordinates": "map" if transform is not None else "pixel",
        "features": label_features(labels, properties, transform),
    }
    if crs:
        collection["crs"] = {"type": "name", "properties": {"name": crs}}
    path = Path(path)
    atomic_write_bytes(path, json.dumps(collection, allow_nan=False).encode("utf-8"))
    return path


def read_geojson(path: str | Path) -> dict[str, Any]:
    """Read a FeatureCollection written by :func:`write_geojson`."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read GeoJSON: {exc}", path) from exc
    if data.get("type") != "FeatureCollection":
        raise InputError("not a GeoJSON FeatureCollection", path)
    return data
