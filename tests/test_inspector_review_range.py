"""The Disparity tab's search range and left-right check, the object table's numbers and the
View tab's before/after pictures, without a browser.

Expectations are worked out by hand from the inputs (the margin is 10 % of the span plus
4 px; offsets are written in fixed notation), not read back from the code under test.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy import ndimage

from inspector.before_after import before_after
from inspector.objects import (
    fixed_text,
    grey_decimals,
    object_details,
    object_rows,
    table_markdown,
)
from inspector.overlays import left_out_legend
from inspector.review import review_markdown, review_run
from radcons.errors import InputError, ParamsError
from radcons.evaluate.matching import (
    dense_disparity,
    left_right_shares,
    matcher_params,
    widen_range,
)
from radcons.evaluate.search_range import inlier_disparities, search_range
from radcons.io import Pair, Raster
from radcons.params import Params
from radcons.pipeline import Run
from radcons.results import (
    Association,
    Matches,
    ObjectAssociation,
    ObjectFit,
    ObjectLabels,
    StageImages,
)

ROWS, COLS, SHIFT = 80, 240, 5


def run_like(rectification=None, disparities=None, truth=None, width=COLS):
    """What :func:`search_range` reads of a run: the work pair, the rectification, the matches."""
    association = None
    if disparities is not None:
        xy = np.zeros((len(disparities), 2), np.float32)
        tgt = xy.copy()
        tgt[:, 0] = -np.asarray(disparities, np.float32)  # x_ref - x_tgt = d
        association = SimpleNamespace(matches=Matches(xy, tgt))
    pair = SimpleNamespace(disparity=truth, shape=(ROWS, width))
    return SimpleNamespace(working_pair=pair, rectification=rectification, association=association)


# ----------------------------------------------------------------------------- the search range


def test_the_rectification_range_is_widened_by_a_tenth_of_its_span_and_4_px():
    rectification = SimpleNamespace(disparity_range=(-14.0, 26.0), method="rpc")
    (low, high), source = search_range(run_like(rectification, disparities=[-300.0, 0.0, 700.0]))
    assert (low, high) == pytest.approx((-14 - 8, 26 + 8))  # span 40: 4 + 4 px on each side
    assert "rpc rectification" in source and "-14.0 .. 26.0" in source


def test_matches_lose_their_outliers_then_span_the_1st_to_99th_percentile():
    inliers = np.linspace(-10.0, 20.0, 201)  # 0.15 px apart
    (low, high), source = search_range(run_like(disparities=[*inliers, -300.0, 750.0, 900.0]))
    # 1st and 99th percentile of the inliers: 1 % of their 30 px span in from each end
    p1, p99 = -10.0 + 0.3, 20.0 - 0.3
    margin = 0.1 * (p99 - p1) + 4.0
    assert (low, high) == pytest.approx((p1 - margin, p99 + margin))
    assert "201 SIFT matches" in source


def test_ground_truth_wins_and_nothing_known_gives_an_eighth_of_the_width():
    truth = np.full((ROWS, COLS), np.nan, np.float32)
    truth[5:10, 5:10] = 3.0
    truth[20, 20] = 9.5
    rectification = SimpleNamespace(disparity_range=(-50.0, 50.0), method="affine")
    assert search_range(run_like(rectification, truth=truth))[0] == (1.0, 11.5)
    assert search_range(run_like(width=400))[0] == (-50.0, 50.0)
    assert search_range(run_like(width=40))[0] == (-16.0, 16.0)


def test_inliers_keep_a_flat_scene_and_drop_far_matches():
    flat = np.array([0.0] * 30 + [0.4, -0.4, 500.0, np.nan])
    assert sorted(inlier_disparities(flat)) == [-0.4] + [0.0] * 30 + [0.4]
    assert inlier_disparities(np.array([np.nan])).size == 0


@pytest.mark.parametrize("bad", [(5.0, 1.0), (np.nan, 2.0), (0.0, np.inf)])
def test_a_bad_range_is_refused_in_one_line(bad):
    with pytest.raises(ParamsError, match="finite with high >= low") as error:
        widen_range(bad)
    assert "\n" not in str(error.value)
    with pytest.raises(ParamsError, match="margin must be >= 0"):
        widen_range((0.0, 1.0), share=-0.1)


# ----------------------------------------------------------------------------- the left-right check


def shifted_pair(seed: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """A textured pair with ``reference(x, y) = target(x - SHIFT, y)``."""
    wide = ndimage.gaussian_filter(np.random.default_rng(seed).normal(size=(ROWS, COLS + SHIFT)), 1.3)
    wide = (100 + 800 * (wide - wide.min()) / (wide.max() - wide.min())).astype(np.float32)
    return wide[:, :COLS].copy(), wide[:, SHIFT:].copy()


@pytest.mark.parametrize("matcher", ["sgbm", "census"])
def test_left_right_shares_confirm_the_true_shift(matcher):
    reference, target = shifted_pair()
    params, search = matcher_params(matcher), (0.0, 12.0)
    left = dense_disparity(reference, target, params, search)
    matched, consistent = left_right_shares(reference, target, left, params, search)
    assert matched == pytest.approx(np.isfinite(left).mean())
    assert 0.75 < consistent <= matched


def test_a_wrong_disparity_fails_the_check_unless_census_checked_it_already():
    reference, target = shifted_pair()
    wrong = np.full(reference.shape, SHIFT + 3.0, np.float32)  # every pixel has a disparity, 3 px off
    matched, consistent = left_right_shares(reference, target, wrong, matcher_params("sgbm"), (0.0, 12.0))
    assert matched == 1.0 and consistent < 0.05
    unchecked = matcher_params("census", cross_check="none")
    assert left_right_shares(reference, target, wrong, unchecked, (0.0, 12.0))[1] < 0.05
    # Pandora's accurate cross-check has already removed what fails it: nothing is matched again
    assert left_right_shares(reference, target, wrong, matcher_params("census"), (0.0, 12.0)) == (1.0, 1.0)


def test_left_right_shares_count_over_the_overlap():
    reference, target = shifted_pair()
    reference[:, :120] = np.nan  # half the reference is invalid
    target[:40, :] = np.nan  # and the target's top rows (an epipolar frame's corner)
    params, search = matcher_params("sgbm"), (0.0, 12.0)
    truth = np.full(reference.shape, float(SHIFT), np.float32)
    truth[:40, :] = np.nan  # nothing can match where the target holds no data
    matched, consistent = left_right_shares(reference, target, truth, params, search)
    assert matched == 1.0 and consistent > 0.8
    with pytest.raises(InputError, match="one shape"):
        left_right_shares(reference, target[:, 1:], truth, params, search)


def unrectified_run() -> Run:
    """A pair without ground truth that radcons 'rectified': its range is 3 .. 7 px."""
    reference, target = shifted_pair()
    rectification = SimpleNamespace(disparity_range=(3.0, 7.0), method="affine")
    pair = Pair(Raster(reference), Raster(target), name="no truth")
    results = {
        "rectify": rectification,
        "original": StageImages(reference, target, {}),
        "global": StageImages(reference, 0.5 * target + 40.0, {}),
    }
    return Run(pair=pair, params=Params(), working_pair=pair, results=results, timings={}, cached={})


def test_a_review_without_truth_uses_the_pairs_range_and_compares_on_consistency():
    run, cache = unrectified_run(), {}
    review = review_run(run, "global", cache, (), matcher="sgbm")
    assert review.disparity_range == pytest.approx((3.0 - 4.4, 7.0 + 4.4))
    assert set(review.consistency) == {"original", "global"}
    assert review.consistency["original"].consistent > 0.75
    text = review_markdown(review)
    assert "disparities -1 .. 11 px (the affine rectification's range 3.0 .. 7.0 px" in text
    row = next(line for line in text.splitlines() if line.startswith("| original"))
    consistent, matched = (float(cell) for cell in row.strip("| ").split("|")[1:3])
    assert consistent == pytest.approx(review.consistency["original"].consistent, abs=5e-4)
    assert matched == pytest.approx(np.isfinite(review.original.disparity).mean(), abs=5e-4)
    again = review_run(run, "global", cache, (), matcher="sgbm")
    assert again.consistency["original"] == review.consistency["original"]  # kept in the cache


# ----------------------------------------------------------------------------- numbers of the object table


def test_fixed_text_never_writes_an_exponent():
    assert fixed_text(-1.6e3, 1) == "-1600.0"
    assert fixed_text(123456.789, 1) == "123456.8"
    assert fixed_text(0.012345, 4) == "0.0123"
    assert fixed_text(float("nan"), 1) == fixed_text(None, 3) == "·"


@pytest.mark.parametrize(
    ("top", "decimals"), [(4095.0, 1), (255.0, 1), (65535.0, 1), (1.0, 4), (0.3, 4), (0.01, 6), (1e-6, 6)]
)
def test_grey_decimals_follow_the_images_range(top, decimals):
    image = np.linspace(0.0, top, 10_000, dtype=np.float64).reshape(100, 100)
    assert grey_decimals(image) == decimals


def object_run(offset: float = -1600.0) -> SimpleNamespace:
    """One object pair on a 12-bit pair, fitted ``reference = 2.46 target + offset``."""
    labels = np.zeros((20, 30), np.int32)
    labels[4:12, 6:16] = 1
    reference = np.linspace(0.0, 4095.0, 600, dtype=np.float32).reshape(20, 30)
    reference[labels == 1] = 1234.56
    target = reference * 0.5
    assoc = Association(Matches.empty(), (ObjectAssociation(1, 1, "sift", 0.0, np.arange(0), np.arange(0)),))
    fit = ObjectFit(1, 1, 2.46, offset, np.ones(3), np.ones(3), np.ones(3), True)
    return SimpleNamespace(
        objects=ObjectLabels(labels, labels, "user"), association=assoc, fits=(fit,),
        params=SimpleNamespace(refine=SimpleNamespace(points="invariant")),
        images=lambda stage=None: (reference, target),
    )


def test_object_table_writes_gain_and_offset_in_fixed_notation():
    run = object_run()
    text = table_markdown(object_rows(run), None, has_truth=False, reviewed=False, decimals=grey_decimals(run.images()[0]))
    assert "| 2.460 / -1600.0 |" in text and "e+" not in text
    assert "| 2.460 / -1600.0000 |" in table_markdown(object_rows(run), None, False, False, decimals=4)
    details = object_details(run, 1, "original", run.images()).metrics
    assert "reference ≈ 2.460 × target − 1600.0 (applied)" in details
    assert "| mean grey ref / tgt | 1234.6 / 617.3 |" in details and "e+" not in details


def test_regions_left_out_are_listed_by_rule_with_their_counts():
    codes = np.zeros((40, 40), np.uint8)
    codes[2:5, 2:5] = 1  # two separate tree regions
    codes[20:25, 30:35] = 1
    codes[10:14, 10:20] = 3  # one region no better matched than the ground
    text = left_out_legend(SimpleNamespace(left_out=codes))
    assert "2 × tree:" in text and "1 × no better matched" in text
    assert "too low" not in text and "shadow" not in text  # rules that left nothing out
    assert "none" in left_out_legend(SimpleNamespace(left_out=np.zeros((4, 4), np.uint8)))
    assert left_out_legend(SimpleNamespace()) == ""


# ----------------------------------------------------------------------------- before / after


def test_anaglyph_is_red_reference_cyan_target_and_differences_share_one_scale():
    reference = np.tile(np.linspace(0.0, 100.0, 64, dtype=np.float32), (32, 1))
    target = reference + 20.0  # brighter by 20 grey levels everywhere
    target[:, :4] = np.nan
    drawn = before_after((reference, target), (reference, reference.copy()), "global")
    red, green, blue = (drawn.original[..., channel].astype(int) for channel in range(3))
    assert np.array_equal(green, blue)
    assert (green[:, 8:] > red[:, 8:]).all()  # the brighter target: cyan wins
    assert (green[:, :4] == 0).all() and (red[:, :4] > 0).any()  # no target there: only the red reference
    after = drawn.shown.astype(int)
    assert np.array_equal(after[..., 0], after[..., 1]) and np.array_equal(after[..., 1], after[..., 2])  # grey
    half = (drawn.difference.shape[1] - 6) // 2
    before_picture, after_picture = drawn.difference[:, :half], drawn.difference[:, -half:]
    assert before_picture[:, 8:].mean() > 100 and after_picture.mean() < 5  # one scale: no difference is black
    # grey levels over a range of about 100: two decimals
    assert "original (left) | **global** (right)" in drawn.caption and "mean 20.00 → 0.00" in drawn.caption
    with pytest.raises(ValueError, match="one shape"):
        before_after((reference, target), (reference[:, 1:], reference[:, 1:]), "global")


def test_evaluate_searches_the_pairs_own_range_not_the_raw_matches(monkeypatch):
    """``radcons evaluate`` on a pair without truth: the matches of two dates hundreds of
    pixels off must not spread the range every method is matched over."""
    import radcons.workflow as workflow
    from radcons.evaluate.matching import MatcherParams

    rng = np.random.default_rng(3)
    image = rng.uniform(0.0, 255.0, (64, 96)).astype(np.float32)
    ref_x = rng.uniform(10.0, 80.0, 60)
    shifts = np.r_[rng.uniform(2.0, 8.0, 57), -300.0, 450.0, 700.0]
    rows_ = rng.uniform(5.0, 60.0, 60)
    matches = Matches(np.c_[ref_x, rows_].astype(np.float32), np.c_[ref_x - shifts, rows_].astype(np.float32))
    pair = Pair(Raster(image), Raster(image.copy()), name="no-truth")
    labels = np.zeros(image.shape, np.int32)
    results = {
        "original": StageImages(image, image, {}),
        "objects": ObjectLabels(labels, labels, "user"),
        "association": Association(matches, ()),
    }
    run = Run(pair=pair, params=Params(), working_pair=pair, results=results, timings={}, cached={})
    seen = {}

    def fake_evaluate(pair, images, object_pairs, matchers, disparity_range=None, normalise_seconds=None):
        seen["range"] = disparity_range
        return None

    monkeypatch.setattr(workflow, "evaluate_matchers", fake_evaluate)
    workflow.evaluate_run_matchers(run, ["original"], [MatcherParams()])
    low, high = seen["range"]
    assert (low, high) == search_range(run)[0]
    assert -5.0 < low < 2.0 and 8.0 < high < 16.0  # 2 .. 8 px widened by 10 % + 4 px, outliers gone
