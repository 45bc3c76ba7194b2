"""Noise level of an image, the noise ratio of a pair, and the notice of a ratio left high.

The estimator is Donoho and Johnstone's robust median estimator on the finest diagonal
wavelet coefficients, ``sigma = median(|HH|) / 0.6745``, the one behind
``skimage.restoration.estimate_sigma``. It is computed here on the Haar (db1) diagonal
coefficients of the 2x2 blocks whose four pixels are valid, so that NaN (nodata) pixels
are simply left out; scikit-image's version needs PyWavelets and a NaN-free image.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from radcons.errors import InputError

__all__ = ["noise_sigma", "noise_ratio", "noise_notice", "NOTICE_RATIO"]

#: Median of |N(0, 1)|: turns the median absolute coefficient into a standard deviation.
_MAD_TO_SIGMA = 0.6744897501960817


def noise_sigma(image: np.ndarray) -> float:
    """Robust estimate of the standard deviation of additive white noise.

    Parameters
    ----------
    image : ndarray
        2-D image, NaN where invalid.

    Returns
    -------
    float
        Estimated noise sigma, in the image's units.

    Raises
    ------
    InputError
        Not 2-D, or no 2x2 block of valid pixels.

    References
    ----------
    Donoho, D. L., Johnstone, I. M. (1994). Ideal spatial adaptation by wavelet shrinkage.
    Biometrika 81(3), 425-455.
    """
    image = np.asarray(image, dtype=np.float64)
    if image.ndim != 2:
        raise InputError(f"noise estimation needs a 2-D image, got shape {image.shape}")
    rows, cols = (image.shape[0] // 2) * 2, (image.shape[1] // 2) * 2
    a = image[0:rows:2, 0:cols:2]
    b = image[0:rows:2, 1:cols:2]
    c = image[1:rows:2, 0:cols:2]
    d = image[1:rows:2, 1:cols:2]
    diagonal = (a - b - c + d) / 2.0  # orthonormal Haar HH coefficient
    diagonal = diagonal[np.isfinite(diagonal)]
    if diagonal.size == 0:
        raise InputError("no 2x2 block of valid pixels to estimate the noise from")
    return float(np.median(np.abs(diagonal)) / _MAD_TO_SIGMA)


def noise_ratio(reference: np.ndarray, target: np.ndarray) -> float:
    """Ratio of the larger to the smaller noise sigma of the two images (>= 1).

    A pair with the same smoothness level gives 1 (the aim of the paper's section 5).
    Returns ``inf`` when exactly one image is noise-free and 1 when both are.
    """
    sigmas = sorted((noise_sigma(reference), noise_sigma(target)))
    if sigmas[1] == 0.0:
        return 1.0
    if sigmas[0] == 0.0:
        return float("inf")
    return sigmas[1] / sigmas[0]


#: Noise ratio above which a run's result says so, and names the option that evens it out
#: (``summary.json``, ``radcons evaluate``, the inspector's Data tab).
NOTICE_RATIO = 1.5


def noise_notice(
    ratio: float, params: Any, sharpness: Mapping[str, Any] | None = None, stages: Sequence[str] | None = None
) -> str | None:
    """One sentence on a noise ratio a run left above :data:`NOTICE_RATIO`, naming the option that closes it.

    The first that applies: the sharpness stage's noise matching smoothed the noisier
    image by its widest Gaussian (``[sharpness] noise_max_sigma``: a larger one lets it go
    on); the paper's smoothness stage did not run (``[smoothness] enabled = true``); the
    noise matching did not run (``[sharpness] noise = "cleaner"``); else both ran and left
    the ratio where it is.

    Parameters
    ----------
    ratio : float
        The noise ratio of the run's final images (:func:`noise_ratio`).
    params : radcons.params.Params
        The run's parameters.
    sharpness : mapping, optional
        The sharpness stage's ``info`` in the run (``denoise_sigma``); None when it did not run.
    stages : sequence of str, optional
        The image stages the run went through (a run stopped early has not run the last
        ones); None: every stage switched on.

    Returns
    -------
    str or None
        None when the ratio is at most :data:`NOTICE_RATIO` (or not a number).
    """
    if not ratio > NOTICE_RATIO:
        return None
    head = f"The noise ratio is {ratio:.2f} after the run, above {NOTICE_RATIO:g}: "

    def ran(stage: str) -> bool:
        return params.enabled(stage) and (stages is None or stage in stages)

    sharp = params.sharpness
    matching = ran("sharpness") and sharp.noise == "cleaner"
    if matching and sharp.denoise is None and (sharpness or {}).get("denoise_sigma", 0.0) >= sharp.noise_max_sigma:
        return head + (
            f"the sharpness stage's noise matching stopped at its widest smoothing ([sharpness] noise_max_sigma = "
            f"{sharp.noise_max_sigma:g} px); a larger noise_max_sigma (up to max_sigma, {sharp.max_sigma:g} px) "
            "lets it bring the noisier image to the cleaner one's level."
        )
    if not ran("smoothness"):
        switch = "the run stopped before it" if params.enabled("smoothness") else "[smoothness] enabled = true"
        return head + f"the paper's smoothness stage ({switch}) evens out the two images' noise levels."
    if not matching:
        switch = "" if params.enabled("sharpness") else "enabled = true, "
        return head + (
            f"the sharpness stage's noise matching ([sharpness] {switch}noise = \"cleaner\") smooths the noisier "
            "image to the cleaner one's level."
        )
    return head + "the smoothness stage and the sharpness stage's noise matching both ran and left it there."
