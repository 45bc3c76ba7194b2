"""Block matching of the group sparse model: the similar patches of each group (section 5.2).

For every centre patch, the ``m`` patches of a square search window with the smallest sum
of squared differences to it form its group (eq 13's similar patches). Union groups search
each image's patches inside the matched object region first (section 5.2 rule b), so the
search ranks a candidate by its region before its distance. Compiled with numba like the
rest of the model (:mod:`radcons.stages.smoothness.group_sparse`).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange, uint64

__all__ = ["block_match"]

#: Reassociation and contraction let numba vectorise the sums of squares; inf stays inf.
_FAST = {"reassoc", "contract", "nsz", "arcp"}
#: Unsigned index constant: with unsigned loop indices numba drops its negative-index
#: test from array accesses, and LLVM vectorises the loops (see group_sparse_linalg).
_1 = np.uint64(1)


@njit(cache=True, nogil=True, fastmath=_FAST)
def _match_one(image, cy, cx, labels, label, patch, radius, m, ref, out_y, out_x, keys, dists):
    height, width = image.shape
    size = uint64(patch)
    half = uint64(patch // 2)
    top = uint64(cy)
    left = uint64(cx)
    for dy in range(size):
        for dx in range(size):
            ref[dy, dx] = image[top + dy, left + dx]
    # slot 0 is the centre patch itself, always kept
    out_y[0] = cy
    out_x[0] = cx
    count = 0
    y0 = uint64(max(cy - radius, 0))
    y1 = uint64(min(cy + radius, height - patch))
    x0 = uint64(max(cx - radius, 0))
    x1 = uint64(min(cx + radius, width - patch))
    for y in range(y0, y1 + _1):
        for x in range(x0, x1 + _1):
            if y == top and x == left:
                continue
            key = 0 if labels[y + half, x + half] == label else 1
            full = count == m - 1
            worst_key = keys[count - 1] if full else 2
            if key > worst_key:
                continue
            bound = dists[count - 1] if (full and key == worst_key) else np.inf
            d = 0.0
            for dy in range(size):
                for dx in range(size):
                    diff = image[y + dy, x + dx] - ref[dy, dx]
                    d += diff * diff
                if d >= bound:
                    break
            if d >= bound:
                continue
            # insert (key, d) into the sorted list
            pos = count - 1 if full else count
            while pos > 0 and (keys[pos - 1] > key or (keys[pos - 1] == key and dists[pos - 1] > d)):
                keys[pos] = keys[pos - 1]
                dists[pos] = dists[pos - 1]
                out_y[pos + 1] = out_y[pos]
                out_x[pos + 1] = out_x[pos]
                pos -= 1
            keys[pos] = key
            dists[pos] = d
            out_y[pos + 1] = y
            out_x[pos + 1] = x
            if not full:
                count += 1
    # fewer candidates than slots (tiny images): repeat the centre
    for k in range(count + 1, m):
        out_y[k] = cy
        out_x[k] = cx


@njit(cache=True, parallel=True, nogil=True)
def block_match(image, centres_y, centres_x, labels, group_labels, patch, radius, m):
    """The ``m`` patches most similar to each centre patch, the centre first.

    Candidates are the patches whose top-left corner lies within ``radius`` pixels of the
    centre's (a ``2 radius + 1`` square window); those whose centre pixel carries the
    group's label in ``labels`` come first (section 5.2 rule b: similar patches are
    searched in the matched object region only), by increasing sum of squared differences,
    and patches of other labels fill the group only when the region has too few.

    Parameters
    ----------
    image : ndarray (H, W) float32
    centres_y, centres_x : ndarray (G,) int
        Top-left corners of the centre patches.
    labels : ndarray (H, W) int32
        Region of every pixel.
    group_labels : ndarray (G,) int32
        Region each group searches in.
    patch, radius, m : int

    Returns
    -------
    ys, xs : ndarray (G, m) int32
        Top-left corners of the group's patches, ``[:, 0]`` the centre.
    """
    n_groups = centres_y.shape[0]
    ys = np.empty((n_groups, m), np.int32)
    xs = np.empty((n_groups, m), np.int32)
    n_chunks = min(n_groups, 8 * 64)
    for chunk in prange(n_chunks):
        ref = np.empty((patch, patch), np.float32)
        keys = np.empty(m, np.int64)
        dists = np.empty(m, np.float64)
        start = chunk * n_groups // n_chunks
        stop = (chunk + 1) * n_groups // n_chunks
        for g in range(start, stop):
            _match_one(
                image, centres_y[g], centres_x[g], labels, group_labels[g], patch, radius, m,
                ref, ys[g], xs[g], keys, dists,
            )
    return ys, xs
