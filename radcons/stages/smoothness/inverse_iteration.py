"""Eigenvectors of the group sparse model's Gram matrices by inverse iteration (section 5).

The third step of :mod:`radcons.stages.smoothness.group_sparse_linalg`'s recipe (after
LAPACK ``syevx``): once the largest eigenvalues of a group's Gram matrix are known, only
the eigenvectors of the singular values that survive soft thresholding (eq 16) are
needed. Each is found by inverse iteration on the tridiagonal ``T`` (LAPACK ``stein``):
solves with a pivoted LU of ``T - value I`` (LAPACK ``lagtf``) from a fixed start
vector, reorthogonalised against the vectors of the same eigenvalue cluster, and carried
back to the Gram matrix's coordinates by the Householder reflectors stored by
:func:`~radcons.stages.smoothness.group_sparse_linalg.tridiagonalize`. Compiled with
numba, float64, in the caller's :data:`~radcons.stages.smoothness.group_sparse_linalg.EigenWorkspace`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, uint64

from radcons.stages.smoothness.group_sparse_linalg import gershgorin_bounds

__all__ = ["eigenvectors"]

#: Unsigned constants for index arithmetic (``k + 1`` with a literal 1 would be signed).
_0 = np.uint64(0)
_1 = np.uint64(1)
_2 = np.uint64(2)

#: Reassociation and contraction let numba vectorise the loops; inf and NaN keep their meaning.
_FAST = {"reassoc", "contract", "nsz", "arcp"}

#: Relative gap under which two eigenvalues count as one cluster (LAPACK ``stein``: 1e-3).
_CLUSTER_GAP = 1e-3
#: Start vectors of inverse iteration: fixed values with no structure (a prime count).
_START = np.random.default_rng(2018).uniform(0.5, 1.5, 509)
#: Inverse iteration solves per eigenvector: the shift is exact to 1e-13, so two suffice.
_INVERSE_SOLVES = 2


@njit(cache=True, nogil=True)
def _factor_shifted(ws, n, shift, tiny):
    """Pivoted LU of ``T - shift I`` (LAPACK ``lagtf``); ``ws.c`` holds reciprocal pivots."""
    n = uint64(n)
    diag, off = ws.diag, ws.off
    c, s, t, mult, swapped = ws.c, ws.s, ws.t, ws.mult, ws.swapped
    for i in range(n):
        c[i] = diag[i] - shift
        s[i] = off[i] if i + _1 < n else 0.0
        t[i] = 0.0
    for i in range(n - _1):
        b = off[i]  # element (i + 1, i)
        if abs(c[i]) >= abs(b):
            swapped[i] = False
            piv = c[i] if abs(c[i]) >= tiny else (tiny if c[i] >= 0.0 else -tiny)
            c[i] = piv
            mu = b / piv
            mult[i] = mu
            c[i + _1] -= mu * s[i]
        else:
            swapped[i] = True
            mu = c[i] / b
            mult[i] = mu
            si = s[i]
            c[i] = b
            s[i] = c[i + _1]
            t[i] = s[i + _1]
            c[i + _1] = si - mu * s[i]
            s[i + _1] = -mu * t[i]
    for i in range(n):
        piv = c[i] if abs(c[i]) >= tiny else (tiny if c[i] >= 0.0 else -tiny)
        c[i] = 1.0 / piv


@njit(cache=True, nogil=True, fastmath={"contract", "nsz"})
def _solve_shifted(ws, n, x):
    """Solve with the factors of :func:`_factor_shifted`, ``x`` in place."""
    n = uint64(n)
    c, s, t, mult, swapped = ws.c, ws.s, ws.t, ws.mult, ws.swapped
    for i in range(n - _1):
        if swapped[i]:
            xi = x[i]
            x[i] = x[i + _1]
            x[i + _1] = xi - mult[i] * x[i]
        else:
            x[i + _1] -= mult[i] * x[i]
    x[n - _1] *= c[n - _1]
    x[n - _2] = (x[n - _2] - s[n - _2] * x[n - _1]) * c[n - _2]
    for back in range(_2, n):
        i = n - _1 - back
        x[i] = (x[i] - s[i] * x[i + _1] - t[i] * x[i + _2]) * c[i]


@njit(cache=True, nogil=True, fastmath=_FAST)
def _normalise(x, n):
    n = uint64(n)
    norm = 0.0
    for i in range(n):
        norm += x[i] * x[i]
    if norm == 0.0:
        x[0] = 1.0
        return
    inv = 1.0 / math.sqrt(norm)
    for i in range(n):
        x[i] *= inv


@njit(cache=True, nogil=True, fastmath=_FAST)
def eigenvectors(ws, n, k):
    """Eigenvectors of ``A`` for ``ws.values[:k]`` (from :func:`largest_eigenvalues`).

    Inverse iteration on ``T`` (LAPACK ``stein``): solves with ``T - value I`` from a
    fixed start vector, each followed by Gram-Schmidt against the vectors already found
    whose eigenvalue lies within the cluster gap (equal eigenvalues get shifts pulled
    apart by a few ulps), so that repeated eigenvalues get an orthonormal basis of their
    eigenspace; then ``Q`` is applied. Returns a view ``(k, n)`` of orthonormal rows.
    """
    _, _, scale, pivmin = gershgorin_bounds(ws, n)
    gap = _CLUSTER_GAP * scale
    tiny = 2.2e-16 * scale + pivmin
    values = ws.values
    vectors = ws.vectors
    n = uint64(n)
    k = uint64(k)
    shift = np.inf
    for j in range(k):
        first = j
        while first > _0 and values[first - _1] - values[first] <= gap:
            first -= _1
        # equal eigenvalues get shifts a little apart, or their solves would coincide
        shift = min(values[j], shift - 10.0 * 2.2e-16 * (abs(shift) + scale))
        _factor_shifted(ws, n, shift, tiny)
        x = vectors[j]
        offset = uint64(37) * j
        for i in range(n):
            x[i] = _START[(i + offset) % _START.size]
        for _ in range(_INVERSE_SOLVES):
            _solve_shifted(ws, n, x)
            _normalise(x, n)
            if first < j:
                for q in range(first, j):
                    other = vectors[q]
                    dot = 0.0
                    for i in range(n):
                        dot += x[i] * other[i]
                    for i in range(n):
                        x[i] -= dot * other[i]
                _normalise(x, n)
    # back to A's coordinates: y <- H_0 (H_1 (... H_{n-3} y))
    reflectors, betas = ws.reflectors, ws.betas
    for j in range(k):
        y = vectors[j]
        for back in range(_2, n):
            h = n - _1 - back
            beta = betas[h]
            if beta == 0.0:
                continue
            v = reflectors[h]
            dot = 0.0
            for i in range(h + _1, n):
                dot += v[i] * y[i]
            dot *= beta
            for i in range(h + _1, n):
                y[i] -= dot * v[i]
    return vectors[:k, :n]
