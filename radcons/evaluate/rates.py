"""Correct-matching rate of a dense disparity map against ground truth (section 6.4).

A pixel is matched correctly when ``|d - d_gt| < threshold`` (1 px in the paper); a pixel
with known ground truth whose match failed (NaN) counts as wrong, as the paper labels
"failed matching pixels and no matching pixels" blue together with the wrong ones.
"""

from __future__ import annotations

import numpy as np

from radcons.errors import InputError, ParamsError

__all__ = ["correct_matching_rate", "elevated_mask", "object_matching_rates"]


def correct_matching_rate(
    disparity: np.ndarray,
    ground_truth: np.ndarray,
    mask: np.ndarray | None = None,
    threshold: float = 1.0,
) -> float:
    """Share of the pixels with known ground truth that are matched within ``threshold``.

    Parameters
    ----------
    disparity : ndarray
        Dense disparity, NaN where matching failed.
    ground_truth : ndarray
        Ground-truth disparity in the same frame and convention, NaN where unknown.
    mask : ndarray of bool, optional
        Restrict the count to these pixels (an object, say).
    threshold : float
        Largest error, exclusive, of a correct match in pixels (paper: 1).

    Returns
    -------
    float
        ``#{known, |d - d_gt| < threshold} / #{known}``; NaN when no pixel (inside
        ``mask``) has known ground truth.

    Raises
    ------
    InputError
        Shapes differ.
    ParamsError
        ``threshold`` not positive.
    """
    if disparity.shape != ground_truth.shape or (mask is not None and mask.shape != disparity.shape):
        raise InputError(
            f"disparity {disparity.shape}, ground truth {ground_truth.shape}"
            + (f" and mask {mask.shape}" if mask is not None else "")
            + " differ in shape"
        )
    if not threshold > 0:
        raise ParamsError(f"threshold must be positive, got {threshold}")
    known = np.isfinite(ground_truth)
    if mask is not None:
        known &= mask.astype(bool)
    total = int(np.count_nonzero(known))
    if total == 0:
        return float("nan")
    error = np.abs(disparity[known].astype(np.float64) - ground_truth[known])
    correct = int(np.count_nonzero(error < threshold))  # NaN compares False: counted wrong
    return correct / total


def elevated_mask(ground_truth: np.ndarray, margin: float = 3.0) -> np.ndarray:
    """Pixels whose ground-truth disparity lies more than ``margin`` px from zero.

    On a tile that is mostly flat ground at zero disparity a constant zero disparity, no
    matching at all, is correct at ``margin`` px on most pixels, so the rate over all
    pixels hardly tells methods apart; the rate over these pixels
    (``correct_matching_rate(d, d_gt, elevated_mask(d_gt, margin), threshold)``) is
    decided by the elevated and sloped areas alone, where zero disparity is always wrong
    for ``threshold <= margin``.

    Parameters
    ----------
    ground_truth : ndarray
        Ground-truth disparity, NaN where unknown (never in the mask).
    margin : float
        Smallest distance from zero, exclusive, in pixels.

    Returns
    -------
    ndarray of bool
        ``|d_gt| > margin``, same shape as ``ground_truth``.

    Raises
    ------
    ParamsError
        ``margin`` negative or not finite.
    """
    if not 0 <= margin < float("inf"):
        raise ParamsError(f"margin must be finite and not negative, got {margin}")
    return np.abs(ground_truth) > margin  # NaN compares False: unknown pixels are left out


def object_matching_rates(
    disparity: np.ndarray,
    ground_truth: np.ndarray,
    labels: np.ndarray,
    threshold: float = 1.0,
) -> dict[int, float]:
    """Correct-matching rate inside each object of a label raster (paper, Table 2).

    Parameters
    ----------
    disparity, ground_truth : ndarray
        As in :func:`correct_matching_rate`.
    labels : ndarray of int
        Object labels in the reference frame (0 = background, not reported).
    threshold : float
        As in :func:`correct_matching_rate`.

    Returns
    -------
    dict
        ``object id -> rate`` for every id > 0 in ``labels`` (NaN where the object has no
        known ground truth).
    """
    if labels.shape != disparity.shape:
        raise InputError(f"labels {labels.shape} and disparity {disparity.shape} differ in shape")
    return {
        int(object_id): correct_matching_rate(disparity, ground_truth, labels == object_id, threshold)
        for object_id in np.unique(labels)
        if object_id > 0
    }
