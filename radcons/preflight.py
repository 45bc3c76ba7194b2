"""The checks the command line makes before any compute: paths, disk, memory, nodata.

Everything here reads file headers and the file system only, so a bad invocation is
refused in well under a second, before an image is decoded or a stage runs. The image and
parameter checks themselves live in :mod:`radcons.io` and :mod:`radcons.validate`.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Sequence

import numpy as np

from radcons.errors import InputError, ParamsError
from radcons.io import (
    MANIFEST,
    ImageHeader,
    check_input_file,
    read_header,
    read_manifest,
    valid_mask,
)
from radcons.io.raster import check_size

__all__ = [
    "BYTES_PER_PIXEL",
    "input_files",
    "image_files",
    "check_memory",
    "check_nodata",
    "check_output_folder",
    "check_output_file",
    "check_params_file",
    "check_params_output",
    "check_scene_options",
    "check_scheduler_address",
    "available_memory",
    "output_bytes",
    "headers_of",
    "check_sizes",
    "memory_budget",
    "parse_size",
    "needs_scene",
    "scene_output_bytes",
    "check_scene_content",
]

#: Peak resident memory of an in-memory run per pixel of the pair (both images), bytes:
#: 4096 x 4096 uint16 pairs take about 4.4 GiB with the default preset (about 280 bytes a
#: pixel), rounded up.
BYTES_PER_PIXEL = 300


def input_files(pair_args: Sequence[Path]) -> tuple[list[Path], Path | None]:
    """Return every input file a pair argument names, and the pair folder if one was given.

    Two images are checked to be existing files; a pair folder's manifest is read and every
    file it names checked to lie inside the folder and exist (:func:`radcons.io.read_manifest`),
    so that nothing outside the folder is read, not even a header.

    Raises
    ------
    InputError
        A missing image, a symbolic link loop, a folder given as an image, or a manifest
        that is missing, malformed or names a file outside its folder or a missing one.
    """
    if len(pair_args) != 1:
        return [check_input_file(path) for path in map(Path, pair_args)], None
    manifest = read_manifest(pair_args[0])
    return [manifest.path, *manifest.files.values()], manifest.folder


def image_files(pair_args: Sequence[Path]) -> list[Path]:
    """The reference and target image files of a pair argument (folder or two files)."""
    files, folder = input_files(pair_args)
    return files[1:3] if folder is not None else files


def available_memory() -> int:
    """Bytes of memory available to a new process (Linux ``MemAvailable``, else total)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))


def check_memory(headers: Sequence[ImageHeader], paths: Sequence[Path], available: int | None = None) -> None:
    """Refuse a pair whose in-memory run would not fit in the memory available.

    Raises
    ------
    InputError
        Naming the pixel count, the memory needed and the memory available.
    """
    available = available_memory() if available is None else available
    pixels = max(header.pixels for header in headers)
    needed = pixels * BYTES_PER_PIXEL
    if needed > available:
        raise InputError(
            f"the pair has {pixels / 1e6:.0f} Mpx per image and would need about {needed / 2**30:.1f} GiB "
            f"of memory, {available / 2**30:.1f} GiB available; process it in scene mode "
            "(`radcons process --tiles`, tile by tile with bounded memory) or a crop of it",
            paths[0],
        )


def check_nodata(nodata: float | None, headers: Sequence[ImageHeader], paths: Sequence[Path]) -> None:
    """Refuse a ``--nodata`` value that an integer image cannot hold."""
    if nodata is None:
        return
    for header, path in zip(headers, paths):
        if header.dtype.kind in "iu":
            info = np.iinfo(header.dtype)
            if not (float(nodata).is_integer() and info.min <= nodata <= info.max):
                raise InputError(
                    f"--nodata {nodata:g} cannot occur in a {header.dtype} image (integers {info.min}..{info.max})",
                    path,
                )


