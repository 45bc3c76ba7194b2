"""Each reference pixel of a dense match sorted by cause (:mod:`radcons.evaluate.validity`)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from radcons.evaluate.matching import dense_disparity, left_right_shares, matcher_params
from radcons.evaluate.validity import (
    CAUSES,
    LEFT_RIGHT_REJECTED,
    MATCHED,
    NO_MATCH,
    NODATA,
    RANGE_EDGE,
    classify_matches,
    match_causes,
    object_consistency,
)

ROWS, COLS = 80, 140
#: The disparities searched: SGBM and census both search 0 .. 15 px for it.
SEARCH = (0.0, 15.0)


def shifted_pair(shift: int, sigma: float = 1.3, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """A smoothed-noise texture seen twice: ``reference(x, y) = target(x - shift, y)``."""
    wide = ndimage.gaussian_filter(np.random.default_rng(seed).normal(size=(ROWS, COLS + abs(shift))), sigma)
    wide = (100.0 + 800.0 * (wide - wide.min()) / (wide.max() - wide.min())).astype(np.float32)
    if shift >= 0:
        return wide[:, :COLS], wide[:, shift : shift + COLS]
    return wide[:, -shift : -shift + COLS], wide[:, :COLS]


def causes_of(reference: np.ndarray, target: np.ndarray, matcher: str = "sgbm"):
    params = matcher_params(matcher)
    disparity = dense_disparity(reference, target, params, SEARCH)
    return disparity, match_causes(reference, target, disparity, params, SEARCH)


def share(codes: np.ndarray, cause: int) -> float:
    return float((codes == cause).mean())


def test_classify_by_hand():
    valid = np.array([[True, True, True, True, True, False]])
    disparity = np.array([[5.0, 5.0, 0.5, 14.5, np.nan, 5.0]])
    consistent = np.array([[True, False, True, False, False, True]])
    codes = classify_matches(valid, disparity, consistent, (0, 15))
    assert codes.tolist() == [[MATCHED, LEFT_RIGHT_REJECTED, RANGE_EDGE, RANGE_EDGE, NO_MATCH, NODATA]]
    assert [CAUSES[c] for c in codes[0]] == [
        "matched", "left-right rejected", "at the range's edge", "at the range's edge", "no match", "nodata",
    ]


@pytest.mark.parametrize("matcher", ["sgbm", "census"])
def test_a_known_shift_inside_the_range_is_matched(matcher):
    reference, target = shifted_pair(5)
    disparity, causes = causes_of(reference, target, matcher)
    shares = causes.shares()
    assert sum(shares.values()) == pytest.approx(1.0)
    # away from the borders, where the image or its mirrored match has no counterpart
    inner = causes.codes[:, 16:-16]
    assert share(inner, MATCHED) > 0.9
    matched = causes.codes == MATCHED
    assert np.mean(np.abs(disparity[matched] - 5.0) < 1.0) > 0.98
    assert shares["matched"] > 0.7 and shares["at the range's edge"] < 0.02 and shares["nodata"] == 0.0


@pytest.mark.parametrize("matcher", ["sgbm", "census"])
@pytest.mark.parametrize("shift", [18, -2])
def test_a_shift_outside_the_range_piles_up_at_its_edge(matcher, shift):
    reference, target = shifted_pair(shift, sigma=4.0, seed=2)
    _, causes = causes_of(reference, target, matcher)
    shares = causes.shares()
    assert shares["at the range's edge"] > 0.5
    assert shares["at the range's edge"] == max(shares.values())
    assert shares["matched"] < 0.1


def test_an_occluded_band_is_not_matched():
    reference, target = shifted_pair(5)
    target = target.copy()
    target[:, 60:80] = 500.0  # a flat occluder: reference columns 65 .. 84 are hidden in the target
    _, causes = causes_of(reference, target)
    occluded = causes.codes[:, 67:83]
    assert share(occluded, MATCHED) < 0.25
    assert share(occluded, LEFT_RIGHT_REJECTED) + share(occluded, NO_MATCH) > 0.75
    assert share(causes.codes[:, 20:55], MATCHED) > 0.9


def test_a_nodata_band_is_nodata_and_only_there():
    reference, target = shifted_pair(5)
    reference = reference.copy()
    reference[10:25] = np.nan
    disparity, causes = causes_of(reference, target)
    assert np.array_equal(causes.codes == NODATA, ~np.isfinite(reference))
    # the rest is classified as without the band: the consistent share of left_right_shares
    valid = np.isfinite(reference)
    _, consistent = left_right_shares(reference, target, disparity, matcher_params("sgbm"), SEARCH)
    assert causes.consistent[valid].sum() / valid.sum() == pytest.approx(consistent)


def test_consistency_per_object():
    labels = np.zeros((4, 6), np.int32)
    labels[:2, :3] = 3
    labels[2:, 3:] = 7
    consistent = np.zeros((4, 6), bool)
    consistent[0, :3] = True  # half of object 3
    valid = np.ones((4, 6), bool)
    valid[3, 3:] = False  # object 7 keeps 3 valid pixels, none consistent
    shares = object_consistency(consistent, valid, labels, [7, 3, 9])
    assert shares[3] == pytest.approx(0.5) and shares[7] == 0.0 and np.isnan(shares[9])
    assert object_consistency(consistent, valid, labels, []) == {}
