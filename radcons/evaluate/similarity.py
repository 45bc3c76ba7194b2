"""Improved histogram similarity of associated objects (Su et al. 2018, eq 20).

Eq 20 as printed::

    C = 1 - [max(j) - min(j)] * sum_j |O1(j) - O2(j)| * zeta_j / (2 * 255 * M * zeta_max)

with ``j`` the grey level (0..255), ``O1``, ``O2`` the histograms (pixel counts) of the two
object crops, ``zeta_j = |A - j| + 1``, ``A`` "the average value", ``zeta_max`` the largest
``zeta_j`` and ``M`` "the size of the image". The text leaves three things open; the
reading implemented here is the one under which C lies in [0, 1] and equals 1 exactly when
the two histograms are equal:

* ``max(j) - min(j)`` is the span of the grey levels that occur in either crop, so that
  ``[max(j) - min(j)] / 255 <= 1``.
* ``M`` is the number of pixels of a crop and the histograms are counted per crop, so
  ``O_k(j) / M`` is crop k's share of pixels at level j. Crops of different sizes (the
  reference and the target boxes of one object rarely agree to the pixel) are compared by
  these shares; with equal sizes this is the printed formula exactly. Then
  ``sum_j |O1(j) - O2(j)| / M <= 2``, which the 2 in the denominator cancels.
* ``A`` is the mean grey level of the two crops together (mean of both histograms) and
  ``zeta_max`` the largest ``zeta_j`` over the occupied levels, so ``zeta_j / zeta_max <= 1``
  wherever the histograms differ. Differences far from the mean grey level weigh more.

The three factors are each at most 1, so ``0 <= C <= 1``; equal histograms give ``C = 1``.

Section 6.3 cuts each object's minimum bounding rectangle from its image and sets the
background (pixels of the rectangle outside the object) to 0; with 256 levels over the
pair's common value range ``[low, high]``, background pixels therefore fall in level 0.
Invalid (NaN) pixels inside the object are left out of the histogram.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from radcons.errors import InputError

__all__ = ["LEVELS", "histogram_similarity", "object_crop", "object_similarities", "common_range"]

#: Number of grey levels of eq 20.
LEVELS = 256


def common_range(*images: np.ndarray) -> tuple[float, float]:
    """Return ``(low, high)``: the smallest and largest finite value over all ``images``.

    Raises
    ------
    InputError
        No finite value at all, or every finite value is the same.
    """
    lows, highs = [], []
    for image in images:
        finite = np.asarray(image)[np.isfinite(image)]
        if finite.size:
            lows.append(float(finite.min()))
            highs.append(float(finite.max()))
    if not lows:
        raise InputError("no finite pixel in the images: cannot find their value range")
    low, high = min(lows), max(highs)
    if not high > low:
        raise InputError(f"the images hold the single value {low}: their value range is empty")
    return low, high


def _levels(values: np.ndarray, value_range: tuple[float, float]) -> np.ndarray:
    """Quantise values into the 256 levels of eq 20 (values outside the range are clipped)."""
    low, high = value_range
    scaled = (values.astype(np.float64) - low) * (LEVELS / (high - low))
    return np.clip(np.floor(scaled), 0, LEVELS - 1).astype(np.intp)


def histogram_similarity(
    ref_crop: np.ndarray, tgt_crop: np.ndarray, value_range: tuple[float, float]
) -> float:
    """Improved histogram similarity C of two crops (eq 20).

    Parameters
    ----------
    ref_crop, tgt_crop : ndarray
        The two crops (any shape, sizes may differ), on the value scale of ``value_range``.
        NaN pixels are left out.
    value_range : (float, float)
        ``(low, high)`` mapped onto the 256 grey levels; values outside are clipped to the
        first or last level. Use the same range for both crops (the pair's common range),
        so that a brightness difference shows.

    Returns
    -------
    float
        C in [0, 1]; 1 when both crops have the same histogram. See the module docstring
        for how the ambiguous terms of eq 20 are read.

    Raises
    ------
    InputError
        An empty crop (no finite pixel) or an empty value range.

    References
    ----------
    Su, Yan, Zhao, Wang (2018), "Object-Oriented Hierarchy Radiation Consistency for Different
    Temporal and Different Sensor Images", Remote Sensing, eq 20 and section 6.3.
    """
    low, high = float(value_range[0]), float(value_range[1])
    if not (np.isfinite(low) and np.isfinite(high) and high > low):
        raise InputError(f"value_range must be finite with high > low, got {value_range}")
    shares = []
    for name, crop in (("reference", ref_crop), ("target", tgt_crop)):
        values = np.asarray(crop, dtype=np.float64).ravel()
        values = values[np.isfinite(values)]
        if values.size == 0:
            raise InputError(f"the {name} crop has no valid pixel")
        counts = np.bincount(_levels(values, (low, high)), minlength=LEVELS)
        shares.append(counts / values.size)  # O_k(j) / M
    p1, p2 = shares
    occupied = np.flatnonzero((p1 > 0) | (p2 > 0))
    span = occupied[-1] - occupied[0]  # max(j) - min(j)
    grey = np.arange(LEVELS, dtype=np.float64)
    mean_level = float(np.sum(grey * (p1 + p2)) / 2.0)  # A
    zeta = np.abs(mean_level - grey) + 1.0
    zeta_max = zeta[occupied].max()
    weighted = float(np.sum(np.abs(p1 - p2) * zeta)) / zeta_max
    return float(1.0 - span * weighted / (2.0 * (LEVELS - 1)))


def object_crop(
    image: np.ndarray, mask: np.ndarray, background: float
) -> np.ndarray:
    """Cut the minimum bounding rectangle of ``mask`` from ``image``, background set.

    Parameters
    ----------
    image : ndarray
        2-D image.
    mask : ndarray of bool
        The object, same shape as ``image``.
    background : float
        Value given to the rectangle's pixels outside the object (section 6.3 sets them to
        0, the lowest grey level).

    Returns
    -------
    ndarray of float64
        The crop.

    Raises
    ------
    InputError
        Shapes differ or the mask is empty.
    """
    if mask.shape != image.shape:
        raise InputError(f"object mask is {mask.shape} but the image is {image.shape}")
    rows, cols = np.nonzero(mask)
    if rows.size == 0:
        raise InputError("the object mask is empty")
    box = (slice(rows.min(), rows.max() + 1), slice(cols.min(), cols.max() + 1))
    return np.where(mask[box], image[box].astype(np.float64), background)


def object_similarities(
    reference: np.ndarray,
    target: np.ndarray,
    labels_ref: np.ndarray,
    labels_tgt: np.ndarray,
    pairs: Sequence[tuple[int, int]],
    value_range: tuple[float, float] | None = None,
) -> dict[int, float]:
    """Eq 20 similarity of each associated object pair.

    For each ``(ref_id, tgt_id)`` the reference crop is the bounding rectangle of
    ``labels_ref == ref_id`` cut from ``reference`` and the target crop the bounding
    rectangle of ``labels_tgt == tgt_id`` cut from ``target``; background pixels of each
    rectangle are set to the lowest grey level (section 6.3).

    Parameters
    ----------
    reference, target : ndarray
        float32 images on their original value range, NaN where invalid.
    labels_ref, labels_tgt : ndarray of int
        Object label rasters of the reference and of the target (0 = background).
    pairs : sequence of (int, int)
        Associated object ids ``(ref_id, tgt_id)``.
    value_range : (float, float), optional
        Range mapped onto the 256 levels; default the pair's common range (smallest and
        largest finite value of the two images).

    Returns
    -------
    dict
        ``ref_id -> C``.

    Raises
    ------
    InputError
        Mismatched shapes, or an id absent from its label raster.
    """
    if labels_ref.shape != reference.shape or labels_tgt.shape != target.shape:
        raise InputError(
            f"label rasters {labels_ref.shape}, {labels_tgt.shape} do not match the images "
            f"{reference.shape}, {target.shape}"
        )
    if value_range is None:
        value_range = common_range(reference, target)
    background = float(value_range[0])
    result: dict[int, float] = {}
    for ref_id, tgt_id in pairs:
        ref_mask, tgt_mask = labels_ref == ref_id, labels_tgt == tgt_id
        if not ref_mask.any():
            raise InputError(f"object {ref_id} is absent from the reference labels")
        if not tgt_mask.any():
            raise InputError(f"object {tgt_id} is absent from the target labels")
        ref_crop = object_crop(reference, ref_mask, background)
        tgt_crop = object_crop(target, tgt_mask, background)
        result[int(ref_id)] = histogram_similarity(ref_crop, tgt_crop, value_range)
    return result
