"""Rational polynomial camera models (RPCs) of an image, and where the image sits in its scene.

Satellite products describe their camera by an RPC model (RPC00B): the image position of a
ground point is a ratio of two cubic polynomials of its normalised longitude, latitude and
height (NIMA STDI-0002, appendix E; the same 20-term order in GDAL, OSSIM and shareloc):

    col = samp_off + samp_scale * P_sn(L, P, H) / P_sd(L, P, H)
    row = line_off + line_scale * P_ln(L, P, H) / P_ld(L, P, H)

with ``L = (lon - long_off) / long_scale``, ``P = (lat - lat_off) / lat_scale``,
``H = (h - height_off) / height_scale`` (degrees, metres above the ellipsoid), and each
polynomial ``sum_k c_k m_k`` over the monomials 1, L, P, H, LP, LH, PH, L², P², H², PLH,
L³, LP², LH², L²P, P³, PH², L²H, P²H, H³.

The models are read from, in this order:

1. an OSSIM keyword list (``.geom``) beside the image (``type: ossimRpcModel``, the
   ``line_num_coeff_00`` ... keywords), as Pleiades products prepared by OTB/CARS come;
2. the RPCs of the file itself: the GDAL RPC tag of a TIFF (``RPCCoefficientTag``, 92
   numbers) or what rasterio reads from a NITF (RPC00B TRE) or JPEG 2000.

A crop of a scene keeps the scene's model; its position in the scene is the translation of
the TIFF's ModelTransformationTag, i.e. the rasterio transform, when that
transform is a pure pixel offset without a map projection (GDAL convention:
scene pixel = crop pixel + offset). A georeferenced image (with a CRS) has no such offset.
Pixel positions are of pixel centres (pixel ``(0, 0)``'s centre is at ``(0, 0)``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from radcons.errors import InputError

if TYPE_CHECKING:
    from radcons.io import Raster

__all__ = [
    "Rpc", "read_rpc", "pair_rpcs", "rpc_from_geom", "rpc_from_rasterio", "rpc_from_tiff_tag", "crop_offset",
]

_SCALARS = (
    "line_off", "samp_off", "lat_off", "long_off", "height_off",
    "line_scale", "samp_scale", "lat_scale", "long_scale", "height_scale",
)
_POLYNOMIALS = ("line_num_coeff", "line_den_coeff", "samp_num_coeff", "samp_den_coeff")
_TERMS = 20
#: TIFF tags read for the crop offset and the RPCs.
_MODEL_TRANSFORMATION, _GEO_KEYS, _RPC_TAG = 34264, 34735, 50844


@dataclass(frozen=True)
class Rpc:
    """An RPC camera model of a scene and the offset of an image (a crop) in that scene.

    Attributes
    ----------
    line_off, samp_off, lat_off, long_off, height_off : float
        Normalisation offsets (scene pixels, degrees, metres).
    line_scale, samp_scale, lat_scale, long_scale, height_scale : float
        Normalisation scales.
    line_num_coeff, line_den_coeff, samp_num_coeff, samp_den_coeff : tuple of float
        The 20 coefficients of each polynomial, RPC00B order.
    crop_offset : tuple of float
        ``(column, row)`` of the image's pixel ``(0, 0)`` in the scene's pixels.
    source : str
        Where the model came from (file and format), for messages and the summary.
    """

    line_off: float
    samp_off: float
    lat_off: float
    long_off: float
    height_off: float
    line_scale: float
    samp_scale: float
    lat_scale: float
    long_scale: float
    height_scale: float
    line_num_coeff: tuple[float, ...]
    line_den_coeff: tuple[float, ...]
    samp_num_coeff: tuple[float, ...]
    samp_den_coeff: tuple[float, ...]
    crop_offset: tuple[float, float] = (0.0, 0.0)
    source: str = ""

    def __post_init__(self) -> None:
        for name in _SCALARS:
            if not np.isfinite(getattr(self, name)):
                raise InputError(f"RPC {name} is not a finite number ({self.source})")
        for name in _SCALARS[5:]:
            if getattr(self, name) == 0:
                raise InputError(f"RPC {name} is zero ({self.source})")
        for name in _POLYNOMIALS:
            values = getattr(self, name)
            if len(values) != _TERMS or not np.all(np.isfinite(values)):
                raise InputError(f"RPC {name} needs {_TERMS} finite coefficients, got {len(values)} ({self.source})")

    def project(self, lon: np.ndarray, lat: np.ndarray, height: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Image ``(column, row)`` of ground points, in the image's own (cropped) pixels.

        Parameters
        ----------
        lon, lat : array_like
            Degrees (WGS84).
        height : array_like
            Metres above the ellipsoid.
        """
        lon_n = (np.asarray(lon, np.float64) - self.long_off) / self.long_scale
        lat_n = (np.asarray(lat, np.float64) - self.lat_off) / self.lat_scale
        h_n = (np.asarray(height, np.float64) - self.height_off) / self.height_scale
        terms = _monomials(lon_n, lat_n, h_n)
        col = self.samp_off + self.samp_scale * (terms @ np.asarray(self.samp_num_coeff)) / (
            terms @ np.asarray(self.samp_den_coeff)
        )
        row = self.line_off + self.line_scale * (terms @ np.asarray(self.line_num_coeff)) / (
            terms @ np.asarray(self.line_den_coeff)
        )
        return col - self.crop_offset[0], row - self.crop_offset[1]

    def ground_sample_distance(self, height: float | None = None) -> float:
        """Side, m, of a pixel on the ground at the scene's centre (``height``: m, default its offset).

        The geometric mean of the pixel's sides: the root of the area on the ground of one
        pixel, from the projection's Jacobian over 10 m east and north.
        """
        height = self.height_off if height is None else float(height)
        metres_per_degree_lat = 111_320.0
        metres_per_degree_lon = metres_per_degree_lat * np.cos(np.radians(self.lat_off))
        step = 10.0
        lon = self.long_off + np.array([0.0, step / metres_per_degree_lon, 0.0])
        lat = self.lat_off + np.array([0.0, 0.0, step / metres_per_degree_lat])
        col, row = self.project(lon, lat, np.full(3, height))
        jacobian = np.array([[col[1] - col[0], col[2] - col[0]], [row[1] - row[0], row[2] - row[0]]]) / step
        return float(1.0 / np.sqrt(abs(np.linalg.det(jacobian))))

    def with_offset(self, crop_offset: tuple[float, float], source: str | None = None) -> "Rpc":
        """The same model for an image at another offset in the scene."""
        fields = {name: getattr(self, name) for name in (*_SCALARS, *_POLYNOMIALS)}
        return Rpc(**fields, crop_offset=tuple(map(float, crop_offset)), source=source or self.source)