def check_output_folder(out: Path, inputs: Sequence[Path], pair_folder: Path | None, needed_bytes: int) -> None:
    """Refuse an output folder that would overwrite inputs, cannot be written or does not fit.

    ``out`` is replaced whole when the run ends (:func:`radcons.io.staged_folder`), so it
    may not hold any input, may not be (inside) the input pair folder, and, if it already
    exists, must be an earlier radcons result (a folder with a manifest) or empty.

    Raises
    ------
    InputError
    """
    target = out.resolve()
    for path in inputs:
        source = path.resolve()
        if target == source or target in source.parents:
            raise InputError(f"--out would replace the input {path}; choose another folder", out)
    if pair_folder is not None:
        folder = pair_folder.resolve()
        if target == folder or folder in target.parents:
            raise InputError(f"--out is inside the input pair folder {pair_folder}; choose a folder outside it", out)
    if out.exists():
        if not out.is_dir():
            raise InputError("--out exists and is not a folder", out)
        if any(out.iterdir()) and not (out / MANIFEST).is_file():
            raise InputError(
                f"--out holds files but no {MANIFEST}: it is not an earlier radcons result and would be "
                "replaced whole; choose a new or empty folder", out
            )
    existing = _nearest_existing(target.parent)
    _check_writable_folder(existing, out, "--out")
    free = shutil.disk_usage(existing).free
    if needed_bytes > free:
        raise InputError(
            f"the output needs about {needed_bytes / 2**20:.0f} MiB, {free / 2**20:.0f} MiB free on its disk", out
        )


def check_output_file(path: Path, inputs: Sequence[Path], what: str) -> None:
    """Refuse an output file (recording, JSON) that is an input, a folder, or unwritable."""
    target = path.resolve()
    if any(target == source.resolve() for source in inputs):
        raise InputError(f"{what} would overwrite an input", path)
    if path.is_dir():
        raise InputError(f"{what} is a folder, not a file", path)
    _check_writable_folder(_nearest_existing(target.parent), path, what)


def check_params_output(path: Path) -> None:
    """Refuse a ``radcons params`` output that is a folder or cannot be written."""
    if path.is_dir():
        raise InputError(f"is a folder; name the file to write, such as {path / 'params.toml'}", path)
    check_output_file(path, [], "the parameter file")


def check_scene_options(tiles: int | None, scheduler: str | None) -> None:
    """Refuse a ``--tiles`` size or a ``--scheduler`` address scene mode cannot take.

    Tiles are 64 to 16384 px and a multiple of 64 (the tiled TIFF's blocks); nothing is
    checked of what was not given.

    Raises
    ------
    ParamsError
    """
    if tiles is not None and (not 64 <= tiles <= 16384 or tiles % 64):
        raise ParamsError(f"--tiles must be between 64 and 16384 px and a multiple of 64, got {tiles}")
    if scheduler is not None:
        check_scheduler_address(scheduler)


#: Dask's network protocols a scheduler address may name (``inproc`` reaches only a
#: scheduler of this process).
SCHEDULER_PROTOCOLS = ("tcp", "tls", "ws", "wss", "ucx", "inproc")


def check_scheduler_address(address: str) -> None:
    """Refuse a ``--scheduler`` value that is not a Dask scheduler address.

    Dask takes ``[protocol://]host:port`` (``tcp`` when no protocol is given), and
    ``inproc://name``. Whether a scheduler answers there is known once the run connects.

    Parameters
    ----------
    address : str
        The address given.

    Raises
    ------
    ParamsError
        An unknown protocol, no host, no port, or a port outside 1..65535.
    """
    protocol, _, rest = address.rpartition("://")
    protocol = protocol or "tcp"
    problem = None
    if protocol not in SCHEDULER_PROTOCOLS:
        problem = f"unknown protocol {protocol!r} (Dask's: {', '.join(SCHEDULER_PROTOCOLS)})"
    elif protocol != "inproc":
        host, colon, port = rest.rpartition(":")
        if not colon:
            problem = "it names no port"
        elif not host.strip("[]"):
            problem = "it names no host"
        elif not port.isdigit() or not 1 <= int(port) <= 65535:
            problem = f"the port {port!r} is not a number in 1..65535"
    elif not rest:
        problem = "it names no scheduler"
    if problem is not None:
        raise ParamsError(
            f"--scheduler {address!r} is not a Dask scheduler address such as tcp://host:8786: {problem}"
        )


def _check_writable_folder(existing: Path, path: Path, what: str) -> None:
    if not existing.is_dir():
        raise InputError(f"cannot create {what}: {existing} is a file, not a folder", path)
    if not os.access(existing, os.W_OK | os.X_OK):
        raise InputError(f"cannot write {what} in {existing} (permission denied)", path)


def check_params_file(path: Path | None) -> None:
    """Refuse a ``--params`` path that is missing or not a file (before reading it)."""
    if path is None:
        return
    if not path.exists():
        raise ParamsError("parameter file not found", path)
    if not path.is_file():
        raise ParamsError("--params must be a TOML file, not a folder", path)


