"""Compiled kernels of the (union) group sparse model, Su et al. (2018) section 5, eq 13-17.

A *group* is a stack of ``m`` similar ``P x P`` patches, one patch a row (``m x P^2``). Its
estimate is the low-rank approximation of eq 15-16: the group is centred on its mean patch
(as in SAIST, Dong, Shi and Li 2013), decomposed as ``U diag(lambda) V^T`` and rebuilt
with soft-thresholded singular values ``max(lambda_i - tau_i, 0)``. The thresholds follow
eq 17 (SAIST's bilateral variance estimate)::

    sigma_i = sqrt(max(lambda_i^2 / m - sigma_w^2, 0)),   tau_i = c sigma_w^2 / sigma_i

where ``lambda_i`` are the singular values of the group itself (single-image model) or of
the *union* group ``[G1; G2]`` stacked from both images (section 5.2; ``m`` is then the
union's number of patches), and the same ``tau`` thresholds each image's own group. The
singular values come from the eigen-decomposition of the ``m x m`` Gram matrix
(:mod:`radcons.stages.smoothness.group_sparse_linalg`), and only the eigenvectors of the
surviving singular values are computed (:mod:`radcons.stages.smoothness.inverse_iteration`).
The groups themselves come from :mod:`radcons.stages.smoothness.patch_matching`.

Overlapping estimates are averaged (eq 13): every patch of every group adds its estimate to
the pixels it covers, and each pixel is divided by the number of estimates it received.
Groups are processed in parallel by bands of rows (:func:`band_starts`), so the result
does not depend on the number of threads or their scheduling.

Why compiled: a group costs a few hundred small dense operations (Gram matrix,
tridiagonal reduction, a handful of eigenpairs, reconstruction) and an image has tens of
thousands of groups per iteration; NumPy's batched calls spend most of their time in
per-call overhead at these sizes. numba compiles the whole per-group chain into one loop
over groups (``parallel=True`` over row bands; ``cache=True``, so that a fresh interpreter
loads the compiled code instead of compiling it again). Every kernel releases the GIL
(``nogil=True``), so a user interface served from the same process stays responsive while
the stage runs.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange, uint64

from radcons.stages.smoothness.group_sparse_linalg import (
    count_below,
    eigen_workspace,
    largest_eigenvalues,
    negligible,
    tridiagonalize,
)
from radcons.stages.smoothness.inverse_iteration import eigenvectors

__all__ = [
    "saist_thresholds",
    "shrink_group",
    "low_rank_estimate",
    "union_low_rank_estimate",
    "band_starts",
    "denoise_pass",
    "union_denoise_pass",
]

#: Reassociation and contraction let numba vectorise the dot products; inf stays inf.
_FAST = {"reassoc", "contract", "nsz", "arcp"}
#: Unsigned index constants: with unsigned loop indices numba drops its negative-index
#: test from array accesses, and LLVM vectorises the loops (see group_sparse_linalg).
_1 = np.uint64(1)


# ------------------------------------------------------------------------- group shrinkage


@njit(cache=True, nogil=True)
def saist_thresholds(values, n, n_columns, sigma_w, c, tau):
    """Eq 17 and the threshold ``tau_i = c sigma_w^2 / sigma_i`` into ``tau[:n]``.

    ``values`` are eigenvalues of the Gram matrix (squared singular values), descending;
    ``n_columns`` is ``m`` of eq 17. A component with ``sigma_i = 0`` gets ``tau = inf``.
    """
    noise = sigma_w * sigma_w
    for i in range(n):
        var = max(values[i], 0.0) / n_columns - noise
        tau[i] = c * noise / math.sqrt(var) if var > 0.0 else np.inf


@njit(cache=True, nogil=True, fastmath=_FAST)
def _gram(group, m, gram, offset):
    """Lower triangle of ``group[:m] group[:m]^T`` into ``gram[offset:, offset:]``."""
    p = uint64(group.shape[1])
    m = uint64(m)
    offset = uint64(offset)
    for i in range(m):
        for j in range(i + _1):
            s = 0.0
            for t in range(p):
                s += group[i, t] * group[j, t]
            gram[offset + i, offset + j] = s


@njit(cache=True, nogil=True, fastmath=_FAST)
def _cross_gram(g1, g2, m, union):
    """Lower off-diagonal block ``G2 G1^T`` of the union Gram ``[[K1, .], [G2 G1^T, K2]]``."""
    p = uint64(g1.shape[1])
    m = uint64(m)
    for i in range(m):
        for j in range(m):
            s = 0.0
            for t in range(p):
                s += g2[i, t] * g1[j, t]
            union[m + i, j] = s


@njit(cache=True, nogil=True, fastmath=_FAST)
def _centre(group, m, mean):
    p = uint64(group.shape[1])
    m = uint64(m)
    for t in range(p):
        mean[t] = 0.0
    for i in range(m):
        for t in range(p):
            mean[t] += group[i, t]
    for t in range(p):
        mean[t] /= float(m)
    for i in range(m):
        for t in range(p):
            group[i, t] -= mean[t]


@njit(cache=True, nogil=True, fastmath=_FAST)
def shrink_group(group, m, rank, tau, ws, coef, mean, out):
    """Rebuild ``group[:m]`` from its ``rank`` leading singular values shrunk by ``tau``.

    ``ws`` holds the tridiagonal form of the group's Gram matrix and, in
    ``ws.values[:rank]``, its largest eigenvalues ``lambda_i^2``; every one of them must
    exceed ``tau_i^2``. Writes ``mean + sum_i max(lambda_i - tau_i, 0) u_i v_i^T`` (eq 16)
    into ``out[:m]``.
    """
    p = uint64(group.shape[1])
    m_ = uint64(m)
    for i in range(m_):
        for t in range(p):
            out[i, t] = mean[t]
    if rank == 0:
        return
    vectors = eigenvectors(ws, m, rank)
    rank = uint64(rank)
    # U diag(lambda - tau) V^T = V^T diag(f) V G with f_i = (lambda_i - tau_i) / lambda_i
    for k in range(rank):
        lam = math.sqrt(ws.values[k])
        f = max(lam - tau[k], 0.0) / lam
        v = vectors[k]
        for t in range(p):
            coef[k, t] = 0.0
        for i in range(m_):
            vi = v[i] * f
            for t in range(p):
                coef[k, t] += vi * group[i, t]
    for k in range(rank):
        v = vectors[k]
        for i in range(m_):
            vi = v[i]
            for t in range(p):
                out[i, t] += vi * coef[k, t]


@njit(cache=True, nogil=True)
def _single_estimate(group, m, sigma_w, c, ws, gram, tau, mean, coef, out):
    """Centred SAIST estimate of one group (eq 15-17) into ``out``; returns the rank kept.

    ``lambda_i`` survives ``tau_i`` exactly when ``lambda_i^2 > m sigma_w^2 (1 + sqrt(1 +
    4 c^2 / m)) / 2``, so one Sturm count gives the rank before any eigenvalue is known.
    """
    _centre(group, m, mean)
    _gram(group, m, gram, 0)
    tridiagonalize(gram, m, ws)
    noise = sigma_w * sigma_w
    cutoff = max(0.5 * m * noise * (1.0 + math.sqrt(1.0 + 4.0 * c * c / m)), negligible(ws, m))
    rank = m - count_below(ws, m, cutoff)
    if rank > 0:
        largest_eigenvalues(ws, m, rank, cutoff)
        saist_thresholds(ws.values, rank, m, sigma_w, c, tau)
    shrink_group(group, m, rank, tau, ws, coef, mean, out)
    return rank


@njit(cache=True, nogil=True)
def _union_estimate(g1, g2, m, sigma_w, c, ws, union, grams, tau, mean, coef, out1, out2):
    """Union group estimate (section 5.2): thresholds from ``[G1; G2]``, applied to each.

    Only the union eigenvalues with ``sigma_i > 0`` (``lambda_i^2 > 2 m sigma_w^2``) have
    a finite threshold, and an image's ``lambda_i`` below the smallest threshold cannot
    survive, so only those eigenvalues are computed. The union Gram's diagonal blocks are
    the two groups' own Gram matrices. Returns the total rank kept.
    """
    _centre(g1, m, mean[0])
    _centre(g2, m, mean[1])
    _gram(g1, m, union, 0)
    _gram(g2, m, union, m)
    _cross_gram(g1, g2, m, union)
    size = uint64(m)
    for i in range(size):
        for j in range(i + _1):
            grams[0, i, j] = union[i, j]
            grams[1, i, j] = union[size + i, size + j]
    n_union = 2 * m
    tridiagonalize(union, n_union, ws)
    noise = sigma_w * sigma_w
    floor = n_union * noise
    finite = min(n_union - count_below(ws, n_union, floor), m)
    if finite > 0:
        largest_eigenvalues(ws, n_union, finite, floor)
        saist_thresholds(ws.values, finite, n_union, sigma_w, c, tau)
    ranks = 0
    for which in range(2):
        group = g1 if which == 0 else g2
        out = out1 if which == 0 else out2
        rank = 0
        if finite > 0:
            gram = grams[which]
            tridiagonalize(gram, m, ws)
            smallest = max(tau[0] * tau[0], negligible(ws, m))
            candidates = min(finite, m - count_below(ws, m, smallest))
            if candidates > 0:
                largest_eigenvalues(ws, m, candidates, smallest)
                while rank < candidates and math.sqrt(max(ws.values[rank], 0.0)) > tau[rank]:
                    rank += 1
        shrink_group(group, m, rank, tau, ws, coef, mean[which], out)
        ranks += rank
    return ranks


@njit(cache=True)
def low_rank_estimate(group, sigma_w, c):
    """SAIST estimate of one group ``(m, P^2)``: centre, eq 17 thresholds, eq 16 shrinkage.

    The per-group kernel of :func:`denoise_pass`, callable on one group (float64 copy).
    """
    m, p = group.shape
    g = group.astype(np.float64)
    out = np.empty((m, p))
    _single_estimate(
        g, m, sigma_w, c, eigen_workspace(m), np.zeros((m, m)), np.empty(m), np.empty(p),
        np.empty((m, p)), out,
    )
    return out


@njit(cache=True)
def union_low_rank_estimate(group1, group2, sigma_w, c):
    """Union group estimate of two groups ``(m, P^2)`` (section 5.2); returns both.

    The per-group kernel of :func:`union_denoise_pass`, callable on one pair of groups.
    """
    m, p = group1.shape
    g1 = group1.astype(np.float64)
    g2 = group2.astype(np.float64)
    out1 = np.empty((m, p))
    out2 = np.empty((m, p))
    _union_estimate(
        g1, g2, m, sigma_w, c, eigen_workspace(2 * m), np.zeros((2 * m, 2 * m)),
        np.zeros((2, m, m)), np.empty(m), np.empty((2, p)), np.empty((m, p)), out1, out2,
    )
    return out1, out2


# ------------------------------------------------------------------------ image passes


@njit(cache=True, nogil=True)
def _gather(image, ys, xs, m, patch, group):
    size = uint64(patch)
    for i in range(uint64(m)):
        y = uint64(ys[i])
        x = uint64(xs[i])
        for dy in range(size):
            for dx in range(size):
                group[i, dy * size + dx] = image[y + dy, x + dx]


@njit(cache=True, nogil=True)
def _scatter(estimate, ys, xs, m, patch, num, den):
    size = uint64(patch)
    for i in range(uint64(m)):
        y = uint64(ys[i])
        x = uint64(xs[i])
        for dy in range(size):
            for dx in range(size):
                num[y + dy, x + dx] += estimate[i, dy * size + dx]
                den[y + dy, x + dx] += 1.0


@njit(cache=True, parallel=True, nogil=True)
def _combine(image, num, den):
    """Eq 13: sum of estimates over their count; pixels no group reached keep ``image``."""
    height, width = image.shape
    result = np.empty((height, width), np.float32)
    for y in prange(height):
        for x in range(width):
            result[y, x] = num[y, x] / den[y, x] if den[y, x] > 0.0 else image[y, x]
    return result


def band_starts(centre_rows: np.ndarray, band_rows: int) -> np.ndarray:
    """First group of each band of ``band_rows`` image rows, for groups sorted by row.

    The passes below process even bands in parallel, then odd bands: a band's groups
    (centre row within the band, patches within ``radius`` rows of it) write only rows
    that the bands two away cannot reach when ``band_rows >= 2 radius + patch``, so no two
    threads ever add to the same pixel, and each pixel receives its estimates in the same
    order whatever the number of threads.
    """
    bands = np.asarray(centre_rows) // band_rows
    if bands.size and np.any(np.diff(bands) < 0):
        raise ValueError("groups must be sorted by centre row")
    edges = np.flatnonzero(np.diff(bands)) + 1
    return np.concatenate([[0], edges, [bands.size]]).astype(np.int64)


@njit(cache=True, parallel=True, nogil=True)
def denoise_pass(image, ys, xs, patch, sigma_w, c, starts):
    """One pass of the single-image group sparse model over all groups (eq 13-17).

    Parameters
    ----------
    image : ndarray (H, W) float32
    ys, xs : ndarray (G, m) int32
        Top-left corners of every group's patches (:func:`block_match`), groups sorted by
        centre row.
    patch : int
    sigma_w, c : float
        Noise level and constant of eq 17.
    starts : ndarray of int64
        :func:`band_starts` of the groups.

    Returns
    -------
    ndarray (H, W) float32
    """
    m = ys.shape[1]
    p = patch * patch
    num = np.zeros(image.shape)
    den = np.zeros(image.shape)
    n_bands = starts.size - 1
    for phase in range(2):
        for half in prange((n_bands - phase + 1) // 2):
            band = phase + 2 * half
            ws = eigen_workspace(m)
            group = np.empty((m, p))
            gram = np.zeros((m, m))
            tau = np.empty(m)
            mean = np.empty(p)
            coef = np.empty((m, p))
            out = np.empty((m, p))
            for g in range(starts[band], starts[band + 1]):
                _gather(image, ys[g], xs[g], m, patch, group)
                _single_estimate(group, m, sigma_w, c, ws, gram, tau, mean, coef, out)
                _scatter(out, ys[g], xs[g], m, patch, num, den)
    return _combine(image, num, den)


@njit(cache=True, parallel=True, nogil=True)
def union_denoise_pass(image1, image2, ys1, xs1, ys2, xs2, patch, sigma_w, c, starts):
    """One pass of the union group sparse model over both images (section 5.2).

    Group ``g`` stacks the patches ``(ys1[g], xs1[g])`` of ``image1`` and
    ``(ys2[g], xs2[g])`` of ``image2`` (same rows, rectified pair); see
    :func:`denoise_pass` for the rest.

    Returns
    -------
    (ndarray, ndarray)
        The two estimates, float32.
    """
    m = ys1.shape[1]
    p = patch * patch
    num1 = np.zeros(image1.shape)
    den1 = np.zeros(image1.shape)
    num2 = np.zeros(image2.shape)
    den2 = np.zeros(image2.shape)
    n_bands = starts.size - 1
    for phase in range(2):
        for half in prange((n_bands - phase + 1) // 2):
            band = phase + 2 * half
            ws = eigen_workspace(2 * m)
            g1 = np.empty((m, p))
            g2 = np.empty((m, p))
            union = np.zeros((2 * m, 2 * m))
            grams = np.zeros((2, m, m))
            tau = np.empty(m)
            mean = np.empty((2, p))
            coef = np.empty((m, p))
            out1 = np.empty((m, p))
            out2 = np.empty((m, p))
            for g in range(starts[band], starts[band + 1]):
                _gather(image1, ys1[g], xs1[g], m, patch, g1)
                _gather(image2, ys2[g], xs2[g], m, patch, g2)
                _union_estimate(g1, g2, m, sigma_w, c, ws, union, grams, tau, mean, coef, out1, out2)
                _scatter(out1, ys1[g], xs1[g], m, patch, num1, den1)
                _scatter(out2, ys2[g], xs2[g], m, patch, num2, den2)
    return _combine(image1, num1, den1), _combine(image2, num2, den2)
