"""The lines of the refine stage: weighted least squares (eq 9-11) and the moments line.

See :mod:`radcons.stages.refine.run` for where they are used and why the moments line exists.
"""

from __future__ import annotations

import numpy as np

from radcons.errors import InputError

__all__ = ["fit_object", "fit_moments"]

#: Standardised differences spread less than this are "all equal" (rounding, not data).
_EQUAL_DIFFERENCES = 1e-9


def _fit_points(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Validate the point pairs of a line fit; return them as flat float64 arrays."""
    x = np.asarray(x, np.float64).ravel()
    y = np.asarray(y, np.float64).ravel()
    if x.shape != y.shape:
        raise InputError(f"x and y differ in length ({x.size} and {y.size})")
    if x.size == 0:
        raise InputError("a line cannot be fitted to no point")
    if not (np.isfinite(x).all() and np.isfinite(y).all()):
        raise InputError("x and y must be finite")
    return x, y


def fit_object(x: np.ndarray, y: np.ndarray) -> tuple[float, float, np.ndarray]:
    """Weighted least-squares line ``y = gain * x + offset`` of one object (eq 9-11).

    Parameters
    ----------
    x : ndarray, shape (N,)
        Target grey values at the invariant points.
    y : ndarray, shape (N,)
        Reference grey values at the same points.

    Returns
    -------
    gain, offset : float
        ``lambda_m`` and ``zeta_m`` of eq 8.
    weights : ndarray, shape (N,), float64
        ``tau_k`` of eq 11, in [0, 1]: 1 for the smallest standardised difference
        ``|y'_k - x'_k|``, 0 for the largest; all 1 when the differences are equal (to
        1e-9, the rounding of an exact line).

    Raises
    ------
    InputError
        Different lengths, no point, or non-finite values.
    """
    x, y = _fit_points(x, y)
    sx, sy = x.std(), y.std()
    x_std = (x - x.mean()) / sx if sx > 0 else np.zeros_like(x)
    y_std = (y - y.mean()) / sy if sy > 0 else np.zeros_like(y)
    difference = np.abs(y_std - x_std)
    spread = difference.max() - difference.min()
    if spread > _EQUAL_DIFFERENCES:
        weights = 1.0 - (difference - difference.min()) / spread
    else:
        weights = np.ones_like(x)
    total = weights.sum()
    mean_x = (weights * x).sum() / total
    mean_y = (weights * y).sum() / total
    var_x = (weights * (x - mean_x) ** 2).sum()
    if not var_x > 1e-12 * max(mean_x * mean_x, 1.0) * total:
        return 1.0, float(mean_y - mean_x), weights
    gain = (weights * (x - mean_x) * (y - mean_y)).sum() / var_x
    return float(gain), float(mean_y - gain * mean_x), weights


def fit_moments(x: np.ndarray, y: np.ndarray) -> tuple[float, float, np.ndarray]:
    """Line ``y = gain * x + offset`` matching the mean and spread of ``x`` to those of ``y``.

    ``gain = std(y) / std(x)`` and ``offset = mean(y) - gain * mean(x)``: the reduced major
    axis of the points (for positively correlated grey values). Unlike the least squares
    of eq 9 it does not depend on how well the points are paired: misregistration lowers
    their correlation, not their spreads. Noise in ``x`` lowers it only by the noise's
    share of the target's spread. A constant ``x`` gives a pure offset, ``gain = 1,
    offset = mean(y) - mean(x)``.

    Parameters
    ----------
    x : ndarray, shape (N,)
        Target grey values.
    y : ndarray, shape (N,)
        Reference grey values at the corresponding points.

    Returns
    -------
    gain, offset : float
    weights : ndarray, shape (N,), float64
        All 1 (every point counts equally).

    Raises
    ------
    InputError
        Different lengths, no point, or non-finite values.
    """
    x, y = _fit_points(x, y)
    mean_x, mean_y, std_x = x.mean(), y.mean(), x.std()
    if not std_x > 1e-6 * max(abs(mean_x), 1.0):
        return 1.0, float(mean_y - mean_x), np.ones_like(x)
    gain = y.std() / std_x
    return float(gain), float(mean_y - gain * mean_x), np.ones_like(x)
