"""Preview rasters for a recording: block means and strided samples, and display ranges.

A recording keeps images at full resolution up to :data:`PREVIEW_MAX_SIDE` pixels on the
longest side. Larger images are logged as previews reduced by the smallest integer factor
``f`` that brings the longest side to at most that size, and placed with a ``[f, f]``
scale so that every overlay (points, lines) stays in full-resolution pixel coordinates.
Grey images are reduced by the mean of each ``f x f`` block over its valid pixels (NaN
where none is valid); label rasters, masks and disparity maps are sampled (the top-left
pixel of each block), which keeps ids and disparities true values.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["PREVIEW_MAX_SIDE", "preview_factor", "block_mean", "subsample", "display_range"]

#: Longest image side, in pixels, logged at full resolution.
PREVIEW_MAX_SIDE = 2048


def preview_factor(shape: tuple[int, ...], full_resolution: bool = False) -> int:
    """Reduction factor of the previews of images of ``shape`` (1 = full resolution)."""
    if full_resolution:
        return 1
    return max(1, math.ceil(max(shape) / PREVIEW_MAX_SIDE))


def block_mean(image: np.ndarray, factor: int) -> np.ndarray:
    """Mean of every ``factor x factor`` block over its finite pixels, float32.

    The last row and column of blocks may be partial; a block without a finite pixel is
    NaN. ``factor == 1`` returns the image itself (float32, not copied when it already is).
    """
    image = np.asarray(image, dtype=np.float32)
    if factor == 1:
        return image
    rows, cols = image.shape
    out_rows, out_cols = -(-rows // factor), -(-cols // factor)
    padded = np.full((out_rows * factor, out_cols * factor), np.nan, np.float32)
    padded[:rows, :cols] = image
    blocks = padded.reshape(out_rows, factor, out_cols, factor)
    finite = np.isfinite(blocks)
    total = np.where(finite, blocks, 0.0).sum(axis=(1, 3), dtype=np.float64)
    count = finite.sum(axis=(1, 3))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / count, np.nan).astype(np.float32)


def subsample(raster: np.ndarray, factor: int) -> np.ndarray:
    """The top-left pixel of every ``factor x factor`` block (the raster itself for 1)."""
    return raster if factor == 1 else np.ascontiguousarray(raster[::factor, ::factor])


def display_range(images: list[np.ndarray]) -> tuple[float, float]:
    """One grey display range for images shown side by side (the two images of a stage).

    ``[min(0, low), high]`` with ``low``, ``high`` the extreme finite values over all
    ``images``: nothing is clipped, 0 stays black, and a difference of brightness between
    the images shows as it is. ``(0, 1)`` when no value is finite.
    """
    lows = [float(np.fmin.reduce(image, axis=None)) for image in images if image.size]
    highs = [float(np.fmax.reduce(image, axis=None)) for image in images if image.size]
    lows = [v for v in lows if math.isfinite(v)]
    highs = [v for v in highs if math.isfinite(v)]
    if not lows:
        return 0.0, 1.0
    low, high = min(0.0, min(lows)), max(highs)
    return low, high if high > low else low + 1.0
