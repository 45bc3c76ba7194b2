"""Noise level of an image and the noise ratio of a pair.

The estimator is Donoho and Johnstone's robust median estimator on the finest diagonal
wavelet coefficients, ``sigma = median(|HH|) / 0.6745``, the one behind
``skimage.restoration.estimate_sigma``. It is computed here on the Haar (db1) diagonal
coefficients of the 2x2 blocks whose four pixels are valid, so that NaN (nodata) pixels
are simply left out; scikit-image's version needs PyWavelets and a NaN-free image.
"""

from __future__ import annotations

import numpy as np

from radcons.errors import InputError

__all__ = ["noise_sigma", "noise_ratio"]

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
