"""An object's disparity D̄m refined at full resolution by the census cost of its pixels.

The objects of the height method (:mod:`radcons.stages.objects.regions`) come with the
mode of their census disparities, computed on a grid reduced by the census factor, whose
1 px bins and fattened edges often leave D̄m off by more than a pixel. Here each object
is matched as one large census window: the 5 x 5 census descriptor (Zabih and Woodfill
1994) of every pixel of both images at full resolution, and for each integer disparity
``d`` within ``radius`` px of the rounded mode, the mean Hamming distance between the
object's reference descriptors and the target's at ``x - d``. The minimum, refined by a
parabola through its two neighbours, is the object's D̄m. :func:`matches_back` is the
object-level left-right check of that disparity. Census sees only the order of grey
levels around each pixel, so tone curves, gains and sensor offsets between the dates do
not move the minimum; the whole roof votes, so the texture-less interior does not either.

References
----------
Zabih, R., Woodfill, J. (1994). Non-parametric local transforms for computing visual
correspondence. ECCV 1994, LNCS 801, 151-158.
"""

from __future__ import annotations

import numpy as np

from radcons.errors import InputError
from radcons.numerics.subpixel import parabola_peak

__all__ = ["census_descriptors", "object_census_costs", "object_census_disparity", "matches_back", "spread_pixels"]

#: Fewest object pixels seen in the target at a candidate disparity for its cost to count.
_MIN_PIXELS = 10
#: Object pixels times disparities compared at once (bounds the memory of one step).
_CHUNK_ELEMENTS = 1 << 22


def census_descriptors(image: np.ndarray, window: int = 5) -> np.ndarray:
    """Census descriptor of every pixel: one bit per neighbour of the window darker than it.

    Parameters
    ----------
    image : ndarray
        2-D image, NaN where invalid (taken as the image's median, edges replicated).
    window : int
        Odd side of the window, 3..7 (at most 48 bits).

    Returns
    -------
    ndarray of uint32 (uint64 for the 7 x 7 window's 48 bits)
        Bit ``k`` set when the ``k``-th neighbour (row-major, centre skipped) is darker.
    """
    if image.ndim != 2:
        raise InputError(f"census descriptors need a 2-D image, got shape {image.shape}")
    if window not in (3, 5, 7):
        raise InputError(f"census descriptor window must be 3, 5 or 7, got {window}")
    valid = np.isfinite(image)
    fill = float(np.median(image[valid])) if valid.any() else 0.0
    centre = np.where(valid, image, fill).astype(np.float32)
    half = window // 2
    padded = np.pad(centre, half, mode="edge")
    rows, cols = centre.shape
    dtype = np.uint32 if window * window - 1 <= 32 else np.uint64
    out = np.zeros(centre.shape, dtype)
    bit = 0
    for dy in range(-half, half + 1):
        for dx in range(-half, half + 1):
            if dy == 0 and dx == 0:
                continue
            darker = padded[half + dy : half + dy + rows, half + dx : half + dx + cols] < centre
            out |= darker.astype(dtype) << dtype(bit)
            bit += 1
    return out


