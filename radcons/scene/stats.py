"""Pass 1, streamed over row blocks: pixel statistics, grey-level histograms and sigma_max.

Every function here works on one block of rows of one image and returns a small result
that the caller sums over the blocks (on Dask workers, see :mod:`radcons.scene.cluster`):

* :func:`block_stats`: sum, count, min and max of the valid pixels, and for 8- and
  16-bit images the count of every grey value (the histogram of eq 20's range and of
  the refine stage's histogram matching);
* :func:`block_histogram`: the same counts on a fine grid for other dtypes;
* :func:`noise_aware_lut`: the refine background's noise-aware mapping from those counts;
* :func:`block_gram`: ``I_b^T (I_b v)``, one block's share of the power iteration of
  eq 5's ``sigma_max`` (:func:`sigma_max_by_blocks`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import scipy.sparse.linalg

from radcons.numerics.valid_pixels import clipping_pile
from radcons.scene.source import SceneImage
from radcons.stages.global_norm.run import GlobalParams
from radcons.stages.refine import background

__all__ = [
    "ImageStats", "block_stats", "block_histogram", "merge_stats", "row_blocks", "block_gram",
    "block_matvec", "block_rmatvec", "sigma_max_by_blocks", "percentile_of_counts", "histogram_lut", "noise_aware_lut",
    "FINE_BINS",
]

#: Bins of the grey-level histogram of images that are not 8- or 16-bit integers.
FINE_BINS = 65536


@dataclass
class ImageStats:
    """Statistics of the valid pixels of one image (or of one block of it).

    Attributes
    ----------
    total : float
        Sum of the valid pixels.
    total_sq : float
        Sum of their squares.
    count : int
    low, high : float
        Smallest and largest valid value.
    grid : ndarray or None
        Grey values of the histogram (integer images: every value of the dtype; others:
        bin centres over ``[low, high]``).
    counts : ndarray or None
        Pixels at each grey value of ``grid``.
    at_low, at_high : int
        Pixels holding ``low`` and ``high`` exactly.
    """

    total: float = 0.0
    total_sq: float = 0.0
    count: int = 0
    low: float = math.inf
    high: float = -math.inf
    grid: np.ndarray | None = None
    counts: np.ndarray | None = field(default=None, repr=False)
    at_low: int = 0
    at_high: int = 0

    @property
    def mean(self) -> float:
        """Mean of the valid pixels."""
        return self.total / self.count if self.count else math.nan

    @property
    def variance(self) -> float:
        """Variance of the valid pixels."""
        return max(self.total_sq / self.count - self.mean**2, 0.0) if self.count else math.nan

    def clip_levels(self) -> tuple[float, ...]:
        """The image's clipping levels: its extreme values where they pile up (see the module notes)."""
        pile = clipping_pile(self.count)
        return tuple(sorted({level for level, n in ((self.low, self.at_low), (self.high, self.at_high)) if n >= pile}))


