"""Height above ground from the pair's own disparity: census disparity, ground surface, height.

A stereo pair carries height: a building is what stands above the ground around it. This
module turns the working pair into a height-above-ground map in three steps:

1. **Disparity** (:func:`coarse_disparity`): census + SGM (CNES Pandora,
   :func:`radcons.census.census_disparity`) of the pair as given, at reduced
   resolution (both images area-averaged by an integer ``factor``: cells of about
   ``census_cell_m``, the larger side at most ``census_side`` px, and coarser where a
   run's cost volume would exceed :data:`MAX_CENSUS_VOLUME`). With no known range, a
   first run at half that resolution searches +/- ``search_share`` of the image width
   with left-right cross-checking; the share of the images' overlap it keeps valid says
   whether matching works on the pair at all (:attr:`HeightMap.valid_share`,
   :func:`consistent_share`), and the 1st-99th percentiles of its
   valid disparities, widened by 2 px below and by half their span and 2 px above, set
   the range of the second run: the few tallest buildings of a scene lie above the 99th percentile (demo pairs
   at 512 px: up to 8 px above it), and a higher percentile takes in mismatched
   patches instead (1024 px: the 99.9th at 240 px, the tallest roof at 77 px).
2. **Ground** (:func:`ground_disparity`): the ``ground_percentile`` of the valid
   disparities in windows of ``ground_window`` px (overlapping by half), interpolated
   bilinearly: a window larger than the largest building always holds ground. Four
   passes of Gaussian-weighted local plane fits (first-order normalised convolution,
   sigma a quarter of the window) through the pixels less than 3, 2, 1 and 1 times the
   height threshold above the current ground then remove the low percentile's bias on
   sloped ground (a percentile of a tilted plane lies below its centre; the first,
   looser passes let the pixels of the upper side of the window back in).
3. **Height** (:func:`height_above_ground`): ``(d - ground) / px_per_unit``, in metres
   when the ground sample distance and the base-to-height ratio are known
   (``px_per_unit = ratio / gsd``) or the RPC models give the metres of one disparity
   pixel, else in disparity pixels of the full image.

References
----------
Hirschmueller, H. (2008). Stereo processing by semiglobal matching and mutual information.
IEEE TPAMI 30(2), 328-341.
Zhang, K. et al. (2003). A progressive morphological filter for removing nonground
measurements from airborne LIDAR data. IEEE TGRS 41(4), 872-882 (ground under buildings
by filters larger than the largest building).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import cv2
import numpy as np

from radcons.census import CensusParams, census_disparity

__all__ = [
    "HeightMap", "census_factor", "bounded_factor", "downsample", "upsample", "coarse_disparity", "checked_census",
    "consistent_share", "fill_occlusions", "window_surface", "ground_disparity", "height_above_ground",
]

#: Percentiles of the range-finding run's valid disparities that bound the final run ...
_RANGE_PERCENTILES = (1.0, 99.0)
#: ... the upper one raised by this share of their span (the tallest roofs are rare) ...
_RANGE_SPAN_SHARE = 0.5
#: ... and both widened by this many pixels.
_RANGE_MARGIN = 2.0
#: Largest cost volume of one census run, grid cells times disparities (about 5 s here).
MAX_CENSUS_VOLUME = 32e6

#: The ground's plane fits are solved on blocks of sigma over this many pixels
#: (see :func:`_local_plane`).
_BLUR_STEP_SIGMAS = 4.0


@dataclass(frozen=True)
class HeightMap:
    """Disparity, ground and height above ground of the reference, at census resolution.

    Attributes
    ----------
    disparity : ndarray, float32
        Census disparity in pixels of the full image (``reference(x, y) <-> target(x - d,
        y)``), at the reduced resolution, NaN where invalid.
    ground : ndarray, float32
        Ground disparity under every pixel (full-image pixels), same grid.
    height : ndarray, float32
        Height above ground in :attr:`unit`, NaN where the disparity is invalid.
    unit : str
        ``"m"`` or ``"px"`` (disparity pixels of the full image).
    px_per_unit : float
        Disparity pixels per unit of height.
    factor : int
        Reduction of the census grid against the full image.
    disparity_range : tuple of float
        Range searched by the census run (full-image pixels).
    valid_share : float
        Share of the pair's overlap the left-right-checked range-finding run kept valid
        (:func:`consistent_share`).
    """

    disparity: np.ndarray
    ground: np.ndarray
    height: np.ndarray
    unit: str
    px_per_unit: float
    factor: int
    disparity_range: tuple[float, float]
    valid_share: float

    def searched_disparities(self) -> np.ndarray:
        """The integer disparities (full-image px) that take in :attr:`disparity_range`."""
        low, high = self.disparity_range
        return np.arange(int(np.floor(low)), int(np.ceil(high)) + 1)

    def full(self, shape: tuple[int, int], which: str = "height") -> np.ndarray:
        """One of the maps resampled bilinearly to the full image ``shape`` (NaN kept)."""
        grid = getattr(self, which)
        return upsample(grid, shape)


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
    are not counted against the disparity (0.0 when the images do not overlap).
    """
    overlap = np.isfinite(reference) & np.isfinite(target)
    count = int(overlap.sum())
    return float((np.isfinite(disparity) & overlap).sum() / count) if count else 0.0


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


