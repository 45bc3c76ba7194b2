"""Hierarchical regression normalisation after Zhong, Xu and Li (2016).

The full text of the paper was not available; this is a reconstruction from its published
description: "a weighted regression based on spectral difference is proposed to
automatically extract the pseudo-invariant features (PIFs), which can also suppress the
negative effect of the first type of changes [changed ground objects]. In addition, a
robust regression with gradient dependence is performed on the extracted PIFs to build the
final relationship between the target image and the reference image, which can be robust
for the second type of changes [misalignment]". The choices made where the description is
silent:

1. Weighted regression on the spectral difference (level 1). The target is first given the
   reference's mean and standard deviation; the difference image ``D = reference -
   mapped target`` then weighs every pixel by ``exp(-D^2 / (2 s^2))`` with ``s`` the robust
   (median absolute deviation) spread of ``D``, a weighted least-squares line is fitted,
   ``D`` is recomputed with it, and so on for ``weighted_iterations`` rounds. The PIFs are
   the pixels with ``|D| < pif_threshold * s`` at the end.
2. Robust regression with gradient dependence (level 2). On the PIFs, iteratively
   reweighted least squares with Tukey's biweight on the residuals, each weight multiplied
   by ``1 / (1 + (g / g_median)^2)``, where ``g`` is the larger of the two images' gradient
   magnitudes: misregistered pixels differ most where the image varies fast.

References
----------
Zhong, C., Xu, Q., Li, B. (2016). Relative radiometric normalization for multitemporal
remote sensing images by hierarchical regression. IEEE Geoscience and Remote Sensing
Letters 13(2), 217-221.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from radcons.baselines.linear import (
    LinearFit,
    aligned_views,
    apply_linear,
    paired_pixels,
    weighted_least_squares,
)
from radcons.errors import ParamsError, StageError

__all__ = ["ZhongParams", "zhong_fit", "zhong_normalisation"]

#: Scales a median absolute deviation to a normal standard deviation.
_MAD_SCALE = 1.4826


@dataclass(frozen=True)
class ZhongParams:
    """Parameters of the hierarchical regression reconstruction.

    Attributes
    ----------
    weighted_iterations : int
        Rounds of difference-weighted regression (level 1).
    pif_threshold : float
        PIFs are the pixels with ``|D| < pif_threshold * s`` (``s``: robust spread of D).
    robust_iterations : int
        Iterations of the reweighted robust regression (level 2).
    tukey_c : float
        Tukey biweight constant in units of the residuals' robust spread (4.685 gives 95 %
        efficiency on normal residuals).
    gradient_dependence : bool
        Weigh the level-2 regression down where the images' gradient is large.
    align : bool
        Pair the pixels after shifting the target by the pair's dominant disparity
        (:func:`radcons.baselines.linear.aligned_views`), the stereo adaptation.
    """

    weighted_iterations: int = 5
    pif_threshold: float = 1.0
    robust_iterations: int = 20
    tukey_c: float = 4.685
    gradient_dependence: bool = True
    align: bool = True

    def __post_init__(self) -> None:
        if self.weighted_iterations < 1 or self.robust_iterations < 1:
            raise ParamsError("weighted_iterations and robust_iterations must be >= 1")
        if not self.pif_threshold > 0 or not self.tukey_c > 0:
            raise ParamsError("pif_threshold and tukey_c must be positive")


def _gaussian_weight(u: np.ndarray) -> np.ndarray:
    """``exp(-u^2 / 2)``, exactly 0 beyond 10 (no subnormal numbers, which are slow)."""
    return np.where(np.abs(u) < 10.0, np.exp(-0.5 * np.minimum(u * u, 100.0)), 0.0)


def _robust_spread(values: np.ndarray) -> float:
    spread = _MAD_SCALE * float(np.median(np.abs(values - np.median(values))))
    return spread if spread > 0 else float(np.std(values)) or 1.0


def _gradient_magnitude(image: np.ndarray) -> np.ndarray:
    filled = np.where(np.isfinite(image), image, np.nanmean(image)).astype(np.float64)
    return np.hypot(ndimage.sobel(filled, axis=1), ndimage.sobel(filled, axis=0)) / 8.0


def zhong_fit(reference: np.ndarray, target: np.ndarray, params: ZhongParams = ZhongParams()) -> LinearFit:
    """Fit ``reference ~ gain * target + offset`` by hierarchical regression.

    Parameters
    ----------
    reference, target : ndarray
        2-D images of one shape, NaN where invalid; pixels at the same position (after
        the alignment of ``params.align``) are compared.
    params : ZhongParams

    Returns
    -------
    LinearFit
        The level-2 robust fit on the pseudo-invariant pixels.

    Raises
    ------
    StageError
        Fewer than 2 pseudo-invariant pixels.
    """
    reference, target = aligned_views(reference, target, params.align)
    x, y, mask = paired_pixels(reference, target)
    # level 1: weighted regression on the spectral difference
    std_x = x.std()
    if not std_x > 0:
        raise StageError("Zhong: the target is constant over the shared pixels")
    gain = y.std() / std_x
    fit = LinearFit(gain, y.mean() - gain * x.mean(), x.size)
    for _ in range(params.weighted_iterations):
        difference = y - (fit.gain * x + fit.offset)
        spread = _robust_spread(difference)
        fit = weighted_least_squares(x, y, _gaussian_weight(difference / spread))
    difference = y - (fit.gain * x + fit.offset)
    pif = np.abs(difference) < params.pif_threshold * _robust_spread(difference)
    if np.count_nonzero(pif) < 2:
        raise StageError("Zhong: fewer than 2 pseudo-invariant pixels")
    x, y = x[pif], y[pif]
    # level 2: robust regression with gradient dependence on the PIFs
    prior = np.ones_like(x)
    if params.gradient_dependence:
        gradient = np.maximum(_gradient_magnitude(reference), _gradient_magnitude(target))[mask][pif]
        scale = float(np.median(gradient)) or 1.0
        prior = 1.0 / (1.0 + (gradient / scale) ** 2)
    fit = weighted_least_squares(x, y, prior)
    for _ in range(params.robust_iterations):
        residual = y - (fit.gain * x + fit.offset)
        u = residual / (params.tukey_c * _robust_spread(residual))
        biweight = np.where(np.abs(u) < 1.0, (1.0 - u * u) ** 2, 0.0)
        updated = weighted_least_squares(x, y, prior * biweight)
        converged = np.isclose(updated.gain, fit.gain, rtol=1e-9) and np.isclose(
            updated.offset, fit.offset, rtol=1e-9
        )
        fit = updated
        if converged:
            break
    return fit


def zhong_normalisation(
    reference: np.ndarray, target: np.ndarray, params: ZhongParams = ZhongParams()
) -> np.ndarray:
    """Hierarchical-regression normalisation: the target mapped by :func:`zhong_fit`."""
    return apply_linear(target, zhong_fit(reference, target, params))