def row_blocks(shape: tuple[int, int], pixels: int = 1 << 24) -> list[tuple[int, int, int, int]]:
    """Windows of whole rows of at most about ``pixels`` pixels covering an image."""
    rows, columns = shape
    step = max(1, pixels // max(columns, 1))
    return [(r, min(r + step, rows), 0, columns) for r in range(0, rows, step)]


def _small_int(dtype: np.dtype) -> bool:
    return dtype.kind in "iu" and dtype.itemsize <= 2


def block_stats(window: tuple[int, int, int, int], image: SceneImage) -> ImageStats:
    """Sum, count, extremes (and for 8/16-bit images the grey-value counts) of one window."""
    data = image.read(window)
    values = image.to_float(data)
    valid = np.isfinite(values)
    stats = ImageStats()
    if not valid.any():
        return stats
    picked = values[valid]
    stats.total, stats.count = float(picked.sum(dtype=np.float64)), int(picked.size)
    stats.total_sq = float(np.dot(picked.astype(np.float64), picked.astype(np.float64)))
    stats.low, stats.high = float(picked.min()), float(picked.max())
    stats.at_low, stats.at_high = int((picked == stats.low).sum()), int((picked == stats.high).sum())
    if _small_int(image.dtype):
        info = np.iinfo(image.dtype)
        raw = data[valid].astype(np.int64) - info.min
        stats.counts = np.bincount(raw, minlength=info.max - info.min + 1)
        stats.grid = np.arange(info.min, info.max + 1, dtype=np.float64)
    return stats


def block_histogram(window: tuple[int, int, int, int], image: SceneImage, low: float, high: float) -> np.ndarray:
    """Counts of one window's valid pixels in :data:`FINE_BINS` bins over ``[low, high]``."""
    values = image.read_float(window)
    values = values[np.isfinite(values)]
    counts, _ = np.histogram(values, FINE_BINS, (low, high if high > low else low + 1.0))
    return counts


def merge_stats(parts: list[ImageStats]) -> ImageStats:
    """Statistics of an image from those of its blocks."""
    out = ImageStats()
    for part in parts:
        if part.count == 0:
            continue
        if part.low < out.low:
            out.low, out.at_low = part.low, 0
        if part.high > out.high:
            out.high, out.at_high = part.high, 0
        out.at_low += part.at_low if part.low == out.low else 0
        out.at_high += part.at_high if part.high == out.high else 0
        out.total += part.total
        out.total_sq += part.total_sq
        out.count += part.count
        if part.counts is not None:
            out.counts = part.counts.copy() if out.counts is None else out.counts + part.counts
            out.grid = part.grid
    return out


def percentile_of_counts(grid: np.ndarray, counts: np.ndarray, q: float) -> float:
    """``np.percentile`` (linear) of the values ``grid`` repeated ``counts`` times."""
    cumulative = np.cumsum(counts)
    position = (cumulative[-1] - 1) * q / 100.0
    below, above = math.floor(position), math.ceil(position)
    low = grid[np.searchsorted(cumulative, below, side="right")]
    high = grid[np.searchsorted(cumulative, above, side="right")]
    return float(low + (high - low) * (position - below))


def histogram_lut(source: ImageStats, template: ImageStats, template_scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Histogram matching of the source image onto ``template_scale`` times the template.

    The mapping ``skimage.exposure.match_histograms`` computes on whole images (the
    quantile of each source grey value, interpolated on the template's quantiles), from
    the two images' grey-value counts. A grey-level scaling of the source (eq 6) changes
    no quantile, so the source's own values index the mapping.

    Returns
    -------
    values, mapped : ndarray
        Source grey values present in the image and the value each maps to; apply with
        ``np.interp(image, values, mapped)``.
    """
    keep_s, keep_t = source.counts > 0, template.counts > 0
    src_values, src_counts = source.grid[keep_s], source.counts[keep_s]
    tmpl_values, tmpl_counts = template.grid[keep_t], template.counts[keep_t]
    src_q = np.cumsum(src_counts) / src_counts.sum()
    tmpl_q = np.cumsum(tmpl_counts) / tmpl_counts.sum()
    return src_values, np.interp(src_q, tmpl_q, tmpl_values * float(template_scale))


def noise_aware_lut(
    source: ImageStats, template: ImageStats, scales: tuple[float, float], noise: tuple[float, float]
) -> tuple[tuple[np.ndarray, np.ndarray], float]:
    """The refine background's noise-aware mapping of the source onto the template, from counts.

    :func:`radcons.stages.refine.background.noise_aware_lut` on the two images' grey-value counts,
    with the noise to add (:func:`radcons.stages.refine.background.noise_to_add`) from their
    noise sigmas and variances after eq 6 (``scales`` times each image), expressed in the
    source's own grey values, which then index the mapping as in :func:`histogram_lut`.

    Parameters
    ----------
    source, template : ImageStats
        The target's and the reference's statistics, with grey-value counts.
    scales : (float, float)
        Eq 6's ``lambda`` of the source and of the template.
    noise : (float, float)
        Noise sigmas of the source and of the template in their own grey values.

    Returns
    -------
    (values, mapped) : (ndarray, ndarray)
        As :func:`histogram_lut`.
    added : float
        The noise added to the source, in its grey values after eq 6.
    """
    scale_s, scale_t = scales
    added = background.noise_to_add(
        noise[1] * scale_t, noise[0] * scale_s, template.variance * scale_t**2, source.variance * scale_s**2
    )
    values, mapped = background.noise_aware_lut(
        source.grid, source.counts, template.grid * float(scale_t), template.counts, added / scale_s
    )
    return (values, mapped), added


def _filled(image: SceneImage, window: tuple[int, int, int, int], fill: float) -> np.ndarray:
    values = image.read_float(window)
    values[~np.isfinite(values)] = np.float32(fill)
    return values


def block_gram(window: tuple[int, int, int, int], image: SceneImage, fill: float, v: np.ndarray) -> np.ndarray:
    """``I_b^T (I_b v)`` of one block of rows ``I_b`` (NaN pixels replaced by ``fill``), float64."""
    block = _filled(image, window, fill)
    return (block.T @ (block @ v.astype(np.float32))).astype(np.float64)


def block_matvec(window: tuple[int, int, int, int], image: SceneImage, fill: float, v: np.ndarray) -> np.ndarray:
    """``I_b v`` of one block of rows: its rows of ``I v``."""
    return (_filled(image, window, fill).astype(np.float64) @ v).astype(np.float64)


def block_rmatvec(window: tuple[int, int, int, int], image: SceneImage, fill: float, u: np.ndarray) -> np.ndarray:
    """``I_b^T u_b`` of one block of rows, ``u_b`` its rows of ``u``."""
    return _filled(image, window, fill).astype(np.float64).T @ u[window[0] : window[1]]


def sigma_max_by_blocks(
    gram: Callable[[np.ndarray], np.ndarray],
    columns: int,
    params: GlobalParams = GlobalParams(),
    *,
    matvec: Callable[[np.ndarray], np.ndarray] | None = None,
    rmatvec: Callable[[np.ndarray], np.ndarray] | None = None,
    rows: int = 0,
) -> float:
    """Largest singular value of an image known through block products (eq 5's ``sigma_max``).

    The power iteration of :func:`radcons.stages.global_norm.run.largest_singular_value`
    (``v <- I^T I v / ||.||`` from the constant vector, ``sigma = sqrt(||I^T I v||)``,
    stopping at ``params.tolerance``), with ``I^T I v`` summed over blocks of rows by
    ``gram``. When it has not converged after ``params.max_iterations``, ARPACK's Lanczos
    method (``svds(k=1)``) takes over on a linear operator whose products ``matvec`` and
    ``rmatvec`` also stream over the blocks.

    Parameters
    ----------
    gram : callable
        ``v -> I^T I v`` (float64, length ``columns``).
    columns : int
        Columns of the image.
    params : GlobalParams
    matvec, rmatvec : callable, optional
        ``v -> I v`` and ``u -> I^T u`` for the fallback; without them the last power
        estimate is returned.
    rows : int
        Rows of the image (for the fallback).

    Returns
    -------
    float
    """
    v = np.full(columns, 1.0 / math.sqrt(columns))
    sigma = 0.0
    for _ in range(params.max_iterations):
        w = gram(v)
        norm = float(np.linalg.norm(w))
        if norm == 0.0:
            return 0.0
        new_sigma = math.sqrt(norm)
        converged = abs(new_sigma - sigma) <= params.tolerance * new_sigma
        sigma = new_sigma
        if converged:
            return sigma
        v = w / norm
    if matvec is None or rmatvec is None:
        return sigma
    operator = scipy.sparse.linalg.LinearOperator((rows, columns), matvec=matvec, rmatvec=rmatvec, dtype=np.float64)
    return float(scipy.sparse.linalg.svds(operator, k=1, return_singular_vectors=False, random_state=0)[0])
