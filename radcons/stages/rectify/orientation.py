"""Which way up an affine-rectified pair is: the sign of its disparity, read from its relief.

Affine cameras fix the epipolar direction but not which of the two views is the left one,
so the affine route (:func:`radcons.stages.rectify.run.rectify_affine`) may turn a pair so
that higher points get smaller disparities. Nothing downstream of the radiometry minds, but the
height method of the objects stage (:mod:`radcons.stages.objects.regions`) then sees
buildings as pits.

Buildings and trees stand on the ground, and the ground is most of a scene: around its
local median, the disparity of a pair whose disparity grows with height has a long upper
tail (the roofs) and a short lower one. Turned the other way, the tails swap. Here the
pair's census disparity (:func:`radcons.numerics.coarse_disparity.coarse_disparity` over
the matches' range, left-right checked, occlusions left out) is computed on a grid whose
larger side is at most :data:`GRID_SIDE` cells (coarser where the cost volume would be
too large), the median of its valid disparities in windows of a :data:`WINDOW_SHARE`-th
of that side is taken off, and the quantile skewness of what remains (Kelly's, from the
5th, 50th and 95th percentiles) is the pair's *relief skew*: positive when the disparity
grows with height.

Natural terrain leans either way (ravines narrower than ridges, or the reverse), and a
pair years apart matches too little of its roofs to lean clearly: both stay near zero, so
a pair is turned only when the skew is below ``-ORIENTATION_SKEW``; between, it keeps the
rotation rule. ``benchmarks/bench_orientation.py`` measures the skew of every pair at
hand taken through the affine route, against the orientation of its RPC models or the
one it was given in.
"""

from __future__ import annotations

import math

import numpy as np

from radcons.numerics.census import CensusParams
from radcons.numerics.coarse_disparity import coarse_disparity, window_surface

__all__ = ["relief_skew", "ORIENTATION_SKEW", "GRID_SIDE", "WINDOW_SHARE"]

#: A pair whose relief skew is below minus this is turned by 180 deg.
ORIENTATION_SKEW = 0.25
#: Largest side of the census grid, cells.
GRID_SIDE = 512
#: The local median is taken in windows of this fraction of the grid's larger side.
WINDOW_SHARE = 4
#: Fewest valid cells for a skew.
_MIN_CELLS = 100


def relief_skew(reference: np.ndarray, target: np.ndarray, disparity_range: tuple[float, float]) -> float:
    """Quantile skewness of an epipolar pair's census disparity around its local median.

    Parameters
    ----------
    reference, target : ndarray
        The rectified pair (same shape, NaN where invalid).
    disparity_range : tuple of float
        The disparities of the pair's matches (full-image px), widened by
        :func:`radcons.numerics.coarse_disparity.coarse_disparity` by a quarter of its span and 2 px.

    Returns
    -------
    float
        ``(q95 + q5 - 2 q50) / (q95 - q5)`` of the disparity less its local median, in
        -1..1: positive when the disparity grows with height (module notes); NaN when
        fewer than 100 cells are valid or the disparity is flat.
    """
    factor = max(1, math.ceil(max(reference.shape) / GRID_SIDE))
    census = CensusParams(cross_check="accurate")
    disparity = coarse_disparity(reference, target, factor, 0.0, census, disparity_range)[0]
    valid = np.isfinite(disparity)
    if valid.sum() < _MIN_CELLS:
        return float("nan")
    window = max(5, max(disparity.shape) // WINDOW_SHARE)
    residual = (disparity - window_surface(disparity, window, 50.0))[valid]
    q5, q50, q95 = np.percentile(residual, (5.0, 50.0, 95.0))
    spread = q95 - q5
    return float((q95 + q5 - 2.0 * q50) / spread) if spread > 0 else float("nan")
