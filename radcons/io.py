"""Reading and writing single-band rasters and stereo pair folders.

A pair on disk is a folder with a ``pair.toml`` manifest naming its files (see the README):

.. code-block:: toml

    reference = "left.tif"          # required
    target = "right.tif"            # required
    disparity = "disparity.tif"     # optional, float32, reference frame, NaN = unknown
    reference_objects = "ref_objects.png"   # optional label rasters, 0 = background
    target_objects = "tgt_objects.png"
    change_mask = "change.png"      # optional, non-zero = changed between the dates
    rectified = true                # rows correspond (default true)
    nodata = 0                      # optional value that marks missing pixels

    [metadata]
    sensor = "WorldView-2 / QuickBird"
    date = "2011-10-09 / 2007-11-11"

Images are PNG (uint8, uint16) or TIFF / GeoTIFF (uint8, uint16, float32). GeoTIFF
georeferencing tags (and RPC and GDAL nodata tags) are kept verbatim in
:attr:`Raster.georef` and written back unchanged, so outputs carry the input's
georeferencing. Every write goes to a temporary file in the destination folder that is then
renamed over the destination, so an interrupted write never leaves a half file.
"""

from __future__ import annotations

import contextlib
import glob
import logging
import math
import os
import shutil
import tempfile
import tomllib
import uuid
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from radcons.errors import InputError
from radcons.validate import MAX_ABS_VALUE

__all__ = [
    "Raster",
    "Pair",
    "read_raster",
    "write_raster",
    "load_pair",
    "load_pair_files",
    "save_pair",
    "atomic_write_bytes",
    "staged_folder",
    "recover_folder",
    "read_header",
    "ImageHeader",
    "MANIFEST",
]

MANIFEST = "pair.toml"

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
_IMAGE_SUFFIXES = {".png", ".tif", ".tiff"}
_SUPPORTED_DTYPES = (np.uint8, np.uint16, np.float32)
#: Fewest pixels along each side of an image radcons processes.
MIN_SIDE = 8


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
    """

    data: np.ndarray
    georef: dict[int, tuple[int, int, Any]] = field(default_factory=dict)
    nodata: float | None = None
    path: Path | None = None

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


@dataclass
class Pair:
    """A stereo pair: reference (left) and target (right) image plus optional ground truth.

    Disparity follows the project convention: ``reference(x, y) <-> target(x - d, y)``,
    NaN where unknown. Object label rasters use 0 for background and the same id for the
    same building in both images.
    """

    reference: Raster
    target: Raster
    disparity: np.ndarray | None = None
    reference_objects: np.ndarray | None = None
    target_objects: np.ndarray | None = None
    change_mask: np.ndarray | None = None
    rectified: bool = True
    metadata: dict[str, Any] = field(default_factory=dict)
    name: str = "pair"
    source: Path | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """Shape of the reference image."""
        return self.reference.data.shape

    def with_images(self, reference: np.ndarray, target: np.ndarray) -> "Pair":
        """Return a copy holding new image arrays, georeferencing and ground truth kept."""
        return replace(
            self,
            reference=replace(self.reference, data=reference, path=None),
            target=replace(self.target, data=target, path=None),
        )


# ----------------------------------------------------------------------------- writing


def _temporary_beside(path: Path) -> tuple[int, str]:
    """Open a temporary file in ``path``'s folder with the permissions a plain open would give.

    Temporary files left beside ``path`` by an earlier write that was killed are removed
    first.
    """
    for stale in path.parent.glob(f".{glob.escape(path.name)}.*.part"):
        stale.unlink(missing_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
    umask = os.umask(0)
    os.umask(umask)
    os.fchmod(fd, 0o666 & ~umask)
    return fd, tmp


def atomic_write_bytes(path: str | Path, payload: bytes) -> None:
    """Write ``payload`` to ``path`` through a temporary file and an atomic rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = _temporary_beside(path)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(payload)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _staging_names(out: Path, kind: str) -> list[Path]:
    return sorted(out.parent.glob(f".{glob.escape(out.name)}.{kind}-*"))


