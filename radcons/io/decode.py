"""Decoding PNG and TIFF files into arrays, for :func:`radcons.io.raster.read_raster`.

The decoders return every band of the file (bands last); making one band of them and
checking it is :mod:`radcons.io.raster`'s work.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Container
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from radcons.errors import InputError

__all__ = ["quiet_logger", "full_resolution_pages", "read_tiff", "read_png"]


@contextlib.contextmanager
def quiet_logger(name: str) -> Iterator[None]:
    """Silence a library's log messages; its failures reach the user as one InputError."""
    logger = logging.getLogger(name)
    level = logger.level
    logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        logger.setLevel(level)


def full_resolution_pages(tif: Any) -> int:
    """Images in a TIFF, not counting reduced-resolution overviews or masks."""
    count = 0
    for page in tif.pages:
        if not (getattr(page, "is_reduced", False) or getattr(page, "is_mask", False)):
            count += 1
    return count


def read_tiff(path: Path, keep: Container[int]) -> tuple[np.ndarray, bool, dict[int, tuple[int, int, Any]]]:
    """Decode a single-image (Geo)TIFF with tifffile.

    Parameters
    ----------
    path : Path
    keep : container of int
        Codes of the tags to return (:data:`radcons.io.raster.GEO_TAGS`).

    Returns
    -------
    data : ndarray
        The pixels, bands last.
    alpha : bool
        Whether the first extra sample is an alpha channel.
    georef : dict
        Tag code -> ``(datatype, count, value)`` of the tags in ``keep``.

    Raises
    ------
    InputError
        A multi-page TIFF (overviews and masks are not counted).
    ValueError
        A TIFF without images; tifffile's own errors pass through.
    """
    import tifffile

    georef: dict[int, tuple[int, int, Any]] = {}
    with quiet_logger("tifffile"), tifffile.TiffFile(path) as tif:
        if not len(tif.pages):
            raise ValueError("no image in the file")
        pages = full_resolution_pages(tif)
        if pages > 1:
            raise InputError(
                f"multi-page TIFF ({pages} images); radcons reads one image per file: "
                "save the page you want on its own", path
            )
        page = tif.pages.first
        for tag in page.tags.values():
            if tag.code in keep:
                georef[tag.code] = (int(tag.dtype), int(tag.count), tag.value)
        data = page.asarray()
        if data.ndim == 3 and page.axes.startswith("S"):
            data = np.moveaxis(data, 0, -1)
        alpha = bool(page.extrasamples) and int(page.extrasamples[0]) in (1, 2)
    return data, alpha, georef


def read_png(path: Path) -> tuple[np.ndarray, bool]:
    """Decode a PNG with OpenCV, colour bands in R, G, B(, A) order.

    Parameters
    ----------
    path : Path

    Returns
    -------
    data : ndarray
        The pixels, bands last.
    alpha : bool
        Whether the image has an alpha channel (grey + alpha or RGBA).

    Raises
    ------
    ValueError
        OpenCV cannot read the file.
    """
    import cv2

    data = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if data is None:
        raise ValueError("not a readable PNG")
    if data.ndim == 3:  # OpenCV's order is B, G, R(, A)
        data = np.concatenate([data[..., 2::-1], data[..., 3:]], axis=-1)
    alpha = data.ndim == 3 and data.shape[-1] in (2, 4)
    return data, alpha
