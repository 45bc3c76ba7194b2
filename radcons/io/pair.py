"""Stereo pair folders: the ``pair.toml`` manifest, loading and saving.

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

Every file the manifest names lies inside the pair folder: an absolute path, ``..`` out of
it or a symbolic link that leaves it is refused (:func:`read_manifest`) before any file is
read. Every file is written atomically and the manifest last, so a folder whose manifest
exists is complete.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from radcons.errors import InputError
from radcons.io.atomic import atomic_write_bytes
from radcons.io.paths import file_inside
from radcons.io.raster import Raster, read_raster, write_raster

__all__ = ["Pair", "Manifest", "MANIFEST", "FILE_KEYS", "read_manifest", "load_pair", "load_pair_files", "save_pair"]

MANIFEST = "pair.toml"
#: Manifest keys that name a file of the pair folder, the two images first.
FILE_KEYS = ("reference", "target", "disparity", "reference_objects", "target_objects", "change_mask")
_KEYS = frozenset({*FILE_KEYS, "rectified", "nodata", "metadata", "name"})


@dataclass
class Pair:
    """A stereo pair: reference (left) and target (right) image plus optional ground truth.

    Disparity follows the project convention: ``reference(x, y) <-> target(x - d, y)``,
    NaN where unknown. Object label rasters use 0 for background and the same id for the
    same building in both images. ``geometry`` says where ``rectified`` came from:
    ``"given"`` (the manifest, the caller or the user), ``"sizes"`` (two sizes, so not
    rectified) or ``"assumed"`` (equal sizes; :func:`radcons.geometry.settle_geometry`
    checks it by the vertical parallax of SIFT matches).
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
    geometry: str = "given"

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


def load_pair_files(
    reference: str | Path,
    target: str | Path,
    *,
    nodata: float | None = None,
    rectified: bool | None = None,
    name: str | None = None,
    band: int | None = None,
) -> Pair:
    """Load any two image files as a pair (no ground truth).

    Parameters
    ----------
    reference, target : str or Path
        The two images (the reference is the left image of an epipolar pair).
    nodata : float, optional
        Value marking missing pixels in both.
    rectified : bool, optional
        Whether rows correspond. None decides: two images of different sizes cannot be
        a rectified pair, so they are taken as unrectified; equal sizes as rectified.
    name : str, optional
        The pair's name (default: the reference's file name).
    band : int, optional
        1-based band of multiband images (default: the grey rule of :mod:`radcons.io.bands`).
    """
    ref = read_raster(reference, nodata, band=band)
    tgt = read_raster(target, nodata, band=band)
    geometry = "given"
    if rectified is None:
        rectified = ref.data.shape == tgt.data.shape
        geometry = "assumed" if rectified else "sizes"
    pair = Pair(ref, tgt, rectified=rectified, name=name or Path(reference).stem, geometry=geometry)
    _check_pair(pair)
    return pair


@dataclass(frozen=True)
class Manifest:
    """A pair folder's ``pair.toml``, read and checked.

    Attributes
    ----------
    path : Path
        The manifest file.
    data : dict
        Its keys and values.
    files : dict
        Each key of :data:`FILE_KEYS` the manifest holds -> its file, resolved, inside the
        pair folder and existing.
    """

    path: Path
    data: dict[str, Any]
    files: dict[str, Path]

    @property
    def folder(self) -> Path:
        """The pair folder."""
        return self.path.parent


def read_manifest(folder: str | Path) -> Manifest:
    """Read a pair folder's manifest and check every file it names, before any is read.

    Parameters
    ----------
    folder : str or Path
        The pair folder, or its ``pair.toml``.

    Returns
    -------
    Manifest

    Raises
    ------
    InputError
        No such folder, no or a malformed manifest, a missing required key, an unknown
        key, or a file key that is not a file name inside the folder (an absolute path,
        ``..`` out of it, a symbolic link that leaves it), or names no existing file.
    """
    folder = Path(folder)
    if folder.name == MANIFEST and folder.is_file():
        folder = folder.parent
    elif not folder.is_dir():
        raise InputError("not a pair folder (no such directory)", folder)
    path = folder / MANIFEST
    if not path.is_file():
        raise InputError(f"no {MANIFEST} manifest in the pair folder", folder)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"malformed manifest: {exc}", path) from exc
    except OSError as exc:
        raise InputError(f"unreadable manifest ({exc.strerror or exc})", path) from exc
    for key in ("reference", "target"):
        if not isinstance(data.get(key), str):
            raise InputError(f"manifest lacks the required key {key!r} (a file name)", path)
    unknown = set(data) - _KEYS
    if unknown:
        raise InputError(f"unknown manifest keys: {', '.join(sorted(unknown))}", path)
    for key in FILE_KEYS:
        if key in data and not isinstance(data[key], str):
            raise InputError(f"{key} must be a file name, got {data[key]!r}", path)
    files = {key: file_inside(folder, data[key], path, key) for key in FILE_KEYS if key in data}
    return Manifest(path, data, files)


def load_pair(folder: str | Path, *, band: int | None = None, rectified: bool | None = None) -> Pair:
    """Load a pair folder described by its ``pair.toml`` manifest.

    ``band`` picks a band of multiband images; ``rectified`` applies when the manifest has
    no ``rectified`` key (the manifest's key wins), else the sizes decide as in
    :func:`load_pair_files`.

    Raises
    ------
    InputError
        Missing or malformed manifest, missing files, mismatched sizes, bad images.
    """
    manifest = read_manifest(folder)
    data, files = manifest.data, manifest.files
    nodata = data.get("nodata")
    if nodata is not None and not isinstance(nodata, (int, float)):
        raise InputError("nodata must be a number", manifest.path)
    ref_path, tgt_path = files["reference"], files["target"]
    pair = Pair(
        reference=read_raster(ref_path, nodata, band=band),
        target=read_raster(tgt_path, nodata, band=band),
        rectified=True,
        metadata=dict(data.get("metadata", {})),
        name=str(data.get("name", manifest.folder.name)),
        source=manifest.folder,
    )
    if "rectified" in data:
        pair.rectified = bool(data["rectified"])
    elif rectified is not None:
        pair.rectified = rectified
    else:
        pair.rectified = pair.reference.data.shape == pair.target.data.shape
        pair.geometry = "assumed" if pair.rectified else "sizes"
    if (path := files.get("disparity")) is not None:
        disparity = read_raster(path, check=False).data.astype(np.float32)
        pair.disparity = disparity
        _same_shape(pair, disparity, path)
    for key in ("reference_objects", "target_objects"):
        if (path := files.get(key)) is not None:
            labels = read_raster(path, labels=True).data.astype(np.int32)
            setattr(pair, key, labels)
            _same_shape(pair, labels, path, reference=key == "reference_objects")
    if (path := files.get("change_mask")) is not None:
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
        write_raster(
            folder / file,
            raster.data,
            raster.georef if suffix != ".png" else None,
            raster.nodata,
            raster.gdal if suffix != ".png" else None,
        )
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

