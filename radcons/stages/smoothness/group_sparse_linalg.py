"""Compiled small symmetric eigenproblems for the group sparse model (section 5, eq 15-17).

Every group of the model is a stack of ``m`` patches (``m`` = 31, or 62 for a union group)
whose low-rank estimate needs the largest eigenvalues of the group's ``m x m`` Gram matrix
(the squared singular values) and the eigenvectors of those that survive soft
thresholding, usually a handful. LAPACK's ``syevd`` on matrices this small spends most of
its time in call overhead and computes every eigenvector.
The routines below follow LAPACK's ``syevx`` recipe, inlined by numba and computing only
what the threshold needs:

1. Householder reduction to a symmetric tridiagonal matrix ``T = Q^T A Q`` (Golub and Van
   Loan, *Matrix Computations*, 4th ed., algorithm 8.3.1), reading and writing only the
   lower triangle,
2. eigenvalue counts by Sturm sequences (the signs of the ``LDL^T`` pivots of
   ``T - x I``) and the ``k`` largest eigenvalues by bisection and Newton steps, all
   ``k`` searches in lock step (after LAPACK ``stebz``), or all eigenvalues by the QL
   method when a third or more of them is wanted,
3. their eigenvectors by inverse iteration on ``T`` with a pivoted tridiagonal LU and
   reorthogonalisation within clusters (LAPACK ``stein``), carried back by the stored
   Householder reflectors (:mod:`radcons.stages.smoothness.inverse_iteration`).

Everything is float64 and works in caller-provided workspaces (:func:`eigen_workspace`),
so the per-group kernels allocate nothing. Loop indices are unsigned (``uint64``): numba
then drops its negative-index wraparound test from every array access, which otherwise
keeps LLVM from vectorising the inner loops.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit, uint64

__all__ = [
    "EigenWorkspace",
    "eigen_workspace",
    "tridiagonalize",
    "count_below",
    "negligible",
    "largest_eigenvalues",
    "gershgorin_bounds",
]

#: Unsigned constants for index arithmetic (``k + 1`` with a literal 1 would be signed).
_0 = np.uint64(0)
_1 = np.uint64(1)
_2 = np.uint64(2)

#: Reassociation and contraction let numba vectorise the loops; inf and NaN keep their meaning.
_FAST = {"reassoc", "contract", "nsz", "arcp"}

#: Scratch arrays of the routines below, for matrices up to ``n x n`` (one per thread).
EigenWorkspace = namedtuple(
    "EigenWorkspace",
    ["diag", "off", "off2", "reflectors", "betas", "work", "values", "lower", "upper",
     "point", "pivots", "counts", "vectors", "c", "s", "t", "mult", "swapped"],
)

#: Eigenvalues below this fraction of the largest carry no energy worth an eigenvector:
#: leaving them out changes a group by less than 1e-7 of its largest singular value.
_NEGLIGIBLE = 1e-14
#: Accuracy of the eigenvalues, relative to the largest one.
_EIGENVALUE_TOL = 1e-13
#: Relative width at which a bracket holding several eigenvalues is final.
_CLUSTER_TOL = 1e-10


@njit(cache=True, nogil=True)
def eigen_workspace(n):
    """Allocate an :data:`EigenWorkspace` for matrices up to ``n x n``."""
    return EigenWorkspace(
        np.zeros(n), np.zeros(n), np.zeros(n), np.zeros((n, n)), np.zeros(n), np.zeros(2 * n),
        np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n, np.int64),
        np.zeros((n, n)), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n),
        np.zeros(n, np.bool_),
    )


@njit(cache=True, nogil=True, fastmath=_FAST)
def tridiagonalize(a, n, ws):
    """Householder reduction of the leading ``n x n`` block (``n >= 2``) of symmetric ``a``.

    Only the lower triangle of ``a`` is read, and it is overwritten. On return
    ``ws.diag[:n]`` and ``ws.off[:n-1]`` hold ``T`` with ``A = Q T Q^T``,
    ``Q = H_0 H_1 ... H_{n-3}``, ``H_k = I - ws.betas[k] v v^T``,
    ``v = ws.reflectors[k, k+1:n]``; ``ws.off2`` holds the squared off-diagonal.
    """
    n = uint64(n)
    diag, off, reflectors, betas = ws.diag, ws.off, ws.reflectors, ws.betas
    p = ws.work[:n]
    w = ws.work[n : _2 * n]
    for k in range(n - _2):
        below = 0.0
        for i in range(k + _2, n):
            below += a[i, k] * a[i, k]
        x0 = a[k + _1, k]
        if below == 0.0:  # column already tridiagonal: H_k = I
            betas[k] = 0.0
            off[k] = x0
            continue
        norm = math.sqrt(below + x0 * x0)
        alpha = -norm if x0 >= 0.0 else norm
        v = reflectors[k]
        v[k + _1] = x0 - alpha
        for i in range(k + _2, n):
            v[i] = a[i, k]
        beta = 2.0 / (below + v[k + _1] * v[k + _1])
        betas[k] = beta
        off[k] = alpha
        # p = beta A22 v from the lower triangle; w = p - (beta / 2)(p.v) v
        for i in range(k + _1, n):
            p[i] = 0.0
        for i in range(k + _1, n):
            vi = v[i]
            s = 0.0
            for j in range(k + _1, i):
                aij = a[i, j]
                s += aij * v[j]
                p[j] += aij * vi
            p[i] += s + a[i, i] * vi
        pv = 0.0
        for i in range(k + _1, n):
            p[i] *= beta
            pv += p[i] * v[i]
        half = 0.5 * beta * pv
        for i in range(k + _1, n):
            w[i] = p[i] - half * v[i]
        # A22 -= v w^T + w v^T, lower triangle
        for i in range(k + _1, n):
            vi = v[i]
            wi = w[i]
            for j in range(k + _1, i + _1):
                a[i, j] -= vi * w[j] + wi * v[j]
    for i in range(n):
        diag[i] = a[i, i]
    off[n - _2] = a[n - _1, n - _2]
    for i in range(n - _1):
        ws.off2[i] = off[i] * off[i]


@njit(cache=True, nogil=True)
def gershgorin_bounds(ws, n):
    """Gershgorin interval of ``T`` and the smallest pivot a Sturm sequence may use."""
    n = uint64(n)
    diag, off = ws.diag, ws.off
    lo = np.inf
    hi = -np.inf
    for i in range(n):
        radius = (abs(off[i - _1]) if i > _0 else 0.0) + (abs(off[i]) if i + _1 < n else 0.0)
        lo = min(lo, diag[i] - radius)
        hi = max(hi, diag[i] + radius)
    scale = max(abs(lo), abs(hi))
    # pivots are kept away from zero by this much: e^2 / pivmin stays finite for any
    # Gram matrix of image patches
    pivmin = 1e-250 * (1.0 + scale)
    return lo, hi, scale, pivmin


@njit(cache=True, nogil=True)
def negligible(ws, n):
    """Eigenvalue of ``T`` under which a component is numerically zero (see ``_NEGLIGIBLE``)."""
    _, _, scale, pivmin = gershgorin_bounds(ws, n)
    return _NEGLIGIBLE * scale + pivmin


@njit(cache=True, nogil=True)
def count_below(ws, n, x):
    """Number of eigenvalues of the tridiagonal ``T`` (after :func:`tridiagonalize`) below ``x``."""
    n = uint64(n)
    diag, off2 = ws.diag, ws.off2
    _, _, _, pivmin = gershgorin_bounds(ws, n)
    count = 0
    q = diag[0] - x
    if abs(q) < pivmin:
        q = -pivmin
    if q < 0.0:
        count += 1
    for i in range(_1, n):
        q = diag[i] - x - off2[i - _1] / q
        if abs(q) < pivmin:
            q = -pivmin
        if q < 0.0:
            count += 1
    return count


@njit(cache=True, nogil=True, fastmath={"contract", "nsz"})
def _sturm_points(ws, n, active, n_active, pivmin):
    """Sturm counts and ``d/dx log det(T - x I)`` at ``ws.point[active[:n_active]]``.

    The ``LDL^T`` recurrence of ``T - x I``; lanes are packed, so ``ws.counts[a]`` and
    ``ws.s[a]`` belong to the ``a``-th active search.
    """
    n = uint64(n)
    k = uint64(n_active)
    diag, off2 = ws.diag, ws.off2
    x, inverse, derivs, counts, logderiv = ws.work, ws.pivots, ws.c, ws.counts, ws.s
    for a in range(k):
        x[a] = ws.point[uint64(active[a])]
        q = diag[0] - x[a]
        if abs(q) < pivmin:
            q = -pivmin
        r = 1.0 / q
        inverse[a] = r
        derivs[a] = -1.0
        counts[a] = 1 if q < 0.0 else 0
        logderiv[a] = -r
    for i in range(_1, n):
        d = diag[i]
        e2 = off2[i - _1]
        for a in range(k):
            r = inverse[a]
            q = d - x[a] - e2 * r
            dq = -1.0 + e2 * derivs[a] * r * r
            if abs(q) < pivmin:
                q = -pivmin
            r = 1.0 / q
            inverse[a] = r
            derivs[a] = dq
            counts[a] += 1 if q < 0.0 else 0
            logderiv[a] += dq * r


@njit(cache=True, nogil=True)
def largest_eigenvalues(ws, n, k, floor):
    """The ``k`` largest eigenvalues of ``T`` into ``ws.values[:k]``, descending.

    Every eigenvalue is bracketed by Sturm counts (LAPACK ``stebz``). At each round the
    counts at the points of all unfinished searches tighten every bracket (so the searches
    share what they learn); a bracket that holds its eigenvalue alone takes a Newton step
    on ``det(T - x I)`` when it stays inside, otherwise the bracket is halved, in
    logarithmic scale when it is positive (Gram matrices span decades). A search ends when
    its Newton step falls below ``_EIGENVALUE_TOL`` of the spectrum, or, for eigenvalues
    too close to isolate, when its bracket is narrower than ``_CLUSTER_TOL`` of its value.
    ``floor`` is a value with at least ``k`` eigenvalues above it; for a Gram matrix, any
    ``floor <= 0`` works. When a third or more of the spectrum is wanted, all eigenvalues
    by the QL method are cheaper (:func:`_largest_by_ql`).
    """
    if 3 * k >= n:
        _largest_by_ql(ws, n, k)
        return
    lower, upper, point = ws.lower, ws.upper, ws.point
    counts, logderiv = ws.counts, ws.s
    count_lower, count_upper, active = ws.t, ws.mult, ws.vectors[0]
    lo, hi, scale, pivmin = gershgorin_bounds(ws, n)
    if floor > lo:
        lo = floor
    tol = _EIGENVALUE_TOL * scale + pivmin
    hi += tol
    count_lo = count_below(ws, n, lo)
    k = uint64(k)
    for j in range(k):
        lower[j] = lo
        upper[j] = hi
        count_lower[j] = count_lo
        count_upper[j] = n
        point[j] = _split(lo, hi)
        active[j] = j
    n_active = k
    for _ in range(200):
        if n_active == 0:
            break
        _sturm_points(ws, n, active, n_active, pivmin)
        # every count tightens every bracket: the j-th largest is the (n-1-j)-th smallest
        for a in range(n_active):
            x = point[uint64(active[a])]
            below = counts[a]
            for b in range(n_active):
                t = uint64(active[b])
                if below + t <= n - 1:
                    if x > lower[t]:
                        lower[t] = x
                        count_lower[t] = below
                elif x < upper[t]:
                    upper[t] = x
                    count_upper[t] = below
        remaining = uint64(0)
        for a in range(n_active):
            j = uint64(active[a])
            target = n - 1 - np.int64(j)
            x = point[j]
            width = upper[j] - lower[j]
            nxt = _split(lower[j], upper[j])
            if count_lower[j] == target and count_upper[j] == target + 1:
                # alone in its bracket: Newton, or halving when the step leaves it
                step = -1.0 / logderiv[a] if logderiv[a] != 0.0 else np.inf
                if abs(step) <= tol:
                    ws.values[j] = min(max(x + step, lower[j]), upper[j])
                    continue
                if width <= tol:
                    ws.values[j] = 0.5 * (lower[j] + upper[j])
                    continue
                if lower[j] < x + step < upper[j]:
                    nxt = x + step
            elif width <= _CLUSTER_TOL * abs(upper[j]) + tol:
                ws.values[j] = 0.5 * (lower[j] + upper[j])
                continue
            point[j] = nxt
            active[remaining] = j
            remaining += _1
        n_active = remaining
    for a in range(n_active):
        j = uint64(active[a])
        ws.values[j] = 0.5 * (lower[j] + upper[j])


@njit(cache=True, nogil=True)
def _largest_by_ql(ws, n, k):
    """All eigenvalues of ``T`` by the implicit QL method with Wilkinson shifts (``tql1``,
    Bowdler, Martin, Reinsch and Wilkinson 1968), the ``k`` largest into ``ws.values``."""
    d, e = ws.lower, ws.upper
    _, _, scale, _ = gershgorin_bounds(ws, n)
    for i in range(n):
        d[i] = ws.diag[i]
        e[i] = ws.off[i] if i < n - 1 else 0.0
    tiny = 2.2e-16 * scale  # an off-diagonal this small splits T
    for first in range(n):
        for _ in range(60):
            last = first
            while last < n - 1 and abs(e[last]) > tiny:
                last += 1
            if last == first:
                break
            g = (d[first + 1] - d[first]) / (2.0 * e[first])
            r = math.sqrt(g * g + 1.0)
            g = d[last] - d[first] + e[first] / (g + (r if g >= 0.0 else -r))
            sine = 1.0
            cosine = 1.0
            p = 0.0
            i = last - 1
            deflated = False
            while i >= first:
                f = sine * e[i]
                b = cosine * e[i]
                r = math.sqrt(f * f + g * g)
                e[i + 1] = r
                if r == 0.0:
                    d[i + 1] -= p
                    e[last] = 0.0
                    deflated = True
                    break
                sine = f / r
                cosine = g / r
                g = d[i + 1] - p
                r = (d[i] - g) * sine + 2.0 * cosine * b
                p = sine * r
                d[i + 1] = g + p
                g = cosine * r - b
                i -= 1
            if deflated:
                continue
            d[first] -= p
            e[first] = g
            e[last] = 0.0
    # the k largest, descending (partial selection sort)
    for j in range(k):
        best = j
        for i in range(j + 1, n):
            if d[i] > d[best]:
                best = i
        d[j], d[best] = d[best], d[j]
        ws.values[j] = d[j]


@njit(cache=True, nogil=True)
def _split(a, b):
    """Bisection point of ``[a, b]``: geometric when ``a > 0``, unless the bracket is narrow."""
    if a > 0.0 and b > 4.0 * a:
        return math.sqrt(a * b)
    return 0.5 * (a + b)
