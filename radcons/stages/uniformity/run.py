"""Illumination uniformity of a single image by relative-gradient attenuation (eq 1-3).

Su et al. (2018), section 4.1: every gradient of the image is multiplied by a factor that
depends on its *relative* gradient (the gradient divided by the local brightness), so large
relative gradients are compressed and small ones are stretched, and the image is rebuilt
from the modified gradient field. This is the gradient attenuation of Fattal, Lischinski
and Werman (2002) with ``alpha = mu * mean`` and ``beta = zeta``, applied at one scale to a
relative gradient instead of the gradient of the log luminance.

Choices where the paper is silent (all exposed in :class:`UniformityParams`):

* ``f`` of eq 2. ``"local_mean"`` (default): ``f(v) = max(v, 0) + eps`` with
  ``eps = epsilon * mean(I)``, so the relative gradient is ``|grad I| / (g * I)``, the
  contrast with respect to the local brightness (close to ``|grad log I|``, the quantity
  Fattal et al. attenuate). ``"one"``: ``f = 1``, plain gradient magnitude (Fattal's
  attenuation on the linear image).
* ``sigma``, the Gaussian width of eq 2, default 3 px: wide enough to average across a
  roof edge (the paper blurs "to inhibit edge gradient mutation"), narrow enough to follow
  the brightness of one building.
* Reconstruction: forward-difference gradient and DCT Poisson solve with Neumann borders
  (:mod:`radcons.numerics.poisson`). The solution is known up to a constant and its contrast
  changes, so it is mapped back to the input's range: ``"mean_std"`` (default) gives it the
  input's mean and standard deviation over valid pixels; ``"percentile"`` maps its 1st and
  99th percentiles onto the input's.
* Invalid (NaN) pixels are filled with the nearest valid value; the filled image goes
  through the whole computation (its gradients inside filled areas are zero except
  where two fill values meet), the mean relative gradient of eq 3 counts valid pixels
  only, and invalid pixels are NaN again on output.

With ``zeta = 1`` the factor is 1, the field is the image's own gradient, and the image
comes back unchanged (up to float32 rounding).
"""

from __future__ import annotations

import cv2
import numpy as np
import scipy.ndimage

from radcons.numerics.poisson import divergence, gradient, solve_poisson_neumann
from radcons.stages.uniformity.params import UniformityParams
from radcons.validate import single_band_image

__all__ = ["UniformityParams", "illumination_uniformity", "relative_gradient", "attenuation"]


def _fill_nearest(image: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Copy of ``image`` with each invalid pixel replaced by its nearest valid one."""
    if valid.all():
        return image
    indices = scipy.ndimage.distance_transform_edt(~valid, return_distances=False, return_indices=True)
    return image[tuple(indices)]


def relative_gradient(
    image: np.ndarray, gx: np.ndarray, gy: np.ndarray, params: UniformityParams = UniformityParams()
) -> np.ndarray:
    """Relative gradient magnitude of eq 2, ``|grad I| / f(I * g)``.

    Parameters
    ----------
    image : ndarray, shape (M, N)
        Finite float32 image (invalid pixels already filled).
    gx, gy : ndarray, shape (M, N)
        Its forward-difference gradient.
    params : UniformityParams

    Returns
    -------
    ndarray, shape (M, N), float32
    """
    magnitude = np.hypot(gx, gy)  # correctly rounded: cv2.magnitude's result depends on the buffer's alignment
    if params.f == "one":
        return magnitude
    local = cv2.GaussianBlur(image, (0, 0), params.sigma, borderType=cv2.BORDER_REFLECT)
    eps = np.float32(params.epsilon * max(float(np.abs(image).mean()), np.finfo(np.float32).tiny))
    np.maximum(local, 0.0, out=local)
    local += eps
    return magnitude / local


def attenuation(relative: np.ndarray, valid: np.ndarray, params: UniformityParams = UniformityParams()) -> np.ndarray:
    """Adjustment factor Theta of eq 3, ``(mu * mean(rel) / rel) ** (1 - zeta)``.

    Parameters
    ----------
    relative : ndarray, shape (M, N)
        Relative gradient magnitude (eq 2).
    valid : ndarray of bool, shape (M, N)
        Pixels whose gradient counts in the mean.
    params : UniformityParams

    Returns
    -------
    ndarray, shape (M, N), float32
        Theta > 1 where ``rel < mu * mean(rel)`` (stretched), < 1 above it (compressed).
        Zero-gradient pixels get a large but finite factor (their product with the
        gradient stays zero).
    """
    threshold = np.float32(params.mu * float(relative[valid].mean()))
    if threshold <= 0:
        return np.ones_like(relative)
    floor = threshold * np.float32(1e-12)
    theta = threshold / np.maximum(relative, floor)
    return np.power(theta, np.float32(1.0 - params.zeta), out=theta)


def _map_to_range(solution: np.ndarray, image: np.ndarray, valid: np.ndarray, how: str) -> np.ndarray:
    new, old = solution[valid].astype(np.float64), image[valid].astype(np.float64)
    if how == "mean_std":
        new_lo, new_spread = new.mean(), new.std()
        old_lo, old_spread = old.mean(), old.std()
    else:
        new_lo, new_hi = np.percentile(new, [1.0, 99.0])
        old_lo, old_hi = np.percentile(old, [1.0, 99.0])
        new_spread, old_spread = new_hi - new_lo, old_hi - old_lo
    scale = old_spread / new_spread if new_spread > 0 else 0.0
    return ((solution - np.float32(new_lo)) * np.float32(scale) + np.float32(old_lo)).astype(np.float32)


def illumination_uniformity(image: np.ndarray, params: UniformityParams = UniformityParams()) -> np.ndarray:
    """Make the illumination of one image more uniform (Su et al. 2018, eq 1-3).

    ``G = grad I * Theta`` (eq 1), Theta from the relative gradient (eq 2-3); the image is
    rebuilt from ``G`` by solving ``laplacian(I') = div G`` (DCT, Neumann borders) and mapped
    back to the input's grey-level range (``params.range_mapping``).

    Parameters
    ----------
    image : ndarray, shape (M, N)
        Single-band image on its original range, NaN where invalid (any real dtype;
        computed in float32).
    params : UniformityParams

    Returns
    -------
    ndarray, shape (M, N), float32
        The uniform-illumination image, NaN where the input was.

    Raises
    ------
    InputError
        Not 2-D, smaller than 2 x 2, not real numbers, or no valid pixel.

    References
    ----------
    Su, Yan, Zhao, Wang (2018), Remote Sensing 10(2):336, section 4.1.
    Fattal, Lischinski, Werman (2002), "Gradient domain high dynamic range compression".
    """
    image = single_band_image(image, "image", 2, "is too small for a gradient (2 x 2 px)")
    valid = np.isfinite(image)
    filled = _fill_nearest(image, valid)
    gx, gy = gradient(filled)
    theta = attenuation(relative_gradient(filled, gx, gy, params), valid, params)
    gx *= theta
    gy *= theta
    solution = solve_poisson_neumann(divergence(gx, gy))
    out = _map_to_range(solution, image, valid, params.range_mapping)
    out[~valid] = np.nan
    return out
