"""Coarse census disparity of a pair as given, and percentile surfaces under a disparity map.

:func:`coarse_disparity` runs census + SGM (CNES Pandora,
:func:`radcons.numerics.census.census_disparity`) on both images area-averaged by an
integer ``factor`` (:func:`census_factor`, :func:`bounded_factor`: cells of a chosen size,
the larger side bounded, and coarser where one run's cost volume would exceed
:data:`MAX_CENSUS_VOLUME`). With no known range, a first left-right-checked run at half
that resolution searches a share of the image width; the share of the overlap it keeps
valid (:func:`consistent_share`) says whether matching works on the pair at all, and the
1st-99th percentiles of its valid disparities, widened by 2 px below and by half their
span and 2 px above (the few tallest buildings lie above the 99th percentile, mismatched
patches above a higher one), set the range of the second run.

:func:`window_surface` interpolates a percentile of the valid disparities in overlapping
windows under every pixel: the ground under the objects, and the relief's median that
tells which way up a pair is.

References
----------
Hirschmueller, H. (2008). Stereo processing by semiglobal matching and mutual information.
IEEE TPAMI 30(2), 328-341.
"""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np

from radcons.numerics.census import CensusParams, census_disparity
from radcons.numerics.valid_pixels import overlap_share

#: Percentiles of the range-finding run's valid disparities that bound the final run ...
_RANGE_PERCENTILES = (1.0, 99.0)


#: ... the upper one raised by this share of their span (the tallest roofs are rare) ...
_RANGE_SPAN_SHARE = 0.5


#: ... and both widened by this many pixels.
_RANGE_MARGIN = 2.0


#: Largest cost volume of one census run, grid cells times disparities (about 5 s here).
MAX_CENSUS_VOLUME = 32e6


def census_factor(shape: tuple[int, int], cell_px: float, census_side: int) -> int:
    """Integer reduction to cells of about ``cell_px`` px, coarser if the larger side of ``shape`` would exceed ``census_side``."""
    return max(1, int(round(cell_px)), int(np.ceil(max(shape) / census_side)))


def downsample(image: np.ndarray, factor: int) -> np.ndarray:
    """Area-average ``image`` by an integer factor, NaN-aware (NaN where < half is valid)."""
    if factor == 1:
        return image.astype(np.float32, copy=True)
    rows, cols = image.shape[0] // factor, image.shape[1] // factor
    valid = np.isfinite(image)
    filled = np.where(valid, image, 0.0).astype(np.float32)[: rows * factor, : cols * factor]
    weight = valid.astype(np.float32)[: rows * factor, : cols * factor]
    total = cv2.resize(filled, (cols, rows), interpolation=cv2.INTER_AREA)
    share = cv2.resize(weight, (cols, rows), interpolation=cv2.INTER_AREA)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = total / share
    out[share < 0.5] = np.nan
    return out.astype(np.float32)