def ground_disparity(
    disparity: np.ndarray, window: int, percentile: float, threshold: float
) -> np.ndarray:
    """Ground (terrain) disparity under every pixel of a disparity map.

    Parameters
    ----------
    disparity : ndarray
        Disparity map (NaN where invalid).
    window : int
        Side of the windows, px of this map: larger than the largest building.
    percentile : float
        Percentile of each window's valid disparities taken as its ground.
    threshold : float
        Pixels less than this (disparity px) above the ground are ground for the slope
        correction.

    Returns
    -------
    ndarray, float32
        Ground disparity, finite everywhere (NaN only when no pixel is valid).
    """
    window = max(3, min(int(window), max(disparity.shape)))
    ground = window_surface(disparity, window, percentile)
    if np.isnan(ground).all():
        return ground
    sigma = window / 4.0
    valid = np.isfinite(disparity)
    filled = np.where(valid, disparity, 0.0).astype(np.float32)
    for allowance in (3.0, 2.0, 1.0, 1.0):
        near = valid & (filled - ground < allowance * threshold)
        ground = _local_plane(filled, near, sigma, ground)
    return ground


def _local_plane(values: np.ndarray, weights: np.ndarray, sigma: float, previous: np.ndarray) -> np.ndarray:
    """Gaussian-weighted least-squares plane through ``values`` where ``weights``, at every pixel.

    First-order normalised convolution: unlike a weighted mean, a plane fit follows a
    slope without bias, at the image's edges too. Pixels whose neighbourhood holds too
    little weight, or weight along a line only, keep ``previous``. A fit over a Gaussian
    of ``sigma`` px varies little within ``sigma / 4`` px: the weighted moments are
    summed in blocks of ``step`` px (at most a quarter of sigma), blurred and solved
    there, and the planes' coefficients resampled bilinearly to every pixel.
    """
    step = max(1, int(sigma // _BLUR_STEP_SIGMAS))
    shape = values.shape
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float64)
    w = weights.astype(np.float64)
    d = np.where(weights, values, 0.0).astype(np.float64)

    def moment(array: np.ndarray) -> np.ndarray:
        small = _block_mean(array, step)
        return cv2.GaussianBlur(small, (0, 0), sigma / step, borderType=cv2.BORDER_CONSTANT)

    s0, sx, sy = moment(w), moment(w * cols), moment(w * rows)
    sxx, sxy, syy = moment(w * cols * cols), moment(w * cols * rows), moment(w * rows * rows)
    sd, sxd, syd = moment(w * d), moment(w * cols * d), moment(w * rows * d)
    normal = np.stack(
        [np.stack([s0, sx, sy], -1), np.stack([sx, sxx, sxy], -1), np.stack([sy, sxy, syy], -1)], -2
    )
    right = np.stack([sd, sxd, syd], -1)
    support = moment(np.ones_like(w))
    good = s0 > 0.05 * support
    good &= np.abs(np.linalg.det(normal)) > 1e-9 * np.maximum(s0, 1e-12) ** 3 * sigma**4
    coef = np.zeros(s0.shape + (3,))
    if good.any():
        coef[good] = np.linalg.solve(normal[good], right[good][:, :, None])[:, :, 0]
    if step > 1:  # the planes' coefficients, smooth, resampled to every pixel
        size = (s0.shape[1] * step, s0.shape[0] * step)
        good = cv2.resize(good.astype(np.float64), size, interpolation=cv2.INTER_LINEAR)[: shape[0], : shape[1]]
        coef = cv2.resize(coef, size, interpolation=cv2.INTER_LINEAR)[: shape[0], : shape[1]]
        with np.errstate(invalid="ignore", divide="ignore"):
            coef = coef / good[:, :, None]
        good = good > 0.999
    fitted = coef[:, :, 0] + coef[:, :, 1] * cols + coef[:, :, 2] * rows
    return np.where(good, fitted, previous).astype(np.float32)


def _block_mean(array: np.ndarray, step: int) -> np.ndarray:
    """Mean over blocks of ``step`` x ``step`` px (zero-padded at the far edges)."""
    if step == 1:
        return array
    padded = np.pad(array, ((0, -array.shape[0] % step), (0, -array.shape[1] % step)))
    return padded.reshape(padded.shape[0] // step, step, padded.shape[1] // step, step).mean(axis=(1, 3))


def height_above_ground(
    disparity: np.ndarray, ground: np.ndarray, px_per_m: float | None
) -> tuple[np.ndarray, str, float]:
    """Height above ground, in metres when the geometry is known, else in disparity pixels.

    ``h = (d - ground) / px_per_m``: one metre of height adds ``px_per_m = r / g`` pixels of
    disparity (``r`` the base-to-height ratio, ``g`` the ground sample distance in metres;
    or the inverse of the metres per disparity pixel of RPC models).

    Returns
    -------
    height : ndarray, float32
    unit : str
        ``"m"`` or ``"px"``.
    px_per_unit : float
    """
    if px_per_m and px_per_m > 0:
        px_per_unit, unit = float(px_per_m), "m"
    else:
        px_per_unit, unit = 1.0, "px"
    return ((disparity - ground) / np.float32(px_per_unit)).astype(np.float32), unit, px_per_unit