def recover_folder(out: str | Path) -> None:
    """Undo what a killed :func:`staged_folder` left beside ``out``.

    A run killed between moving the old result aside and moving the new one in leaves no
    ``out``: the old result is put back. Every other staging folder is removed.
    """
    out = Path(out)
    if not out.parent.is_dir():
        return
    olds = _staging_names(out, "old")
    if olds and not out.exists():
        os.replace(olds.pop(), out)
    for leftover in olds + _staging_names(out, "new"):
        shutil.rmtree(leftover, ignore_errors=True)


@contextlib.contextmanager
def staged_folder(out: str | Path) -> Iterator[Path]:
    """Build a folder's new content beside it and swap it in whole at the end.

    Yields a temporary folder next to ``out`` (same file system); when the block ends
    without an error, the old ``out`` (if any) is moved aside, the new one renamed into
    place and the old one removed. On an error, or when the process is interrupted, the
    temporary folder is removed and ``out`` keeps its old, complete content; a process
    killed outright leaves staging folders that :func:`recover_folder` (called first
    here) clears on the next run.

    Parameters
    ----------
    out : str or Path
        The folder to write.

    Yields
    ------
    Path
        The folder to write into.
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    recover_folder(out)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.new-", dir=out.parent))
    try:
        yield staging
        staging.chmod(0o777 & ~_umask())
        if out.exists():
            old = out.parent / f".{out.name}.old-{uuid.uuid4().hex[:12]}"
            os.replace(out, old)
            os.replace(staging, out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(staging, out)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


def write_raster(
    path: str | Path,
    data: np.ndarray,
    georef: dict[int, tuple[int, int, Any]] | None = None,
    nodata: float | None = None,
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
    fd, tmp = _temporary_beside(path)
    os.close(fd)
    try:
        tifffile.imwrite(tmp, np.ascontiguousarray(data), extratags=extratags, photometric="minisblack")
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


# ----------------------------------------------------------------------------- reading


def read_raster(
    path: str | Path, nodata: float | None = None, *, labels: bool = False, check: bool = True
) -> Raster:
    """Read a single-band PNG or (Geo)TIFF raster.

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

    Returns
    -------
    Raster

    Raises
    ------
    InputError
        Missing, unreadable or truncated file, more than one band, unsupported dtype.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("file not found", path)
    suffix = path.suffix.lower()
    georef: dict[int, tuple[int, int, Any]] = {}
    try:
        if suffix in (".tif", ".tiff"):
            import tifffile

            with _quiet_logger("tifffile"), tifffile.TiffFile(path) as tif:
                if not len(tif.pages):
                    raise ValueError("no image in the file")
                pages = _full_resolution_pages(tif)
                if pages > 1:
                    raise InputError(
                        f"multi-page TIFF ({pages} images); radcons reads one image per file: "
                        "save the page you want on its own", path
                    )
                page = tif.pages.first
                for tag in page.tags.values():
                    if tag.code in GEO_TAGS:
                        georef[tag.code] = (int(tag.dtype), int(tag.count), tag.value)
                data = page.asarray()
        elif suffix == ".png":
            import cv2

            data = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
            if data is None:
                raise ValueError("not a readable PNG")
        else:
            raise InputError(f"unsupported image type {suffix!r} (PNG or TIFF expected)", path)
    except InputError:
        raise
    except Exception as exc:  # noqa: BLE001 - any decoder failure is the file's problem
        detail = str(exc) or type(exc).__name__
        raise InputError(f"unreadable or truncated image ({detail})", path) from exc
    data = np.asarray(data)
    if data.ndim == 3 and data.shape[-1] in (3, 4) or data.ndim == 3 and data.shape[0] in (3, 4):
        raise InputError(f"expected a single-band (grey) image, got {data.shape} (RGB?)", path)
    if data.ndim == 3 and 1 in (data.shape[0], data.shape[-1]):
        data = data.reshape(data.shape[1:] if data.shape[0] == 1 else data.shape[:-1])
    if data.ndim != 2:
        raise InputError(f"expected a single-band image of rows x columns, got an array of shape {data.shape}", path)
    if data.size == 0:
        raise InputError("the image is empty", path)
    if _NODATA_TAG in georef and nodata is None:
        try:
            nodata = float(str(georef[_NODATA_TAG][2]).strip("\x00 "))
        except ValueError:
            nodata = None
    georef.pop(_NODATA_TAG, None)
    if labels:
        if data.dtype.kind not in "iub":
            raise InputError(f"label raster must be integer, got {data.dtype}", path)
        return Raster(data, georef, None, path)
    if data.dtype == np.float64:
        data = data.astype(np.float32)
    if data.dtype not in _SUPPORTED_DTYPES:
        raise InputError(f"unsupported dtype {data.dtype} (uint8, uint16 or float32)", path)
    raster = Raster(data, georef, nodata, path)
    if check:
        check_image(raster.data, raster.nodata, path)
    return raster


