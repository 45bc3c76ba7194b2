"""Normalisation by grey-level statistics: histogram matching and mean-std matching.

The two tools every user knows (the paper's section 4.2 mentions histogram matching as the
early approach). Both map the target's grey levels so that its statistics over all valid
pixels equal the reference's, ignoring where the pixels are.
"""

from __future__ import annotations

import numpy as np
from skimage.exposure import match_histograms

from radcons.baselines.linear import LinearFit, apply_linear, check_pair
from radcons.errors import InputError

__all__ = ["histogram_matching", "mean_std_matching"]


def histogram_matching(reference: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Match the target's histogram to the reference's (``skimage.exposure.match_histograms``).

    Parameters
    ----------
    reference, target : ndarray
        2-D float32 images of one shape, NaN where invalid (NaN pixels take no part).

    Returns
    -------
    ndarray of float32
        The target with the reference's grey-level distribution, NaN kept.
    """
    check_pair(reference, target)
    valid_tgt = np.isfinite(target)
    out = np.full(target.shape, np.nan, np.float32)
    matched = match_histograms(
        target[valid_tgt].astype(np.float64), reference[np.isfinite(reference)].astype(np.float64)
    )
    out[valid_tgt] = matched
    return out


def mean_std_matching(reference: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Linear map giving the target the reference's mean and standard deviation.

    ``out = (target - mean_t) * std_r / std_t + mean_r`` over the valid pixels of each image.

    Returns
    -------
    ndarray of float32
        NaN kept.

    Raises
    ------
    InputError
        The target is constant.
    """
    check_pair(reference, target)
    ref = reference[np.isfinite(reference)].astype(np.float64)
    tgt = target[np.isfinite(target)].astype(np.float64)
    std_t = tgt.std()
    if not std_t > 0:
        raise InputError("the target is constant: mean-std matching needs contrast")
    gain = ref.std() / std_t
    return apply_linear(target, LinearFit(gain, ref.mean() - gain * tgt.mean(), tgt.size))