def upsample(grid: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Bilinear resampling of a reduced grid to ``shape`` (pixel centres aligned), NaN kept."""
    valid = np.isfinite(grid)
    filled = np.where(valid, grid, 0.0).astype(np.float32)
    size = (int(shape[1]), int(shape[0]))
    value = cv2.resize(filled, size, interpolation=cv2.INTER_LINEAR)
    weight = cv2.resize(valid.astype(np.float32), size, interpolation=cv2.INTER_LINEAR)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = value / weight
    out[weight < 0.5] = np.nan
    return out


def coarse_disparity(
    reference: np.ndarray,
    target: np.ndarray,
    factor: int,
    search_share: float,
    census: CensusParams,
    disparity_range: tuple[float, float] | None = None,
) -> tuple[np.ndarray, tuple[float, float], float, int]:
    """Census disparity of the pair at ``1 / factor`` resolution or coarser (full-image pixels).

    Each run's cost volume (grid cells times disparities) is kept within
    :data:`MAX_CENSUS_VOLUME` by a coarser grid (:func:`bounded_factor`): a large image
    with a wide range (a Sentinel-2 pair whose matches spread over 1200 px) would
    otherwise take minutes.

    Parameters
    ----------
    reference, target : ndarray
        The working pair (same shape, NaN where invalid).
    factor : int
        Reduction of the census grid: the finest used.
    search_share : float
        Without ``disparity_range``: the range-finding run searches +/- this share of the
        image width.
    census : CensusParams
        Matcher parameters of the final run (the range-finding run always cross-checks).
    disparity_range : tuple of float, optional
        Known range in full-image pixels (e.g. from the rectification's matches), widened
        by a quarter of its span and 2 px on each side.

    Returns
    -------
    disparity : ndarray
        At the reduced resolution, in full-image pixels, NaN where invalid.
    disparity_range : tuple of float
        The range of the final run (full-image pixels).
    valid_share : float
        Share of the overlap valid in the cross-checked range-finding run (in the final
        run when the range was given; :func:`consistent_share`).
    factor : int
        The reduction of the final run's grid.
    """
    shape = reference.shape
    ref_small, tgt_small = downsample(reference, factor), downsample(target, factor)
    if disparity_range is None:
        tiny_factor = bounded_factor(shape, 2 * factor, 2 * search_share * shape[1])
        if tiny_factor == 2 * factor:
            ref_tiny, tgt_tiny = downsample(ref_small, 2), downsample(tgt_small, 2)
        else:
            ref_tiny, tgt_tiny = downsample(reference, tiny_factor), downsample(target, tiny_factor)
        reach = max(2.0, search_share * ref_tiny.shape[1])
        tiny = checked_census(ref_tiny, tgt_tiny, (-reach, reach), CensusParams(cross_check="accurate"))
        valid = np.isfinite(tiny)
        valid_share = consistent_share(tiny, ref_tiny, tgt_tiny)
        if valid.sum() < 16:
            return np.full(ref_small.shape, np.nan, np.float32), (0.0, 0.0), valid_share, factor
        low, high = (float(v) * tiny_factor for v in np.percentile(tiny[valid], _RANGE_PERCENTILES))
        low, high = low - _RANGE_MARGIN * factor, high + _RANGE_SPAN_SHARE * (high - low) + _RANGE_MARGIN * factor
    else:  # a range from sparse matches: widened by a quarter of its span and 2 px
        low, high = (float(v) for v in disparity_range)
        margin = 0.25 * (high - low) + _RANGE_MARGIN
        low, high = low - margin, high + margin
        valid_share = float("nan")
    coarser = bounded_factor(shape, factor, high - low)
    if coarser != factor:
        factor = coarser
        ref_small, tgt_small = downsample(reference, factor), downsample(target, factor)
    low, high = math.floor(low / factor), math.ceil(high / factor)
    small = checked_census(ref_small, tgt_small, (low, high), census)
    if not math.isfinite(valid_share):
        valid_share = consistent_share(small, ref_small, tgt_small)
    return small * np.float32(factor), (low * factor, high * factor), valid_share, factor


def bounded_factor(shape: tuple[int, int], factor: int, span: float) -> int:
    """``factor``, or the smallest larger one whose census cost volume for ``span`` px of disparity is within :data:`MAX_CENSUS_VOLUME`."""
    while shape[0] * shape[1] * max(span, 1.0) / factor**3 > MAX_CENSUS_VOLUME:
        factor += 1
    return factor


def checked_census(
    reference: np.ndarray, target: np.ndarray, disparity_range: tuple[float, float], census: CensusParams
) -> np.ndarray:
    """Census disparity, left-right checked by two unchecked runs when the check is ``"accurate"``.

    Pandora's accurate check computes the target's disparity too and then compares the
    two maps pixel by pixel in Python, which costs more than the second matching. Here
    the target's disparity is the reference's of the mirrored pair (``fliplr(target)``
    against ``fliplr(reference)`` matches ``target(u) <-> reference(u + d)`` with the same
    sign and range), and a reference pixel is kept when the target's disparity at
    ``x - d`` is within ``cross_check_threshold`` of its own. Other checks go to Pandora.
    """
    if census.cross_check != "accurate":
        return census_disparity(reference, target, disparity_range, census)
    single = replace(census, cross_check="none")
    left = census_disparity(reference, target, disparity_range, single)
    right = census_disparity(target[:, ::-1], reference[:, ::-1], disparity_range, single)[:, ::-1]
    rows, cols = np.indices(left.shape)
    back = np.rint(cols - np.nan_to_num(left, nan=0.0)).astype(np.int64)
    inside = np.isfinite(left) & (back >= 0) & (back < left.shape[1])
    found = np.full(left.shape, np.nan, np.float32)
    found[inside] = right[rows[inside], back[inside]]
    keep = np.abs(found - left) <= census.cross_check_threshold
    return np.where(keep, left, np.nan).astype(np.float32)


def consistent_share(disparity: np.ndarray, reference: np.ndarray, target: np.ndarray) -> float:
    """Share of the pair's overlap (cells valid in both images) where ``disparity`` is valid.

    A pair whose images cover different ground (an affine-rectified crop of another
    extent, a target cut by the scene's edge) has cells that no matcher can match; they
    are not counted against the disparity (0.0 when the images do not overlap;
    :func:`radcons.numerics.valid_pixels.overlap_share`).
    """
    return overlap_share(np.isfinite(disparity), reference, target)


def fill_occlusions(disparity: np.ndarray) -> np.ndarray:
    """Fill each run of invalid pixels along a row with the smaller of the disparities at its two ends.

    A left-right check leaves occlusions (ground hidden beside a building) and
    mismatches invalid: the background, the lower of the two sides, is what an occlusion
    hides, and a hole inside a roof is closed by the roof on both sides. Rows without a
    valid pixel stay NaN.
    """
    valid = np.isfinite(disparity)
    cols = np.arange(disparity.shape[1])
    left = np.maximum.accumulate(np.where(valid, cols, -1), axis=1)
    right = np.minimum.accumulate(np.where(valid, cols, disparity.shape[1])[:, ::-1], axis=1)[:, ::-1]
    rows = np.arange(disparity.shape[0])[:, None]
    from_left = np.where(left >= 0, disparity[rows, np.maximum(left, 0)], np.nan)
    from_right = np.where(right < disparity.shape[1], disparity[rows, np.minimum(right, disparity.shape[1] - 1)], np.nan)
    filled = np.fmin(from_left, from_right)
    return np.where(valid, disparity, filled).astype(np.float32)


def _window_percentiles(disparity: np.ndarray, window: int, percentile: float) -> np.ndarray:
    """A percentile of the valid disparities in windows of ``window`` px, centres every half window."""
    step = max(1, window // 2)
    rows = np.arange(0, disparity.shape[0] + step - 1, step)
    cols = np.arange(0, disparity.shape[1] + step - 1, step)
    grid = np.full((rows.size, cols.size), np.nan, np.float32)
    half = window // 2
    for i, r in enumerate(rows):
        for j, c in enumerate(cols):
            block = disparity[max(r - half, 0) : r + half + 1, max(c - half, 0) : c + half + 1]
            values = block[np.isfinite(block)]
            if values.size >= max(4, block.size // 10):
                grid[i, j] = np.percentile(values, percentile)
    if np.isnan(grid).all():
        return grid
    while np.isnan(grid).any():  # windows without ground take their neighbours' mean
        filled = cv2.blur(np.nan_to_num(grid), (3, 3))
        weight = cv2.blur(np.isfinite(grid).astype(np.float32), (3, 3))
        grid = np.where(np.isfinite(grid), grid, np.where(weight > 0, filled / np.maximum(weight, 1e-6), np.nan))
    return grid.astype(np.float32)


def window_surface(disparity: np.ndarray, window: int, percentile: float) -> np.ndarray:
    """A percentile of the valid disparities in windows of ``window`` px, interpolated under every pixel.

    Window centres lie every half window; windows with fewer than a tenth of their pixels
    valid take their neighbours' mean.

    Returns
    -------
    ndarray, float32
        Same shape as ``disparity``; all NaN when no window has enough valid pixels.
    """
    coarse = _window_percentiles(disparity, window, percentile)
    if np.isnan(coarse).all():
        return np.full(disparity.shape, np.nan, np.float32)
    step = max(1, window // 2)
    size = (coarse.shape[1] * step, coarse.shape[0] * step)
    surface = cv2.resize(coarse, size, interpolation=cv2.INTER_LINEAR)
    shift = step // 2  # window centres sit at multiples of step; resize puts them at step/2
    rows, cols = disparity.shape
    pad = ((0, max(0, rows + shift - surface.shape[0])), (0, max(0, cols + shift - surface.shape[1])))
    surface = np.pad(surface, pad, mode="edge")
    return np.ascontiguousarray(surface[shift : shift + rows, shift : shift + cols])