def _full_resolution_pages(tif: Any) -> int:
    """Images in a TIFF, not counting reduced-resolution overviews or masks."""
    count = 0
    for page in tif.pages:
        if not (getattr(page, "is_reduced", False) or getattr(page, "is_mask", False)):
            count += 1
    return count


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
    path = Path(path)
    if not path.is_file():
        raise InputError("file not found", path)
    suffix = path.suffix.lower()
    try:
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

            with _quiet_logger("tifffile"), tifffile.TiffFile(path) as tif:
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
    raise InputError(f"unsupported image type {suffix!r} (PNG or TIFF expected)", path)


@contextlib.contextmanager
def _quiet_logger(name: str) -> Iterator[None]:
    """Silence a library's log messages; its failures reach the user as one InputError."""
    logger = logging.getLogger(name)
    level = logger.level
    logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        logger.setLevel(level)


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
    if min(data.shape) < MIN_SIDE:
        raise InputError(
            f"the image is {data.shape[0]} x {data.shape[1]} px; its smaller side needs at least {MIN_SIDE} px", path
        )
    valid = valid_mask(data, nodata)
    if not valid.any():
        raise InputError("every pixel is NaN or nodata", path)
    values = data[valid]
    if values.min() == values.max():
        raise InputError(f"the image is constant (every valid pixel is {values.flat[0]})", path)


def load_pair_files(
    reference: str | Path,
    target: str | Path,
    *,
    nodata: float | None = None,
    rectified: bool = True,
    name: str | None = None,
) -> Pair:
    """Load any two image files as a pair (no ground truth)."""
    ref = read_raster(reference, nodata)
    tgt = read_raster(target, nodata)
    pair = Pair(ref, tgt, rectified=rectified, name=name or Path(reference).stem)
    _check_pair(pair)
    return pair


def load_pair(folder: str | Path) -> Pair:
    """Load a pair folder described by its ``pair.toml`` manifest.

    Raises
    ------
    InputError
        Missing or malformed manifest, missing files, mismatched sizes, bad images.
    """
    folder = Path(folder)
    manifest_path = folder / MANIFEST if folder.is_dir() else folder
    if folder.is_dir():
        pass
    elif folder.name == MANIFEST and folder.is_file():
        folder = folder.parent
    else:
        raise InputError("not a pair folder (no such directory)", folder)
    if not manifest_path.is_file():
        raise InputError(f"no {MANIFEST} manifest in the pair folder", folder)
    try:
        manifest = tomllib.loads(manifest_path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"malformed manifest: {exc}", manifest_path) from exc
    for key in ("reference", "target"):
        if not isinstance(manifest.get(key), str):
            raise InputError(f"manifest lacks the required key {key!r} (a file name)", manifest_path)
    unknown = set(manifest) - {
        "reference", "target", "disparity", "reference_objects", "target_objects",
        "change_mask", "rectified", "nodata", "metadata", "name",
    }
    if unknown:
        raise InputError(f"unknown manifest keys: {', '.join(sorted(unknown))}", manifest_path)

    def member(key: str) -> Path | None:
        value = manifest.get(key)
        if value is None:
            return None
        candidate = (folder / value).resolve()
        if folder.resolve() not in candidate.parents:
            raise InputError(f"{key} = {value!r} points outside the pair folder", manifest_path)
        if not candidate.is_file():
            raise InputError(f"{key} names a missing file {value!r}", manifest_path)
        return candidate

    nodata = manifest.get("nodata")
    if nodata is not None and not isinstance(nodata, (int, float)):
        raise InputError("nodata must be a number", manifest_path)
    ref_path, tgt_path = member("reference"), member("target")
    pair = Pair(
        reference=read_raster(ref_path, nodata),
        target=read_raster(tgt_path, nodata),
        rectified=bool(manifest.get("rectified", True)),
        metadata=dict(manifest.get("metadata", {})),
        name=str(manifest.get("name", folder.name)),
        source=folder,
    )
    if (path := member("disparity")) is not None:
        disparity = read_raster(path, check=False).data.astype(np.float32)
        pair.disparity = disparity
        _same_shape(pair, disparity, path)
    for key in ("reference_objects", "target_objects"):
        if (path := member(key)) is not None:
            labels = read_raster(path, labels=True).data.astype(np.int32)
            setattr(pair, key, labels)
            _same_shape(pair, labels, path, reference=key == "reference_objects")
    if (path := member("change_mask")) is not None:
        mask = read_raster(path, labels=True).data != 0
        pair.change_mask = mask
        _same_shape(pair, mask, path)
    _check_pair(pair)
    return pair