def _monomials(l: np.ndarray, p: np.ndarray, h: np.ndarray) -> np.ndarray:
    """The 20 RPC00B monomials of normalised (longitude, latitude, height), shape (..., 20)."""
    one = np.ones_like(l)
    return np.stack(
        [one, l, p, h, l * p, l * h, p * h, l * l, p * p, h * h, p * l * h, l**3, l * p * p, l * h * h,
         l * l * p, p**3, p * h * h, l * l * h, p * p * h, h**3],
        axis=-1,
    )


def rpc_from_geom(path: str | Path) -> Rpc:
    """Read an OSSIM keyword list holding an RPC model (``type: ossimRpcModel``).

    Raises
    ------
    InputError
        Unreadable file, another camera model (e.g. ``ossimPleiadesModel``, a physical
        model), or a missing or non-numeric keyword; the message names the file.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise InputError(f"cannot read the RPC model: {exc.strerror or exc}", path) from exc
    keywords: dict[str, str] = {}
    for line in text.splitlines():
        key, sep, value = line.partition(":")
        if sep:
            keywords[key.strip()] = value.strip()
    kind = keywords.get("type", "")
    if kind != "ossimRpcModel":
        raise InputError(f"not an RPC model (OSSIM type {kind or 'missing'!r}; radcons reads ossimRpcModel)", path)

    def number(key: str) -> float:
        if key not in keywords:
            raise InputError(f"RPC keyword {key!r} missing", path)
        try:
            return float(keywords[key])
        except ValueError:
            raise InputError(f"RPC keyword {key!r} is not a number: {keywords[key]!r}", path) from None

    scalars = {name: number(name) for name in _SCALARS}
    polynomials = {name: tuple(number(f"{name}_{k:02d}") for k in range(_TERMS)) for name in _POLYNOMIALS}
    return Rpc(**scalars, **polynomials, source=f"{path.name} (OSSIM keyword list)")


def rpc_from_rasterio(rpcs: dict[str, Any], source: str) -> Rpc:
    """An :class:`Rpc` from rasterio's ``RPC.to_dict()`` (NITF RPC00B, TIFF tag, JPEG 2000)."""
    try:
        scalars = {name: float(rpcs[name]) for name in _SCALARS}
        polynomials = {name: tuple(float(v) for v in rpcs[name]) for name in _POLYNOMIALS}
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"incomplete RPCs ({exc}) in {source}") from None
    return Rpc(**scalars, **polynomials, source=source)


