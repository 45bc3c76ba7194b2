"""Which way up an affine-rectified pair is: the sign of its disparity, read from its relief.

Affine cameras fix the epipolar direction but not which of the two views is the left one,
so the affine route (:func:`radcons.stages.rectify.rectify_affine`) may turn a pair so that
higher points get smaller disparities. Nothing downstream of the radiometry minds, but the
height method of the objects stage (:mod:`radcons.stages.objects_height`) then sees
buildings as pits. On the four real Pleiades pairs at hand (Gizeh, Kahramanmaras pre/pre,
post/post and pre/post), the rotation rule turned every one that way (checked against
their RPC models).

Buildings and trees stand on the ground, and the ground is most of a scene: around its
local median, the disparity of a pair whose disparity grows with height has a long upper
tail (the roofs) and a short lower one. Turned the other way, the tails swap. Here the
pair's census disparity (:func:`radcons.stages.height.coarse_disparity` over the matches'
range, left-right checked, occlusions left out) is computed on a grid whose larger side is
at most :data:`GRID_SIDE` cells (coarser where the cost volume would be too large), the median of its valid disparities in windows of a
:data:`WINDOW_SHARE`-th of that side is taken off, and the quantile skewness of what
remains (Kelly's, from the 5th, 50th and 95th percentiles) is the pair's *relief skew*:
positive when the disparity grows with height.

Natural terrain leans either way (ravines narrower than ridges, or the reverse), and a
pair seven years apart matches too little of its roofs to lean clearly, so a pair is
turned only when the skew is below ``-ORIENTATION_SKEW``; between, it keeps the rotation
rule. Every pair at hand taken through the affine route
(``benchmarks/bench_orientation.py``; right way up by the RPC models, or, for a pair given
rectified, by the orientation it was given in), with its skew as the rotation rule left it:

| pair | relief skew | rotation rule right way up | relief rule |
| --- | --- | --- | --- |
| Pleiades Gizeh | -0.45 | no | yes |
| Pleiades Kahramanmaras pre1/pre2 | -0.48 | no | yes |
| Pleiades Kahramanmaras post1/post2 | -0.58 | no | yes |
| Pleiades Kahramanmaras pre1/post1 (2016 / 2023) | +0.05 | no | no |
| Pleiades Mont Ventoux (wooded slopes; a physical model, no RPC) | +0.04 | unknown | kept |
| Pleiades La Reunion (volcanic slopes, given rectified) | -0.14 | yes | yes |
| WorldView-3 JAX_072 (given rectified) | +0.35 | yes | yes |
| WorldView-3 JAX_122 (given rectified) | +0.17 | yes | yes |

The threshold 0.25 was set on these pairs and on two demo pairs at 1024 px (``mixed``
seed 0, +0.12; ``multi-temporal`` seed 5, +0.55): a margin of 0.11 from La Reunion's
slopes, 0.20 from Gizeh. On 15 demo pairs it never saw (512 px, seeds 1-4 and 6, three
scenarios), each also given with both images turned by 180 deg (which the rotation rule
gives back upside down), the relief rule put 29 of the 30 right way up (the rotation
rule 15): skews +0.33 to +0.76 upright, -0.33 to -0.79 turned, and one turned pair at
-0.08 kept upside down. No pair was turned the wrong way.
"""

from __future__ import annotations

import math

import numpy as np

from radcons.census import CensusParams
from radcons.stages.height import coarse_disparity, window_surface

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
        :func:`radcons.stages.height.coarse_disparity` by a quarter of its span and 2 px.

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
