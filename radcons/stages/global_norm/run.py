"""Initial global illumination normalisation by singular value equalisation (eq 4-6).

Su et al. (2018), section 4.2.1: with ``I = D Sigma V^T`` (eq 4), every singular value is
scaled by ``lambda = max(Sigma_IA) / max(Sigma_I)`` (eq 5), where ``I_A`` is the image of
the same size whose every pixel is ``A``, the mean grey level of the pair, and the image is
rebuilt from the scaled values (eq 6).

Two facts make this cheap and tileable:

* scaling every singular value by one scalar gives ``D (lambda Sigma) V^T = lambda I``,
  so eq 6 is a multiplication, no decomposition needed;
* ``I_A = A 1_m 1_n^T`` has rank one with ``max(Sigma_IA) = A sqrt(m n)``.

So only ``sigma_max(I)`` is needed; :func:`largest_singular_value` finds it by power
iteration on ``I^T I`` with float32 matrix-vector products (two passes over the image per
iteration, no ``n x n`` matrix), falling back to ARPACK (``scipy.sparse.linalg.svds``)
when the two largest singular values are too close for the power iteration to converge.
``A`` and ``sigma_max`` are computed once on the whole pair and passed in explicitly, so
tiles of a large scene can be normalised independently with the scene-wide values.

Invalid (NaN) pixels are treated as missing: they do not count in ``A``, they are replaced
by the image's valid mean for ``sigma_max`` (so a few holes barely change it), ``m n``
counts every pixel of the grid (the filled image is the one decomposed), and they stay NaN
in the output.

Reference: Su, Yan, Zhao, Wang (2018), Remote Sensing 10(2):336, section 4.2.1; the
singular value equalisation it improves is Demirel, Anbarjafari, Jahromi (2008), "Image
equalization based on singular value decomposition", ISCIS.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse.linalg

from radcons.errors import InputError
from radcons.stages.global_norm.params import GlobalParams

__all__ = ["GlobalParams", "pair_mean", "largest_singular_value", "global_normalisation"]


def _image(image: np.ndarray, name: str = "image") -> np.ndarray:
    image = np.asarray(image)
    if image.ndim != 2:
        raise InputError(f"{name} must be a single-band 2-D array, got shape {image.shape}")
    if image.size == 0:
        raise InputError(f"{name} is empty")
    return image.astype(np.float32, copy=False)


def pair_mean(reference: np.ndarray, target: np.ndarray) -> float:
    """Mean grey level ``A`` of the pair: the mean of the valid pixels of both images pooled.

    Parameters
    ----------
    reference, target : ndarray
        2-D images, NaN where invalid (they may differ in shape).

    Returns
    -------
    float

    Raises
    ------
    InputError
        Not 2-D, or no valid pixel in either image.
    """
    total, count = 0.0, 0
    for name, image in (("reference", reference), ("target", target)):
        image = _image(image, name)
        valid = np.isfinite(image)
        total += float(image[valid].sum(dtype=np.float64))
        count += int(valid.sum())
    if count == 0:
        raise InputError("the pair has no valid pixel")
    return total / count


def _filled(image: np.ndarray) -> np.ndarray:
    valid = np.isfinite(image)
    if valid.all():
        return image
    if not valid.any():
        raise InputError("every pixel of the image is NaN")
    return np.where(valid, image, np.float32(image[valid].mean(dtype=np.float64)))


def largest_singular_value(image: np.ndarray, params: GlobalParams = GlobalParams()) -> float:
    """Largest singular value ``sigma_max`` of an image, without a full SVD.

    Power iteration ``v <- I^T (I v) / ||.||`` started from the constant vector (close to
    the leading right singular vector of a non-negative image, so a few iterations do);
    ``sigma = sqrt(||I^T I v||)``. If it has not converged after ``params.max_iterations``
    iterations, ARPACK's Lanczos method (``scipy.sparse.linalg.svds(k=1)``) takes over.

    Parameters
    ----------
    image : ndarray, shape (M, N)
        NaN pixels are replaced by the mean of the valid ones.
    params : GlobalParams

    Returns
    -------
    float

    Raises
    ------
    InputError
        Not 2-D, empty, or no valid pixel.
    """
    matrix = _filled(_image(image))
    v = np.full(matrix.shape[1], 1.0 / np.sqrt(matrix.shape[1]), np.float32)
    sigma = 0.0
    for _ in range(params.max_iterations):
        w = matrix.T @ (matrix @ v)
        norm = float(np.linalg.norm(w.astype(np.float64)))
        if norm == 0.0:
            break
        new_sigma = float(np.sqrt(norm))
        converged = abs(new_sigma - sigma) <= params.tolerance * new_sigma
        sigma = new_sigma
        if converged:
            return sigma
        v = w / np.float32(norm)
    if not matrix.any():
        return 0.0
    values = scipy.sparse.linalg.svds(matrix, k=1, return_singular_vectors=False, random_state=0)
    return float(values[0])


def global_normalisation(
    image: np.ndarray,
    pair_mean_value: float,
    sigma_max: float | None = None,
    params: GlobalParams = GlobalParams(),
    *,
    shape: tuple[int, int] | None = None,
) -> tuple[np.ndarray, float]:
    """Scale an image's singular values toward those of the constant pair-mean image (eq 4-6).

    ``lambda = max(Sigma_IA) / max(Sigma_I) = A sqrt(m n) / sigma_max`` (eq 5) and
    ``I_hat = D (lambda Sigma) V^T = lambda I`` (eq 6).

    Parameters
    ----------
    image : ndarray
        The image, or one tile of it; NaN where invalid.
    pair_mean_value : float
        ``A``, from :func:`pair_mean`; must be positive.
    sigma_max : float, optional
        ``max(Sigma_I)``; computed with :func:`largest_singular_value` when omitted.
    params : GlobalParams
    shape : (int, int), optional
        ``(m, n)`` of the image ``sigma_max`` belongs to; defaults to ``image.shape``. Pass
        the scene's shape (with the scene's ``sigma_max``) to normalise one tile.

    Returns
    -------
    normalised : ndarray, float32
        ``lambda * image``, NaN kept.
    lam : float
        ``lambda``.

    Raises
    ------
    InputError
        ``A`` not positive and finite, or ``sigma_max`` zero (an all-zero image).
    """
    image = _image(image)
    if not (np.isfinite(pair_mean_value) and pair_mean_value > 0):
        raise InputError(f"the pair mean A must be positive and finite, got {pair_mean_value}")
    if sigma_max is None:
        if shape is not None and tuple(shape) != image.shape:
            raise InputError(f"a tile of a {tuple(shape)} scene needs the scene's sigma_max")
        sigma_max = largest_singular_value(image, params)
    if not (np.isfinite(sigma_max) and sigma_max > 0):
        raise InputError(f"largest singular value must be positive, got {sigma_max} (all-zero image?)")
    m, n = image.shape if shape is None else shape
    lam = float(pair_mean_value) * float(np.sqrt(float(m) * float(n))) / float(sigma_max)
    return image * np.float32(lam), lam
