"""The disparity range dense matching searches on a pair: the pair's own range.

Dense matching of a pair without ground truth must search the disparities the pair
holds, not those of every SIFT match: two dates of a city give hundreds of wrong matches
hundreds of pixels away, and a matcher asked to search -113 .. 726 px finds almost
nothing. The range is the ground truth's where it exists, else the rectification's, else
the SIFT matches' once their outliers are removed, widened by a margin
(:func:`search_range`). The inspector's review, ``radcons evaluate`` and the recordings'
disparity review use it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from radcons.evaluate.matching import disparity_range_from_matches, disparity_range_from_truth, widen_range

__all__ = ["RANGE_MARGIN", "inlier_disparities", "search_range"]

#: Margin added on both sides of the pair's own disparity range: this share of its span plus these pixels.
RANGE_MARGIN = (0.1, 4.0)

#: Quantiles of the SIFT matches' disparities (outliers removed) that span the range.
_MATCH_QUANTILE = 0.01

#: Matches farther from the median disparity than this many robust standard deviations
#: (1.4826 times the median absolute deviation) are outliers.
_MATCH_SPREAD = 5.0


def search_range(run: Any, disparities: np.ndarray | None = None) -> tuple[tuple[float, float], str]:
    """The disparity range every method is matched over, and where it came from.

    The ground truth's range (2 px margin), else the pair's own range widened by
    :data:`RANGE_MARGIN`: the range the rectification found when radcons rectified the
    pair (``run.rectification.disparity_range``), else the 1st to 99th percentile of the
    association's SIFT matches once the outliers are removed (:func:`inlier_disparities`).
    Without any of these, +-width/8.

    Parameters
    ----------
    run : radcons.pipeline.Run
    disparities : ndarray, optional
        Disparities of SIFT matches to use instead of the association's (a run that
        stopped before the association).

    Returns
    -------
    (low, high) : tuple of float
        Disparities searched, px, in the work pair's frame.
    source : str
        A short sentence saying where the range came from.
    """
    pair = run.working_pair
    if pair.disparity is not None and np.isfinite(pair.disparity).any():
        return disparity_range_from_truth(pair.disparity), "the ground truth's range + 2 px"
    share, pixels = RANGE_MARGIN
    margin = f"+ {share:.0%} of its span + {pixels:g} px"
    own = getattr(run.rectification, "disparity_range", None)
    if own is not None:
        method = getattr(run.rectification, "method", "")
        low, high = own
        return widen_range(own, share, pixels), f"the {method} rectification's range {low:.1f} .. {high:.1f} px {margin}"
    if disparities is None and run.association is not None:
        disparities = run.association.matches.disparity
    values = inlier_disparities(disparities) if disparities is not None else np.zeros(0)
    if values.size:
        low, high = disparity_range_from_matches(values, margin=0.0, quantile=_MATCH_QUANTILE)
        text = f"{values.size} SIFT matches (outliers removed), 1st-99th percentile {low:.1f} .. {high:.1f} px {margin}"
        return widen_range((low, high), share, pixels), text
    half = max(16.0, pair.shape[1] / 8.0)
    return (-half, half), "no range known (no rectification, no match): +-width/8"


def inlier_disparities(disparities: np.ndarray, spread: float = _MATCH_SPREAD) -> np.ndarray:
    """The finite disparities within ``spread`` robust standard deviations of their median.

    The robust standard deviation is 1.4826 times the median absolute deviation (at least
    1 px, so that matches of a flat scene all stay): wrong matches of a pair taken at two
    dates, hundreds of pixels away, go, the relief's disparities stay.
    """
    values = np.asarray(disparities, np.float64)
    values = values[np.isfinite(values)]
    if values.size == 0:
        return values
    median = float(np.median(values))
    sigma = max(1.0, 1.4826 * float(np.median(np.abs(values - median))))
    return values[np.abs(values - median) <= spread * sigma]
