"""Why the pixels of a dense match are valid or not: each reference pixel by cause.

A dense matcher (:func:`radcons.evaluate.matching.dense_disparity`) leaves NaN where it
found no match, and a disparity it found may still be wrong. Without ground truth the
reference pixels are sorted into causes (:data:`CAUSES`, codes in that order):

- ``matched``: a finite disparity that passes the left-right check
  (:func:`radcons.evaluate.matching.left_right_consistent`);
- ``left-right rejected``: a finite disparity the target's own disparity does not
  confirm within the tolerance;
- ``at the range's edge``: a finite disparity within ``edge`` px of either bound of the
  disparities the matcher searched (:func:`radcons.evaluate.matching.searched_bounds`), a
  sign that the true disparity lies outside the range; it takes precedence over the two
  above, since a match pressed against a bound is suspect even when both ways agree;
- ``no match``: the matcher gave no disparity to a valid reference pixel;
- ``nodata``: the reference pixel is invalid (NaN).

:func:`match_causes` runs the left-right check and classifies; :func:`classify_matches`
only classifies, and :func:`object_consistency` gives the left-right consistent share of
each object of a label image.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from radcons.errors import InputError
from radcons.evaluate.matching import (
    MatcherParams,
    left_right_consistent,
    searched_bounds,
)
from radcons.numerics.census import CensusParams

__all__ = [
    "CAUSES",
    "LEFT_RIGHT_REJECTED",
    "MATCHED",
    "NODATA",
    "NO_MATCH",
    "RANGE_EDGE",
    "MatchCauses",
    "classify_matches",
    "match_causes",
    "object_consistency",
]

#: Names of the causes; a pixel's code is the index of its cause here.
CAUSES: tuple[str, ...] = ("matched", "left-right rejected", "at the range's edge", "no match", "nodata")
MATCHED, LEFT_RIGHT_REJECTED, RANGE_EDGE, NO_MATCH, NODATA = range(len(CAUSES))


@dataclass(frozen=True)
class MatchCauses:
    """The cause of every reference pixel of a dense match.

    Attributes
    ----------
    codes : ndarray of uint8, shape (H, W)
        Index into :data:`CAUSES` of each reference pixel's cause.
    consistent : ndarray of bool, shape (H, W)
        Where the disparity passes the left-right check (at the range's edge or not).
    """

    codes: np.ndarray
    consistent: np.ndarray

    def shares(self) -> dict[str, float]:
        """Cause name -> share of the reference's pixels (all of them; they sum to 1)."""
        counts = np.bincount(self.codes.ravel(), minlength=len(CAUSES))
        return {name: float(count) / self.codes.size for name, count in zip(CAUSES, counts)}


def classify_matches(
    valid: np.ndarray,
    disparity: np.ndarray,
    consistent: np.ndarray,
    bounds: tuple[float, float],
    edge: float = 1.0,
) -> np.ndarray:
    """The cause code of each reference pixel (see the module docstring).

    Parameters
    ----------
    valid : ndarray of bool
        Where the reference pixel is valid.
    disparity : ndarray
        The reference's disparity, NaN where the matcher gave none.
    consistent : ndarray of bool
        Where the disparity passes the left-right check.
    bounds : (float, float)
        Smallest and largest disparity searched.
    edge : float
        A finite disparity within this many px of a bound is ``at the range's edge``.

    Returns
    -------
    ndarray of uint8
        Index into :data:`CAUSES` per pixel.

    Raises
    ------
    InputError
        Arrays of different shapes.
    """
    if not valid.shape == disparity.shape == consistent.shape:
        raise InputError(
            f"classifying needs arrays of one shape, got {valid.shape}, {disparity.shape} and {consistent.shape}"
        )
    finite = np.isfinite(disparity) & valid
    low, high = bounds
    with np.errstate(invalid="ignore"):
        at_edge = finite & ((disparity <= low + edge) | (disparity >= high - edge))
    codes = np.full(disparity.shape, NO_MATCH, np.uint8)
    codes[~valid] = NODATA
    codes[finite & ~consistent] = LEFT_RIGHT_REJECTED
    codes[finite & consistent] = MATCHED
    codes[at_edge] = RANGE_EDGE
    return codes


def match_causes(
    reference: np.ndarray,
    target: np.ndarray,
    disparity: np.ndarray,
    params: MatcherParams | CensusParams,
    disparity_range: tuple[float, float],
    tolerance: float = 1.0,
    edge: float = 1.0,
) -> MatchCauses:
    """Check a dense match left-right and classify its reference pixels by cause.

    Parameters
    ----------
    reference, target : ndarray
        The images ``disparity`` was matched on (NaN where invalid).
    disparity : ndarray
        The reference's disparity by :func:`radcons.evaluate.matching.dense_disparity`.
    params : MatcherParams or CensusParams
        The matcher that made it.
    disparity_range : (float, float)
        The range it was asked to search.
    tolerance : float
        Left-right tolerance, px.
    edge : float
        Distance, px, to a bound of the searched range within which a disparity is at
        the range's edge.

    Returns
    -------
    MatchCauses

    Raises
    ------
    InputError
        Arrays of different shapes, or a reference without a valid pixel.
    """
    consistent = left_right_consistent(reference, target, disparity, params, disparity_range, tolerance)
    bounds = searched_bounds(params, disparity_range)
    codes = classify_matches(np.isfinite(reference), disparity, consistent, bounds, edge)
    return MatchCauses(codes, consistent)


def object_consistency(
    consistent: np.ndarray, valid: np.ndarray, labels: np.ndarray, ids: Iterable[int]
) -> dict[int, float]:
    """The left-right consistent share of each object's valid reference pixels.

    Parameters
    ----------
    consistent : ndarray of bool
        Where the disparity passes the left-right check.
    valid : ndarray of bool
        Where the reference pixel is valid.
    labels : ndarray of int
        Object labels of the reference (0 = background).
    ids : iterable of int
        The objects to measure.

    Returns
    -------
    dict
        Object id -> share (NaN for an object without a valid pixel).
    """
    if not consistent.shape == valid.shape == labels.shape:
        raise InputError("consistency per object needs arrays of one shape")
    ids = np.asarray(sorted({int(i) for i in ids}), np.int64)
    if ids.size == 0:
        return {}
    flat = labels.ravel().astype(np.int64)
    keep = valid.ravel() & (flat >= 0) & (flat <= ids.max())
    size = int(ids.max()) + 1
    totals = np.bincount(flat[keep], minlength=size)
    passed = np.bincount(flat[keep], weights=consistent.ravel()[keep], minlength=size)
    return {int(i): float(passed[i] / totals[i]) if totals[i] else float("nan") for i in ids}