def rpc_from_tiff_tag(values: tuple[float, ...], source: str) -> Rpc:
    """An :class:`Rpc` from the 92 numbers of GDAL's TIFF ``RPCCoefficientTag`` (50844).

    Order: error bias, error random, then the offsets and scales (line, sample, latitude,
    longitude, height), then the four 20-term polynomials (line num, line den, sample num,
    sample den).
    """
    values = tuple(float(v) for v in np.ravel(values))
    if len(values) != 12 + 4 * _TERMS:
        raise InputError(f"the TIFF RPC tag holds {len(values)} numbers, expected {12 + 4 * _TERMS} ({source})")
    order = ("line_off", "samp_off", "lat_off", "long_off", "height_off",
             "line_scale", "samp_scale", "lat_scale", "long_scale", "height_scale")
    scalars = dict(zip(order, values[2:12]))
    polynomials = {name: values[12 + k * _TERMS : 12 + (k + 1) * _TERMS] for k, name in enumerate(_POLYNOMIALS)}
    return Rpc(**scalars, **polynomials, source=source)


def crop_offset(georef: dict[int, tuple[int, int, Any]], gdal: dict[str, Any] | None) -> tuple[float, float]:
    """``(column, row)`` of an image's pixel ``(0, 0)`` in its scene, from its georeferencing.

    The translation of the ModelTransformationTag of a TIFF without map projection (GDAL
    writes a crop's offset so, as the tie point form cannot hold rows growing downwards), or
    of the rasterio transform of an image without CRS; zero for a georeferenced image or one
    without a transform. A transform that scales, flips or rotates pixels is a map
    georeferencing, not a crop offset.
    """
    if gdal is not None:
        if gdal.get("crs"):
            return 0.0, 0.0
        c, a, b, f, d, e = gdal.get("transform", (0.0, 1.0, 0.0, 0.0, 0.0, 1.0))
        return (float(c), float(f)) if (a, b, d, e) == (1.0, 0.0, 0.0, 1.0) else (0.0, 0.0)
    if _GEO_KEYS in georef:
        return 0.0, 0.0
    if _MODEL_TRANSFORMATION in georef:
        m = np.asarray(georef[_MODEL_TRANSFORMATION][2], np.float64)
        if m.size == 16 and np.allclose(m[[0, 1, 4, 5]], [1.0, 0.0, 0.0, 1.0]):
            return float(m[3]), float(m[7])
        return 0.0, 0.0
    return 0.0, 0.0


def read_rpc(
    path: str | Path | None, georef: dict[int, tuple[int, int, Any]], gdal: dict[str, Any] | None
) -> Rpc | None:
    """The RPC model of an image and its crop offset, or None when it carries none.

    Parameters
    ----------
    path : str or Path or None
        The image file (its ``.geom`` sidecar is looked for beside it).
    georef : dict
        :attr:`radcons.io.Raster.georef` (TIFF tags).
    gdal : dict or None
        :attr:`radcons.io.Raster.gdal` (rasterio's CRS, transform and RPCs).

    Raises
    ------
    InputError
        A model is present but unreadable or incomplete (the message names the file).
    """
    name = Path(path).name if path is not None else "the image"
    rpc: Rpc | None = None
    if path is not None:
        sidecar = Path(path).with_suffix(".geom")
        if sidecar.is_file():
            rpc = rpc_from_geom(sidecar)
    if rpc is None and gdal is not None and gdal.get("rpcs"):
        rpc = rpc_from_rasterio(gdal["rpcs"], f"{name} (RPC00B read by GDAL)")
    if rpc is None and _RPC_TAG in georef:
        rpc = rpc_from_tiff_tag(georef[_RPC_TAG][2], f"{name} (TIFF RPC tag)")
    if rpc is None:
        return None
    return rpc.with_offset(crop_offset(georef, gdal))


def pair_rpcs(reference: Raster, target: Raster) -> tuple[tuple[Rpc, Rpc] | None, str]:
    """The models of both images of a pair, or None and why not.

    Parameters
    ----------
    reference, target : radcons.io.Raster
        The pair's images as read (their path, TIFF tags and rasterio georeferencing).

    Returns
    -------
    rpcs : tuple of Rpc or None
        ``(reference model, target model)`` when both images carry one.
    reason : str
        Empty with models; else which image has none, or why one is unreadable.
    """
    models = []
    problems = []
    for name, raster in (("reference", reference), ("target", target)):
        try:
            model = read_rpc(raster.path, raster.georef, raster.gdal)
        except InputError as exc:
            problems.append(f"the {name}'s RPC model is unreadable ({exc})")
            continue
        if model is None:
            problems.append(f"the {name} carries no RPC model")
        models.append(model)
    if problems:
        return None, "; ".join(problems)
    return (models[0], models[1]), ""
