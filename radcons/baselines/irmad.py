"""IR-MAD relative radiometric normalisation of one band (Canty and Nielsen 2008).

IR-MAD finds the pixels that did not change between two dates with the iteratively
reweighted multivariate alteration detection transformation, then fits the normalisation
by orthogonal regression on them. For a single band the canonical variates reduce to the
two standardised images (the canonical correlation is their correlation rho), the MAD
variate is their difference, with variance ``2 (1 - rho)``, and its standardised square
follows a chi-square law with one degree of freedom on no-change pixels. Each iteration
re-estimates the means, variances and rho with the no-change probabilities of the last one
as weights, until rho settles.

References
----------
Canty, M. J., Nielsen, A. A. (2008). Automatic radiometric normalization of multitemporal
satellite imagery with the iteratively re-weighted MAD transformation. Remote Sensing of
Environment 112(3), 1025-1036.
Nielsen, A. A. (2007). The regularized iteratively reweighted MAD method for change
detection in multi- and hyperspectral data. IEEE TIP 16(2), 463-478.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import erfc

from radcons.baselines.linear import (
    LinearFit,
    aligned_views,
    apply_linear,
    orthogonal_regression,
    paired_pixels,
)
from radcons.errors import ParamsError, StageError

__all__ = ["IrmadParams", "irmad_fit", "irmad_normalisation"]


@dataclass(frozen=True)
class IrmadParams:
    """Parameters of IR-MAD (defaults as in Canty and Nielsen 2008).

    Attributes
    ----------
    max_iterations : int
        Upper bound on the reweighting iterations.
    tolerance : float
        Stop when the canonical correlation changes by less than this (0.001). With one
        band the reweighting keeps sharpening the no-change band if let run, so the
        stopping rule matters.
    no_change_probability : float
        Pixels whose no-change probability exceeds this are the invariant pixels of the
        final regression (0.95 in the paper).
    align : bool
        Pair the pixels after shifting the target by the pair's dominant disparity
        (:func:`radcons.baselines.linear.aligned_views`), the stereo adaptation.
    """

    max_iterations: int = 50
    tolerance: float = 1e-3
    no_change_probability: float = 0.95
    align: bool = True

    def __post_init__(self) -> None:
        if self.max_iterations < 1:
            raise ParamsError("max_iterations must be >= 1")
        if not 0.0 < self.no_change_probability < 1.0:
            raise ParamsError("no_change_probability must lie in (0, 1)")


def _no_change_probability(x: np.ndarray, y: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, float]:
    """Chi-square no-change probabilities of the single-band MAD variate, and rho."""
    total = weights.sum()
    mx, my = np.sum(weights * x) / total, np.sum(weights * y) / total
    dx, dy = x - mx, y - my
    sx = np.sqrt(np.sum(weights * dx * dx) / total)
    sy = np.sqrt(np.sum(weights * dy * dy) / total)
    if not (sx > 0 and sy > 0):
        raise StageError("IR-MAD: an image is constant over the weighted pixels")
    rho = float(np.sum(weights * dx * dy) / total / (sx * sy))
    mad = dx / sx - np.sign(rho) * dy / sy
    variance = max(2.0 * (1.0 - abs(rho)), np.finfo(float).tiny)
    chi_square = mad * mad / variance
    # chi-square survival function with one degree of freedom: erfc(sqrt(z / 2))
    return erfc(np.sqrt(0.5 * chi_square)), rho


def irmad_fit(reference: np.ndarray, target: np.ndarray, params: IrmadParams = IrmadParams()) -> LinearFit:
    """Fit ``reference ~ gain * target + offset`` on IR-MAD no-change pixels.

    Parameters
    ----------
    reference, target : ndarray
        2-D images of one shape, NaN where invalid; pixels at the same position (after
        the alignment of ``params.align``) are compared.
    params : IrmadParams

    Returns
    -------
    LinearFit
        Orthogonal regression on the pixels with no-change probability above
        ``params.no_change_probability``. With one band the reweighting can narrow the
        no-change band onto pixels of a single grey level (integer images, where many
        pixels share a value); the iteration then stops at the last set that still spans
        several levels, on which a line is defined.

    Raises
    ------
    StageError
        Fewer than 2 no-change pixels.
    """
    x, y, _ = paired_pixels(*aligned_views(reference, target, params.align))
    weights = np.ones_like(x)
    rho_previous = np.inf
    no_change = np.zeros(x.shape, bool)
    for _ in range(params.max_iterations):
        probability, rho = _no_change_probability(x, y, weights)
        sharpened = probability > params.no_change_probability
        if no_change.any() and not _spread(x[sharpened], y[sharpened]):
            break  # the band narrowed onto one grey level: keep the last set that spans several
        no_change, weights = sharpened, probability
        if abs(rho - rho_previous) < params.tolerance:
            break
        rho_previous = rho
    if np.count_nonzero(no_change) < 2:
        raise StageError("IR-MAD found fewer than 2 no-change pixels")
    return orthogonal_regression(x[no_change], y[no_change])


def _spread(x: np.ndarray, y: np.ndarray) -> bool:
    """Whether both images take more than one value over these pixels (a line can be fitted)."""
    return x.size > 1 and bool(np.ptp(x) > 0) and bool(np.ptp(y) > 0)


def irmad_normalisation(
    reference: np.ndarray, target: np.ndarray, params: IrmadParams = IrmadParams()
) -> np.ndarray:
    """IR-MAD relative normalisation: the target mapped by :func:`irmad_fit` (float32, NaN kept)."""
    return apply_linear(target, irmad_fit(reference, target, params))