def object_census_costs(
    reference_census: np.ndarray,
    target_census: np.ndarray,
    rows: np.ndarray,
    cols: np.ndarray,
    disparities: np.ndarray,
    window: int = 5,
) -> np.ndarray:
    """Mean census cost of an object's pixels at each integer disparity, as a share of the bits.

    Parameters
    ----------
    reference_census, target_census : ndarray of unsigned int
        :func:`census_descriptors` of both images (one window).
    rows, cols : ndarray of int
        The object's reference pixels.
    disparities : ndarray of int
        Candidate disparities (``reference(x, y) <-> target(x - d, y)``).
    window : int
        The descriptors' window (``window**2 - 1`` bits).

    Returns
    -------
    ndarray of float
        Mean Hamming distance over the bits of a descriptor (0: every comparison agrees,
        about 0.5: unrelated pixels), one per disparity; inf where fewer than 10 of the
        object's pixels land in the target.
    """
    width = target_census.shape[1]
    bits = window * window - 1
    disparities = np.asarray(disparities, np.int64)
    costs = np.full(disparities.size, np.inf)
    reference = reference_census[rows, cols]
    flat = target_census.ravel()
    at = rows.astype(np.int64) * width + cols  # the pixels' flat index, disparity 0
    step = max(1, _CHUNK_ELEMENTS // max(rows.size, 1))
    for start in range(0, disparities.size, step):
        shift = disparities[start : start + step, None]
        moved = cols[None, :] - shift
        inside = (moved >= 0) & (moved < width)
        found = flat[np.where(inside, at[None, :] - shift, 0)]
        distance = (np.bitwise_count(reference ^ found) * inside).sum(axis=1, dtype=np.int64)
        count = inside.sum(axis=1)
        enough = count >= _MIN_PIXELS
        costs[start : start + step][enough] = distance[enough] / (count[enough] * bits)
    return costs


def object_census_disparity(
    reference_census: np.ndarray, target_census: np.ndarray, rows: np.ndarray, cols: np.ndarray, start: float, radius: int
) -> float:
    """D̄m of one object: the disparity of least mean census cost of its pixels.

    Parameters
    ----------
    reference_census, target_census : ndarray of unsigned int
        :func:`census_descriptors` of both images.
    rows, cols : ndarray of int
        The object's reference pixels.
    start : float
        The disparity the search is centred on (the census mode).
    radius : int
        Integer disparities within this many px of ``round(start)`` are tried.

    Returns
    -------
    float
        The refined D̄m; ``start`` when the least cost lies on the search's edge (the
        object matches elsewhere, or nowhere) or too few pixels could be compared.
    """
    centre = int(round(start))
    candidates = np.arange(centre - radius, centre + radius + 1)
    costs = object_census_costs(reference_census, target_census, rows, cols, candidates)
    best = int(np.argmin(costs))
    if not (0 < best < candidates.size - 1 and np.isfinite(costs[best - 1 : best + 2]).all()):
        return float(start)
    return float(candidates[best] + parabola_peak(-costs[best - 1], -costs[best], -costs[best + 1]))


def spread_pixels(rows: np.ndarray, cols: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """At most ``count`` of an object's pixels, evenly spread over its list (all when fewer)."""
    if rows.size <= count:
        return rows, cols
    pick = np.linspace(0, rows.size - 1, count).round().astype(np.int64)
    return rows[pick], cols[pick]


def matches_back(
    reference_census: np.ndarray,
    target_census: np.ndarray,
    rows: np.ndarray,
    cols: np.ndarray,
    shift: float,
    disparities: np.ndarray,
    tolerance: int = 2,
) -> bool:
    """Object-level left-right check: does the object's copy in the target match back at D̄m?

    The target pixels the object lands on at ``round(shift)`` are matched into the
    reference as one census window over ``disparities`` (widened to take in
    ``round(shift)`` +/- ``tolerance`` + 1), the roles of :func:`object_census_costs`
    swapped; the check holds when their least cost lies within ``tolerance`` px of
    ``round(shift)``. A roof's copy finds the roof again. A region raised by a mismatch
    does not: ground beside a building that the target hides, whose forward match lands
    on the building, or a roof that changed between the dates; their target pixels match
    best where they really came from.

    Parameters
    ----------
    reference_census, target_census : ndarray of unsigned int
        :func:`census_descriptors` of both images.
    rows, cols : ndarray of int
        The object's reference pixels.
    shift : float
        Its D̄m (px).
    disparities : ndarray of int
        The disparities searched (``reference(x, y) <-> target(x - d, y)``).
    tolerance : int
        Largest distance of the least cost from ``round(shift)``, px.

    Returns
    -------
    bool
        False also when fewer than 10 of the copy's pixels lie in the target.
    """
    centre = int(round(shift))
    wanted = np.arange(
        min(int(np.min(disparities)), centre - tolerance - 1), max(int(np.max(disparities)), centre + tolerance + 1) + 1
    )
    moved = cols - centre
    inside = (moved >= 0) & (moved < target_census.shape[1])
    costs = object_census_costs(target_census, reference_census, rows[inside], moved[inside], -wanted)
    if not np.isfinite(costs).any():
        return False
    return abs(int(wanted[int(np.argmin(costs))]) - centre) <= tolerance