def _nearest_existing(path: Path) -> Path:
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def output_bytes(headers: Sequence[ImageHeader]) -> int:
    """Bytes the output pair folder will take: both images and ground-truth rasters, rounded up."""
    return sum(header.pixels * header.bands * header.dtype.itemsize for header in headers) + 2 * max(
        header.pixels for header in headers
    ) * 4 + (1 << 20)


def headers_of(paths: Sequence[Path]) -> list[ImageHeader]:
    """Headers of the reference and target images (see :func:`radcons.io.read_header`)."""
    return [read_header(path) for path in paths]


def check_sizes(headers: Sequence[ImageHeader], paths: Sequence[Path]) -> None:
    """Refuse an image smaller than some stage takes, from its header
    (:data:`radcons.io.raster.MIN_SIDE`)."""
    for header, path in zip(headers, paths):
        check_size(header.shape, path)


#: Share of the available memory a run may use unless ``--memory-limit`` says otherwise.
MEMORY_SHARE = 0.5
_UNITS = {"": 1, "k": 1 << 10, "m": 1 << 20, "g": 1 << 30, "t": 1 << 40}


def memory_budget(limit: str | None = None) -> int:
    """Bytes a run may use: ``limit`` (``"8G"``, ``"512M"``, bytes) or half the available memory.

    Raises
    ------
    ParamsError
        A limit that is not a size.
    """
    return parse_size(limit) if limit is not None else int(available_memory() * MEMORY_SHARE)


def parse_size(text: str) -> int:
    """Bytes of a size such as ``"4G"``, ``"512MiB"``, ``"1.5g"`` or ``"1000000"``.

    Raises
    ------
    ParamsError
        Not a positive size.
    """
    value = str(text).strip().lower().removesuffix("ib").removesuffix("b")
    unit = value[-1:] if value[-1:] in _UNITS else ""
    try:
        number = float(value[: len(value) - len(unit)])
    except ValueError:
        number = float("nan")
    if not number > 0 or number == float("inf"):
        raise ParamsError(f"--memory-limit must be a size such as 4G or 512M, got {text!r}")
    return int(number * _UNITS[unit])


def needs_scene(headers: Sequence[ImageHeader], budget: int) -> bool:
    """True when an in-memory run of the pair would pass ``budget`` bytes (:data:`BYTES_PER_PIXEL`)."""
    return max(header.pixels for header in headers) * BYTES_PER_PIXEL > budget


def scene_output_bytes(headers: Sequence[ImageHeader]) -> int:
    """Bytes a scene run's output may take while it is written.

    Both images uncompressed with a third more for overviews, twice: the workers' blocks
    wait in scratch files beside the output files until these are laid out
    (:mod:`radcons.io.tiled_tiff`).
    """
    images = sum(header.pixels * header.dtype.itemsize for header in headers)
    return 2 * (images * 4 // 3) + (1 << 20)


#: Samples per side of the decimated read :func:`check_scene_content` makes.
CONTENT_SAMPLES = 256


def check_scene_content(path: Path, shape: tuple[int, int], band: int | tuple[int, ...] = 1,
                        nodata: float | None = None) -> None:
    """Refuse a scene image that is all nodata or one value (a header-only or blank file).

    ``band`` is the band read, or the bands whose grey value is read (as
    :class:`radcons.scene.source.SceneImage`).

    Reads at most :data:`CONTENT_SAMPLES` x :data:`CONTENT_SAMPLES` pixels (nearest pixels
    of a decimated read, from the file's overviews when it has them), so that a blank
    scene is refused before a cluster streams it whole.

    Raises
    ------
    InputError
        Every sample is nodata (or NaN), or every valid sample has one value.
    """
    from radcons.io.gdal import read_decimated_gdal

    samples = (min(shape[0], CONTENT_SAMPLES), min(shape[1], CONTENT_SAMPLES))
    data = read_decimated_gdal(path, samples, band, labels=True)  # labels: nearest pixels
    if data.ndim == 3:  # several bands: their grey value, as the scene reads them
        from radcons.io.bands import grey_band

        data = grey_band(data, None, path)[0]
    valid = valid_mask(data, nodata)
    where = f"{samples[0]} x {samples[1]} pixels sampled over the {shape[0]} x {shape[1]} image"
    if not valid.any():
        raise InputError(f"the image holds no valid pixel (nodata or NaN at all {where}); nothing to process", path)
    values = data[valid]
    if values.min() == values.max():
        raise InputError(f"the image is constant ({values.flat[0]} at all {where}); nothing to process", path)