def _same_shape(pair: Pair, array: np.ndarray, path: Path, reference: bool = True) -> None:
    expected = pair.reference.data.shape if reference else pair.target.data.shape
    if array.shape != expected:
        raise InputError(f"size {array.shape} differs from the image's {expected}", path)


def _check_pair(pair: Pair) -> None:
    ref, tgt = pair.reference, pair.target
    if pair.rectified and ref.data.shape != tgt.data.shape:
        raise InputError(
            f"reference is {ref.data.shape} but target is {tgt.data.shape}; a rectified pair "
            "needs equal sizes (for an unrectified pair: rectified = false in pair.toml, or --unrectified)",
            tgt.path or pair.source,
        )


def save_pair(pair: Pair, folder: str | Path, *, image_suffix: str | None = None) -> Path:
    """Write a pair folder (images, ground truth, manifest), every file atomically.

    The manifest is written last, so a folder whose manifest exists is complete.

    Parameters
    ----------
    pair : Pair
    folder : str or Path
        Destination folder; created if needed.
    image_suffix : str, optional
        ``.tif`` or ``.png``; default ``.tif`` (keeps float data and georeferencing).

    Returns
    -------
    Path
        The manifest path.
    """
    import tomli_w

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    suffix = image_suffix or ".tif"
    manifest: dict[str, Any] = {"name": pair.name}
    for key, raster in (("reference", pair.reference), ("target", pair.target)):
        file = f"{key}{suffix}"
        write_raster(folder / file, raster.data, raster.georef if suffix != ".png" else None, raster.nodata)
        manifest[key] = file
    if pair.disparity is not None:
        write_raster(folder / "disparity.tif", pair.disparity.astype(np.float32))
        manifest["disparity"] = "disparity.tif"
    for key in ("reference_objects", "target_objects"):
        labels = getattr(pair, key)
        if labels is not None:
            write_raster(folder / f"{key}.png", labels)
            manifest[key] = f"{key}.png"
    if pair.change_mask is not None:
        write_raster(folder / "change_mask.png", pair.change_mask.astype(bool))
        manifest["change_mask"] = "change_mask.png"
    manifest["rectified"] = bool(pair.rectified)
    nodata = pair.reference.nodata
    if nodata is not None and not math.isnan(float(nodata)):
        manifest["nodata"] = float(nodata) if isinstance(nodata, float) and not float(nodata).is_integer() else int(nodata)
    if pair.metadata:
        manifest["metadata"] = _toml_safe(pair.metadata)
    atomic_write_bytes(folder / MANIFEST, tomli_w.dumps(manifest).encode("utf-8"))
    return folder / MANIFEST


def _toml_safe(value: Any) -> Any:
    """Convert numpy scalars and tuples so that ``tomli_w`` can write them."""
    if isinstance(value, dict):
        return {str(k): _toml_safe(v) for k, v in value.items() if v is not None}
    if isinstance(value, (list, tuple)):
        return [_toml_safe(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def is_image_file(path: Path) -> bool:
    """True for a file name radcons can read as an image."""
    return path.suffix.lower() in _IMAGE_SUFFIXES
