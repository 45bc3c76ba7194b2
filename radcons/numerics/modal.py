"""The modal disparity D̄m of a set of disparities (the paper's per-object disparity, sec 2.2)."""

from __future__ import annotations

import numpy as np

from radcons.errors import InputError

__all__ = ["modal_disparity"]


def modal_disparity(disparities: np.ndarray) -> float:
    """Most frequent disparity D̄m: 1 px histogram mode refined by the median of its bin.

    Bins are centred on integers (``round(D)``); on a tie the smallest disparity wins.

    Parameters
    ----------
    disparities : ndarray
        At least one finite value.

    Returns
    -------
    float
    """
    disparities = np.asarray(disparities, np.float64)
    if disparities.size == 0:
        raise InputError("the modal disparity of no matches is undefined")
    bins = np.rint(disparities).astype(np.int64)
    values, counts = np.unique(bins, return_counts=True)
    mode = values[np.argmax(counts)]
    return float(np.median(disparities[bins == mode]))
