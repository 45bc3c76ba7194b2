"""Single-band rasters: reading, checking and writing PNG and (Geo)TIFF images.

Images are PNG (uint8, uint16), TIFF / GeoTIFF (uint8, uint16, float32), or a format of
:data:`radcons.io.gdal.GDAL_SUFFIXES` (JPEG, JPEG 2000, NITF, ...) read through rasterio.
GeoTIFF georeferencing tags (and RPC and GDAL nodata tags) are kept verbatim in
:attr:`Raster.georef` and written back unchanged, so outputs carry the input's
georeferencing. Multiband images become one grey band by :mod:`radcons.io.bands`.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from radcons.errors import InputError
from radcons.io.atomic import atomic_write_bytes, temporary_beside
from radcons.io.bands import green_leaf_index, grey_band
from radcons.io.decode import quiet_logger, read_png, read_tiff
from radcons.io.gdal import GDAL_SUFFIXES, header_gdal, read_gdal, write_gdal
from radcons.io.paths import check_input_file
from radcons.validate import MAX_ABS_VALUE

__all__ = [
    "Raster", "ImageHeader", "read_raster", "read_header", "write_raster", "check_image",
    "valid_mask", "is_image_file", "check_size", "GEO_TAGS", "MIN_SIDE", "SUPPORTED_TEXT",
]

#: TIFF tags that carry georeferencing, camera models or nodata; kept verbatim.
GEO_TAGS = {
    33550: "ModelPixelScaleTag",
    33922: "ModelTiepointTag",
    34264: "ModelTransformationTag",
    34735: "GeoKeyDirectoryTag",
    34736: "GeoDoubleParamsTag",
    34737: "GeoAsciiParamsTag",
    42112: "GDAL_METADATA",
    42113: "GDAL_NODATA",
    50844: "RPCCoefficientTag",
}
_NODATA_TAG = 42113
_IMAGE_SUFFIXES = {".png", ".tif", ".tiff", *GDAL_SUFFIXES}
SUPPORTED_TEXT = "PNG, TIFF, JPEG, JPEG 2000 or NITF"
_SUPPORTED_DTYPES = (np.uint8, np.uint16, np.float32)
#: Fewest pixels along each side of an image radcons processes: the largest of the stages'
#: own minimums (the sharpness stage's power spectrum and the rectification take 16 px, the
#: uniformity stage's gradient 2; the objects stage's census disparity skips a pair under
#: 32 px), so that an image read is one every stage takes.
MIN_SIDE = 16


@dataclass
class Raster:
    """A single-band image with the georeferencing it came with.

    Attributes
    ----------
    data : ndarray
        2-D array, uint8, uint16 or float32.
    georef : dict
        TIFF tag code -> ``(datatype, count, value)`` for the tags in :data:`GEO_TAGS`;
        empty when the file carried none.
    nodata : float or None
        Value marking missing pixels (NaN pixels of float images are always missing).
    path : Path or None
        Where it was read from.
    bands : str
        How the band was made from the file's bands (:func:`radcons.io.bands.grey_band`).
    gdal : dict or None
        Georeferencing of an image read through rasterio (:mod:`radcons.io.gdal`): CRS,
        affine transform, RPCs; written back by rasterio.
    greenness : ndarray or None
        Green leaf index of each pixel of an RGB image (:func:`radcons.io.bands.green_leaf_index`),
        on the grid of ``data``; None for other images and once the grid changes (resampling).
    """

    data: np.ndarray
    georef: dict[int, tuple[int, int, Any]] = field(default_factory=dict)
    nodata: float | None = None
    path: Path | None = None
    bands: str = "single band"
    gdal: dict[str, Any] | None = None
    greenness: np.ndarray | None = None

    def valid_mask(self) -> np.ndarray:
        """Return True where the pixel holds data (finite and not ``nodata``)."""
        return valid_mask(self.data, self.nodata)

    def as_float32(self) -> np.ndarray:
        """The data as a new float32 array with NaN where the pixel is invalid."""
        image = self.data.astype(np.float32, copy=True)
        image[~self.valid_mask()] = np.nan
        return image


def valid_mask(data: np.ndarray, nodata: float | None = None) -> np.ndarray:
    """Return True where ``data`` is finite and differs from ``nodata``."""
    valid = np.isfinite(data) if data.dtype.kind == "f" else np.ones(data.shape, bool)
    if nodata is not None and not (isinstance(nodata, float) and math.isnan(nodata)):
        valid &= data != nodata
    return valid


def write_raster(
    path: str | Path,
    data: np.ndarray,
    georef: dict[int, tuple[int, int, Any]] | None = None,
    nodata: float | None = None,
    gdal: dict[str, Any] | None = None,
) -> Path:
    """Write a single-band raster atomically as PNG or (Geo)TIFF, chosen by suffix.

    Parameters
    ----------
    path : str or Path
        Destination; ``.png`` (uint8, uint16, bool, integer labels < 65536) or
        ``.tif``/``.tiff`` (any supported dtype, georeferencing and nodata kept).
    data : ndarray
        2-D array.
    georef : dict, optional
        Tags from :attr:`Raster.georef`; TIFF only.
    nodata : float, optional
        Written as the GDAL_NODATA tag (TIFF only).
    gdal : dict, optional
        :attr:`Raster.gdal` of an image read through rasterio: the TIFF is then written by
        rasterio with that georeferencing (:func:`radcons.io.gdal.write_gdal`).

    Returns
    -------
    Path
        The written path.
    """
    import tifffile

    path = Path(path)
    data = np.asarray(data)
    if data.ndim != 2:
        raise InputError(f"expected a single-band 2-D array, got shape {data.shape}", path)
    suffix = path.suffix.lower()
    if suffix == ".png":
        import cv2

        if data.dtype == bool:
            data = data.astype(np.uint8) * 255
        elif data.dtype.kind in "iu" and data.dtype not in (np.uint8, np.uint16):
            if data.min(initial=0) < 0 or data.max(initial=0) > 65535:
                raise InputError("labels outside 0..65535 cannot be stored in PNG", path)
            data = data.astype(np.uint16)
        if data.dtype not in (np.uint8, np.uint16):
            raise InputError(f"PNG holds uint8 or uint16, not {data.dtype}; use .tif", path)
        ok, buffer = cv2.imencode(".png", np.ascontiguousarray(data))
        if not ok:
            raise InputError("PNG encoding failed", path)
        atomic_write_bytes(path, buffer.tobytes())
        return path
    if suffix not in (".tif", ".tiff"):
        raise InputError(f"unknown raster suffix {suffix!r} (use .png or .tif)", path)
    tags = dict(georef or {})
    if nodata is not None:
        text = "nan" if math.isnan(float(nodata)) else repr(float(nodata)).removesuffix(".0")
        tags[_NODATA_TAG] = (2, len(text) + 1, text)
    extratags = [(code, dtype, count, value, True) for code, (dtype, count, value) in sorted(tags.items())]
    if data.dtype == bool:
        data = data.astype(np.uint8)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = temporary_beside(path)
    os.close(fd)
    try:
        if gdal is not None:
            write_gdal(Path(tmp), np.ascontiguousarray(data), gdal, nodata)
        else:
            tifffile.imwrite(tmp, np.ascontiguousarray(data), extratags=extratags, photometric="minisblack")
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


# ----------------------------------------------------------------------------- reading


def read_raster(
    path: str | Path,
    nodata: float | None = None,
    *,
    labels: bool = False,
    check: bool = True,
    band: int | None = None,
) -> Raster:
    """Read a PNG or (Geo)TIFF image as one band.

    Multiband images (RGB, RGBA, multispectral) become one grey band by the rule of
    :func:`radcons.io.bands.grey_band`; ``band`` picks one instead.

    Parameters
    ----------
    path : str or Path
        The file.
    nodata : float, optional
        Value marking missing pixels; overrides a GDAL_NODATA tag in the file.
    labels : bool
        Read an integer label raster or mask: any integer dtype is accepted and the
        image checks (dtype, constant values) are skipped.
    check : bool
        Refuse images without valid pixels or with a single value (default). Ground truth
        rasters (a flat scene has a constant disparity) are read with ``check=False``.
    band : int, optional
        1-based band of a multiband image to read instead of the grey rule.

    Returns
    -------
    Raster

    Raises
    ------
    InputError
        Missing, unreadable or truncated file, a label raster with several bands, more
        than 16 bands, a band out of range, unsupported dtype.
    """
    path = check_input_file(path)
    data, georef, gdal, alpha, file_nodata = _decode(path)
    nodata = file_nodata if nodata is None else nodata
    data, how, greenness = _single_band(data, path, labels=labels, band=band, alpha=alpha)
    nodata = _take_nodata_tag(georef, nodata)
    if labels:
        if data.dtype.kind not in "iub":
            raise InputError(f"label raster must be integer, got {data.dtype}", path)
        return Raster(data, georef, None, path, how, gdal)
    if data.dtype == np.float64:
        data = data.astype(np.float32)
    if data.dtype not in _SUPPORTED_DTYPES:
        raise InputError(f"unsupported dtype {data.dtype} (uint8, uint16 or float32)", path)
    raster = Raster(data, georef, nodata, path, how, gdal, greenness)
    if check:
        check_image(raster.data, raster.nodata, path)
    return raster


def _decode(
    path: Path,
) -> tuple[np.ndarray, dict[int, tuple[int, int, Any]], dict[str, Any] | None, bool, float | None]:
    """Decode an image file by its suffix, with every band it holds.

    Parameters
    ----------
    path : Path
        An existing file.

    Returns
    -------
    data : ndarray
        The pixels, rows x columns or rows x columns x bands.
    georef : dict
        The TIFF tags of :data:`GEO_TAGS` (GDAL_NODATA included); empty for other files.
    gdal : dict or None
        Georeferencing of an image read through rasterio; None for PNG and TIFF.
    alpha : bool
        Whether the last band is an alpha channel.
    file_nodata : float or None
        The nodata value of an image read through rasterio; None for PNG and TIFF.

    Raises
    ------
    InputError
        Unsupported suffix, a multi-page TIFF, or any decoder failure (unreadable or
        truncated file).
    """
    suffix = path.suffix.lower()
    georef: dict[int, tuple[int, int, Any]] = {}
    gdal = file_nodata = None
    try:
        if suffix in GDAL_SUFFIXES:
            data, file_nodata, gdal, alpha = read_gdal(path)
        elif suffix in (".tif", ".tiff"):
            data, alpha, georef = read_tiff(path, GEO_TAGS)
        elif suffix == ".png":
            data, alpha = read_png(path)
        else:
            raise InputError(f"unsupported image type {suffix!r} ({SUPPORTED_TEXT} expected)", path)
    except InputError:
        raise
    except Exception as exc:  # noqa: BLE001 - any decoder failure is the file's problem
        detail = str(exc) or type(exc).__name__
        raise InputError(f"unreadable or truncated image ({detail})", path) from exc
    return np.asarray(data), georef, gdal, alpha, file_nodata


def _single_band(
    data: np.ndarray, path: Path, *, labels: bool, band: int | None, alpha: bool
) -> tuple[np.ndarray, str, np.ndarray | None]:
    """Make one band of a decoded image (:func:`radcons.io.bands.grey_band`), and check its shape.

    Parameters
    ----------
    data : ndarray
        The decoded pixels, bands last.
    path : Path
        The file, named in errors.
    labels : bool
        A label raster: one band only, and no greenness.
    band : int or None
        1-based band to pick instead of the grey rule.
    alpha : bool
        Whether the last band is an alpha channel.

    Returns
    -------
    data : ndarray
        The 2-D band.
    how : str
        How the band was made.
    greenness : ndarray or None
        Green leaf index of an RGB image (:func:`radcons.io.bands.green_leaf_index`).

    Raises
    ------
    InputError
        A label raster with several bands, a band out of range, or an empty image or one
        that is not rows x columns.
    """
    how = "single band"
    greenness = None
    if data.ndim == 3:
        if labels and data.shape[-1] > 1:
            raise InputError(f"a label raster has one band, this one {data.shape[-1]}", path)
        greenness = None if labels else green_leaf_index(data, band, alpha=alpha)
        data, how = grey_band(data, band, path, alpha=alpha)
    elif band is not None and band != 1:
        raise InputError(f"--band {band} is out of range: the image has 1 band", path)
    if data.ndim != 2:
        raise InputError(f"expected a single-band image of rows x columns, got an array of shape {data.shape}", path)
    if data.size == 0:
        raise InputError("the image is empty", path)
    return data, how, greenness


def _take_nodata_tag(georef: dict[int, tuple[int, int, Any]], nodata: float | None) -> float | None:
    """Remove the GDAL_NODATA tag from ``georef``; its value is the nodata unless one is given.

    Parameters
    ----------
    georef : dict
        Tags read from the file; changed in place.
    nodata : float or None
        The nodata value given by the caller or the file's rasterio metadata.

    Returns
    -------
    float or None
        ``nodata`` when given, else the tag's value (None when it is absent or not a number).
    """
    if _NODATA_TAG in georef and nodata is None:
        try:
            nodata = float(str(georef[_NODATA_TAG][2]).strip("\x00 "))
        except ValueError:
            nodata = None
    georef.pop(_NODATA_TAG, None)
    return nodata


@dataclass(frozen=True)
class ImageHeader:
    """What an image file holds, read from its header without decoding the pixels.

    Attributes
    ----------
    shape : tuple of int
        ``(rows, columns)`` of the image (bands left out).
    bands : int
        Samples per pixel.
    dtype : numpy.dtype
        Sample type.
    """

    shape: tuple[int, int]
    bands: int
    dtype: np.dtype

    @property
    def pixels(self) -> int:
        """Pixels of one band."""
        return int(self.shape[0]) * int(self.shape[1])


def read_header(path: str | Path) -> ImageHeader:
    """Read an image's size and sample type from its header (PNG or TIFF).

    Raises
    ------
    InputError
        Missing file, unsupported suffix, unreadable header.
    """
    path = check_input_file(path)
    suffix = path.suffix.lower()
    try:
        if suffix in GDAL_SUFFIXES:
            shape, bands, dtype = header_gdal(path)
            return ImageHeader(shape, bands, dtype)
        if suffix == ".png":
            with open(path, "rb") as handle:
                head = handle.read(29)
            if len(head) < 29 or head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
                raise ValueError("not a PNG file")
            width, height = int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
            depth, colour = head[24], head[25]
            bands = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}.get(colour, 1)
            return ImageHeader((height, width), bands, np.dtype(np.uint16 if depth == 16 else np.uint8))
        if suffix in (".tif", ".tiff"):
            import tifffile

            with quiet_logger("tifffile"), tifffile.TiffFile(path) as tif:
                if not len(tif.pages):
                    raise ValueError("no image in the file")
                page = tif.pages.first
                shape = tuple(int(n) for n in page.shape)
                bands = int(page.samplesperpixel)
                rows, columns = (page.imagelength, page.imagewidth)
                return ImageHeader((int(rows), int(columns)), bands if len(shape) > 2 else 1, np.dtype(page.dtype))
    except InputError:
        raise
    except Exception as exc:  # noqa: BLE001 - any decoder failure is the file's problem
        raise InputError(f"unreadable image header ({str(exc) or type(exc).__name__})", path) from exc
    raise InputError(f"unsupported image type {suffix!r} ({SUPPORTED_TEXT} expected)", path)


def check_image(data: np.ndarray, nodata: float | None, path: str | Path | None) -> None:
    """Raise :class:`InputError` when an image has no usable pixels or a single value.

    NaN marks missing pixels (like ``nodata``); infinite values and magnitudes above
    :data:`radcons.validate.MAX_ABS_VALUE` are refused with their count.
    """
    if data.dtype.kind == "f":
        infinite = int(np.isinf(data).sum())
        if infinite:
            raise InputError(f"{infinite} pixel(s) are infinite (NaN marks missing pixels; inf is not a value)", path)
        huge = int((np.abs(np.nan_to_num(data)) > MAX_ABS_VALUE).sum())
        if huge:
            peak = float(np.nanmax(np.abs(data)))
            raise InputError(
                f"{huge} pixel(s) exceed {MAX_ABS_VALUE:g} in magnitude (largest {peak:.3g}); "
                "rescale the image or mark those pixels as nodata", path
            )
    check_size(data.shape, path)
    valid = valid_mask(data, nodata)
    if not valid.any():
        raise InputError("every pixel is NaN or nodata", path)
    values = data[valid]
    if values.min() == values.max():
        raise InputError(f"the image is constant (every valid pixel is {values.flat[0]})", path)


def check_size(shape: tuple[int, ...], path: str | Path | None) -> None:
    """Raise :class:`InputError` when an image of ``shape`` (rows, columns) is smaller than
    :data:`MIN_SIDE` along a side."""
    if min(shape[:2]) < MIN_SIDE:
        raise InputError(
            f"the image is {shape[0]} x {shape[1]} px; its smaller side needs at least {MIN_SIDE} px, "
            "the least every stage works on", path
        )


def is_image_file(path: Path) -> bool:
    """True for a file name radcons can read as an image."""
    return path.suffix.lower() in _IMAGE_SUFFIXES
