"""The census rules a candidate roof of the searches passes: it stands, it matches, uniquely.

The searches for the roofs the height map missed (:mod:`radcons.stages.objects.searches`)
and the gable completion (:mod:`radcons.stages.objects.joins.mirror`) judge a set of the
reference's pixels (an image segment, a union of segments, a mirrored roof plane) by
matching them into the target as one census window over the whole disparity range
searched (:func:`radcons.stages.objects.disparity.object_census_costs`, on at most
:data:`MAX_PIXELS` of them, evenly spread). Their least-cost disparity is taken when:

1. it stands at least ``min_object_height`` times the height threshold above the ground
   under the pixels (the height method's median-height rule);
2. the cost there is at least ``min_match_score`` lower than at the ground's disparity
   (the height method's census contrast: a roof matches best at its own disparity);
3. it is unique: every disparity more than :data:`_PEAK_HALF_WIDTH` px from it costs at
   least ``missed_margin`` more (rows of parked cars and road markings repeat along the
   rows and match at several disparities).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from radcons.stages.objects.disparity import object_census_costs, spread_pixels
from radcons.stages.objects.ground import HeightMap

__all__ = ["CensusCheck", "MAX_PIXELS"]

#: Pixels of a segment its census costs are computed on (evenly spread over it).
MAX_PIXELS = 400
#: Disparities within this many px of the least-cost one do not count against its uniqueness.
_PEAK_HALF_WIDTH = 2


@dataclass(frozen=True)
class CensusCheck:
    """Rules 1-3 of the module notes, for any set of the reference's pixels.

    Attributes
    ----------
    census : (ndarray, ndarray)
        Census descriptors of both images at full resolution.
    disparities : ndarray of int
        The disparities searched.
    ground : ndarray
        The ground disparity under every pixel.
    lowest : float
        Least disparity above the ground (px) of an object (rule 1).
    params : ObjectsParams
        ``min_match_score`` (rule 2) and ``missed_margin`` (rule 3) are used.
    """

    census: tuple[np.ndarray, np.ndarray]
    disparities: np.ndarray
    ground: np.ndarray
    lowest: float
    params: object

    @classmethod
    def of(
        cls, height: HeightMap, census: tuple[np.ndarray, np.ndarray], params: object, threshold: float,
        shape: tuple[int, int],
    ) -> "CensusCheck":
        """The check of a pair's height map, at the height method's thresholds, for images of ``shape``."""
        lowest = params.min_object_height * threshold * height.px_per_unit
        return cls(census, height.searched_disparities(), height.full(shape, "ground"), lowest, params)

    def disparity(self, rows: np.ndarray, cols: np.ndarray) -> float | None:
        """The pixels' least-cost disparity when they pass rules 1-3, else None.

        The pixels' ground is the median of the ground disparity over those compared.
        """
        rows, cols = spread_pixels(rows, cols, MAX_PIXELS)
        disparities = self.disparities
        ground = float(np.median(self.ground[rows, cols]))
        costs = object_census_costs(*self.census, rows, cols, disparities)
        if not np.isfinite(costs).any():
            return None
        best = int(np.argmin(costs))
        at_ground = int(np.clip(round(ground) - disparities[0], 0, disparities.size - 1))
        far = np.abs(np.arange(disparities.size) - best) > _PEAK_HALF_WIDTH
        margin = float(np.min(costs[far]) - costs[best]) if far.any() else np.inf
        if not (
            disparities[best] - ground >= self.lowest
            and costs[at_ground] - costs[best] >= self.params.min_match_score
            and margin >= self.params.missed_margin
        ):
            return None
        return float(disparities[best])

