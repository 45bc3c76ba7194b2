"""Sub-pixel position of a peak sampled on integer steps."""

from __future__ import annotations

import numpy as np

__all__ = ["parabola_peak"]


def parabola_peak(left: float, centre: float, right: float) -> float:
    """Sub-pixel offset in [-0.5, 0.5] of the vertex of the parabola through three samples.

    The samples are at -1, 0 and +1 around a maximum at 0; for a minimum, pass the three
    values negated.

    Parameters
    ----------
    left, centre, right : float
        The samples.

    Returns
    -------
    float
        The vertex's offset from 0, clipped to [-0.5, 0.5]; 0 when the parabola opens
        upwards or is flat there, or a sample is not finite.
    """
    curvature = left - 2.0 * centre + right
    if not (np.isfinite(curvature) and curvature < 0):
        return 0.0
    return float(np.clip(0.5 * (left - right) / curvature, -0.5, 0.5))
