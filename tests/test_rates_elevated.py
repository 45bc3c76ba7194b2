"""The correct-matching rate over the pixels away from zero disparity (``elevated_mask``)."""

from __future__ import annotations

import numpy as np
import pytest

from radcons.errors import ParamsError
from radcons.evaluate.rates import correct_matching_rate, elevated_mask

NAN = float("nan")

#: Ground truth of a 3 x 4 tile: flat ground near zero, a roof at +5 / +6, a pit at -4,
#: values exactly on the margin (3, -3) and two unknown pixels.
TRUTH = np.array(
    [
        [0.0, 1.0, 3.0, -3.0],
        [5.0, 6.0, 5.0, NAN],
        [-4.0, 2.5, NAN, 3.5],
    ],
    np.float32,
)

#: A matched disparity: NaN where matching failed.
DISPARITY = np.array(
    [
        [0.0, 0.0, 0.0, 0.0],
        [5.5, 3.5, NAN, 1.0],
        [-4.0, 2.0, 7.0, 1.0],
    ],
    np.float32,
)


def test_mask_keeps_pixels_strictly_beyond_the_margin() -> None:
    expected = np.array(
        [
            [False, False, False, False],  # 3 and -3 lie on the margin, not beyond it
            [True, True, True, False],  # NaN: unknown, left out
            [True, False, False, True],
        ]
    )
    np.testing.assert_array_equal(elevated_mask(TRUTH, 3.0), expected)


def test_rates_over_elevated_pixels_match_hand_count() -> None:
    # elevated pixels, by hand: (1,0) 5 vs 5.5 -> err 0.5; (1,1) 6 vs 3.5 -> 2.5;
    # (1,2) 5 vs NaN -> failed, wrong; (2,0) -4 vs -4 -> 0; (2,3) 3.5 vs 1 -> 2.5.
    # within 1 px: (1,0), (2,0) -> 2 of 5; within 3 px: all but (1,2) -> 4 of 5.
    mask = elevated_mask(TRUTH, 3.0)
    assert correct_matching_rate(DISPARITY, TRUTH, mask, threshold=1.0) == pytest.approx(2 / 5)
    assert correct_matching_rate(DISPARITY, TRUTH, mask, threshold=3.0) == pytest.approx(4 / 5)


def test_zero_disparity_is_wrong_on_every_elevated_pixel() -> None:
    # over all 10 known pixels zero disparity is within 3 px of 0, 1 and 2.5 (3 and -3
    # are not: the tolerance is exclusive); over the elevated ones it is never right
    zero = np.zeros_like(TRUTH)
    assert correct_matching_rate(zero, TRUTH, threshold=3.0) == pytest.approx(3 / 10)
    assert correct_matching_rate(zero, TRUTH, elevated_mask(TRUTH, 3.0), threshold=3.0) == 0.0


def test_margin_zero_keeps_every_known_nonzero_pixel() -> None:
    assert int(np.count_nonzero(elevated_mask(TRUTH, 0.0))) == 9  # 10 known, one of them 0


def test_no_elevated_pixel_gives_nan() -> None:
    flat = np.array([[0.0, 1.0], [-2.0, NAN]], np.float32)
    rate = correct_matching_rate(np.zeros_like(flat), flat, elevated_mask(flat, 3.0), threshold=3.0)
    assert np.isnan(rate)


@pytest.mark.parametrize("margin", [-1.0, float("inf"), NAN])
def test_bad_margin_is_refused(margin: float) -> None:
    with pytest.raises(ParamsError):
        elevated_mask(TRUTH, margin)
