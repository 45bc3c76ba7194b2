"""Gradient-domain reconstruction: forward-difference gradient, divergence, Poisson solve.

The three functions share one discretisation, so that
``solve_poisson_neumann(divergence(*gradient(I))) == I - I.mean()`` up to rounding:

* :func:`gradient` takes forward differences and sets the flux through the image border
  to zero (last column of ``gx``, last row of ``gy``), the Neumann boundary condition;
* :func:`divergence` takes the matching backward differences, i.e. it is minus the
  adjoint of :func:`gradient`, so ``divergence(gradient(I))`` is the 5-point Laplacian with
  reflecting borders;
* :func:`solve_poisson_neumann` inverts that Laplacian exactly with a type-II discrete
  cosine transform, which diagonalises it (Strang 1999, "The discrete cosine transform",
  SIAM Review 41(1); the solver Fattal, Lischinski and Werman 2002 use for gradient-domain
  tone mapping).

Work stays in the input's floating dtype (float32 stays float32) so large images cost half
the memory of a float64 solve.
"""

from __future__ import annotations

import numpy as np
import scipy.fft

from radcons.errors import InputError

__all__ = ["gradient", "divergence", "solve_poisson_neumann"]


def _float_array(array: np.ndarray, name: str) -> np.ndarray:
    array = np.asarray(array)
    if array.ndim != 2:
        raise InputError(f"{name} must be a 2-D array, got shape {array.shape}")
    if min(array.shape) < 1:
        raise InputError(f"{name} is empty (shape {array.shape})")
    if array.dtype not in (np.float32, np.float64):
        array = array.astype(np.float32)
    if not np.isfinite(array).all():
        raise InputError(f"{name} holds NaN or infinite values; fill them before the solve")
    return array


def gradient(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Forward-difference gradient with zero flux through the border (Neumann).

    Parameters
    ----------
    image : ndarray, shape (M, N)
        Finite values; integer input is computed in float32.

    Returns
    -------
    gx, gy : ndarray, shape (M, N)
        ``gx[i, j] = I[i, j + 1] - I[i, j]`` with ``gx[:, -1] = 0``;
        ``gy[i, j] = I[i + 1, j] - I[i, j]`` with ``gy[-1, :] = 0``.
    """
    image = _float_array(image, "image")
    gx = np.zeros_like(image)
    gy = np.zeros_like(image)
    np.subtract(image[:, 1:], image[:, :-1], out=gx[:, :-1])
    np.subtract(image[1:, :], image[:-1, :], out=gy[:-1, :])
    return gx, gy


def divergence(gx: np.ndarray, gy: np.ndarray) -> np.ndarray:
    """Backward-difference divergence matching :func:`gradient`.

    ``div[i, j] = gx[i, j] - gx[i, j - 1] + gy[i, j] - gy[i - 1, j]`` where the
    out-of-image terms ``gx[:, -1]`` (left of column 0) are zero. The last column of ``gx``
    and the last row of ``gy`` are fluxes through the border and are ignored (treated as
    zero), which is the Neumann condition; the result therefore always sums to zero, as
    the solvability of the Neumann problem requires.

    Parameters
    ----------
    gx, gy : ndarray, shape (M, N)
        Horizontal and vertical fields, e.g. an attenuated gradient.

    Returns
    -------
    ndarray, shape (M, N)
    """
    gx = _float_array(gx, "gx")
    gy = _float_array(gy, "gy")
    if gx.shape != gy.shape:
        raise InputError(f"gx {gx.shape} and gy {gy.shape} differ in shape")
    dtype = np.result_type(gx, gy)
    div = np.zeros(gx.shape, dtype)
    div[:, :-1] += gx[:, :-1]
    div[:, 1:] -= gx[:, :-1]
    div[:-1, :] += gy[:-1, :]
    div[1:, :] -= gy[:-1, :]
    return div


def solve_poisson_neumann(divergence: np.ndarray) -> np.ndarray:
    """Solve ``laplacian(u) = divergence`` with Neumann borders, zero-mean solution.

    The 5-point Laplacian with reflecting borders (the operator ``divergence(gradient(.))``
    of this module) is diagonal in the orthonormal DCT-II basis, with eigenvalues
    ``2 cos(pi k / M) - 2 + 2 cos(pi l / N) - 2``. The solve is one forward and one inverse
    2-D DCT: O(MN log MN). The constant mode (eigenvalue 0) is set to zero, which both
    picks the zero-mean solution and discards any non-zero mean of the right-hand side
    (the least-squares solution when the data is inconsistent).

    Parameters
    ----------
    divergence : ndarray, shape (M, N)
        Right-hand side, finite. float32 input is solved in float32.

    Returns
    -------
    ndarray, shape (M, N)
        Zero-mean solution, in the input's floating dtype.

    References
    ----------
    Fattal, Lischinski, Werman (2002), "Gradient domain high dynamic range compression",
    ACM TOG 21(3), section 5.
    """
    rhs = _float_array(divergence, "divergence")
    m, n = rhs.shape
    coeffs = scipy.fft.dctn(rhs, type=2, norm="ortho", workers=-1)
    ky = (2.0 * np.cos(np.pi * np.arange(m) / m) - 2.0).astype(rhs.dtype)
    kx = (2.0 * np.cos(np.pi * np.arange(n) / n) - 2.0).astype(rhs.dtype)
    denominator = ky[:, None] + kx[None, :]
    denominator[0, 0] = 1.0
    coeffs /= denominator
    coeffs[0, 0] = 0.0
    return scipy.fft.idctn(coeffs, type=2, norm="ortho", workers=-1)
