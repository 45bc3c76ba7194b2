"""Dense matching (sign convention, known disparities), correct-matching rates, comparisons."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import ndimage

from radcons.numerics.census import CensusParams
from radcons.errors import InputError, ParamsError
from radcons.evaluate.compare import baseline_images, evaluate_matchers, evaluate_methods
from radcons.evaluate.matching import (
    MatcherParams,
    dense_disparity,
    disparity_range_from_matches,
    disparity_range_from_truth,
    to_uint8_pair,
)
from radcons.evaluate.rates import correct_matching_rate, object_matching_rates
from radcons.io import Pair, Raster
from radcons.results import Matches

SIZE = 128


def texture(rows: int, cols: int, seed: int = 0) -> np.ndarray:
    """Random texture with structure at a few pixels, values about 100..900."""
    rng = np.random.default_rng(seed)
    field = ndimage.gaussian_filter(rng.normal(size=(rows, cols)), 1.2)
    return (500.0 + 400.0 * field / np.abs(field).max()).astype(np.float32)


def piecewise_pair(d_top: int = 4, d_bottom: int = 11) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reference, target and ground truth with ``reference(x, y) = target(x - d, y)``.

    The top half moves by ``d_top`` px, the bottom half by ``d_bottom`` px; columns whose
    match falls outside the target have unknown (NaN) ground truth.
    """
    wide = texture(SIZE, SIZE + 64)
    reference = wide[:, 32:32 + SIZE].copy()
    target = np.empty_like(reference)
    truth = np.empty(reference.shape, np.float32)
    half = SIZE // 2
    for rows, d in ((slice(0, half), d_top), (slice(half, SIZE), d_bottom)):
        # target(x') = wide(x' + 32 + d), so target(x - d) = wide(x + 32) = reference(x)
        target[rows] = wide[rows, 32 + d:32 + d + SIZE]
        truth[rows] = d
    columns = np.arange(SIZE)[None, :]
    truth[(columns - truth < 0) | (columns - truth >= SIZE)] = np.nan
    return reference, target, truth


# ----------------------------------------------------------------------------- rates


def test_rate_of_exact_disparity_is_one():
    truth = np.full((20, 30), 7.5, np.float32)
    truth[:, :5] = np.nan
    assert correct_matching_rate(truth.copy(), truth) == 1.0
    assert correct_matching_rate(truth + 0.9, truth) == 1.0


def test_rate_of_partly_shifted_disparity():
    truth = np.full((20, 30), 3.0, np.float32)
    truth[:, :5] = np.nan  # 20 x 25 = 500 known pixels
    disparity = truth.copy()
    disparity[:, 5:15] += 2.0  # 200 of them wrong by 2 px
    disparity[:, 0:5] = 100.0  # wrong where the truth is unknown: not counted
    assert correct_matching_rate(disparity, truth) == pytest.approx(300 / 500)
    mask = np.zeros(truth.shape, bool)
    mask[:10, 10:20] = True  # 50 known pixels wrong (cols 10-14), 50 right
    assert correct_matching_rate(disparity, truth, mask) == pytest.approx(0.5)
    assert correct_matching_rate(disparity, truth, threshold=2.5) == 1.0


def test_failed_pixels_count_as_wrong_and_threshold_is_strict():
    truth = np.zeros((10, 10), np.float32)
    disparity = np.zeros((10, 10), np.float32)
    disparity[:3] = np.nan  # 30 failed
    disparity[3, :] = 1.0  # error exactly 1 px: not below 1
    assert correct_matching_rate(disparity, truth) == pytest.approx(60 / 100)
    assert np.isnan(correct_matching_rate(disparity, np.full_like(truth, np.nan)))


def test_object_rates():
    truth = np.zeros((10, 10), np.float32)
    disparity = truth.copy()
    labels = np.zeros((10, 10), np.int32)
    labels[:5, :5] = 1
    labels[5:, 5:] = 2
    disparity[:5, :2] = 5.0  # 10 of object 1's 25 pixels wrong
    assert object_matching_rates(disparity, truth, labels) == {1: pytest.approx(0.6), 2: 1.0}


def test_rate_input_errors():
    with pytest.raises(InputError):
        correct_matching_rate(np.zeros((3, 3)), np.zeros((3, 4)))
    with pytest.raises(ParamsError):
        correct_matching_rate(np.zeros((3, 3)), np.zeros((3, 3)), threshold=0)


# ----------------------------------------------------------------------------- matching


def test_uint8_mapping_is_the_references_robust_range_for_both_images():
    reference = np.linspace(0.0, 1000.0, 1001, dtype=np.float32).reshape(7, 143)
    reference[0, 0] = np.nan
    target = np.array([[5.0, 500.0, 995.0, 5000.0, -30.0]], np.float32)
    left, right = to_uint8_pair(reference, target)
    low, high = np.percentile(reference[np.isfinite(reference)], [0.5, 99.5])
    expected = np.clip(np.rint((target - low) * 255.0 / (high - low)), 0, 255)
    np.testing.assert_array_equal(right, expected)
    assert right[0, 3] == 255 and right[0, 4] == 0  # outliers clip, they do not rescale
    # an outlier in the target does not change how the reference is mapped
    np.testing.assert_array_equal(to_uint8_pair(reference, target * 10)[0], left)
    assert left[0, 0] == 0 and left[3, 71] == np.rint((reference[3, 71] - low) * 255.0 / (high - low))


@pytest.mark.parametrize("method", ["sgbm", "bm"])
def test_recovers_piecewise_disparity_with_sign(method):
    reference, target, truth = piecewise_pair(4, 11)
    params = MatcherParams(method=method, block_size=5 if method == "sgbm" else 9)
    disparity = dense_disparity(reference, target, params, disparity_range=(0, 15))
    assert disparity.dtype == np.float32 and disparity.shape == reference.shape
    assert correct_matching_rate(disparity, truth) > (0.85 if method == "sgbm" else 0.75)
    # well inside each half the disparity is the known one, positive
    assert np.nanmedian(disparity[8:56, 40:120]) == pytest.approx(4.0, abs=0.25)
    assert np.nanmedian(disparity[72:120, 40:120]) == pytest.approx(11.0, abs=0.25)


def test_negative_disparity_and_radiometric_difference():
    reference, target, truth = piecewise_pair(-6, -6)
    target = 0.5 * target + 40.0  # one mapping to 8 bits keeps this difference visible
    disparity = dense_disparity(reference, target, MatcherParams(), disparity_range=(-10.0, 0.0))
    assert np.nanmedian(disparity) == pytest.approx(-6.0, abs=0.25)
    assert correct_matching_rate(disparity, truth) > 0.85


def test_invalid_pixels_give_nan():
    reference, target, truth = piecewise_pair(5, 5)
    reference[10:20, 60:70] = np.nan
    target[40:50, 60:70] = np.nan  # seen from reference columns 65..74
    disparity = dense_disparity(reference, target, MatcherParams(), disparity_range=(0, 10))
    assert np.isnan(disparity[10:20, 60:70]).all()
    assert np.isnan(disparity[40:50, 66:74]).all()
    rows, cols = np.nonzero(np.isfinite(disparity))
    matched = np.rint(cols - disparity[rows, cols]).astype(int)
    assert np.isfinite(target[rows, matched]).all()
    assert correct_matching_rate(disparity, truth) > 0.8


def test_matcher_params_and_ranges():
    with pytest.raises(ParamsError):
        MatcherParams(method="census")
    with pytest.raises(ParamsError):
        MatcherParams(block_size=4)
    with pytest.raises(ParamsError):
        dense_disparity(np.zeros((8, 8)), np.ones((8, 8)), MatcherParams())
    truth = np.array([[np.nan, 3.0], [12.5, 7.0]])
    assert disparity_range_from_truth(truth, margin=1.0) == (2.0, 13.5)
    matches = Matches(
        np.array([[10, 0], [20, 1], [30, 2], [40, 3]], np.float32),
        np.array([[4, 0], [12, 1], [22, 2], [31, 3]], np.float32),
    )  # disparities 6, 8, 8, 9
    assert disparity_range_from_matches(matches, margin=2.0, quantile=0.0) == (4.0, 11.0)
    with pytest.raises(InputError):
        disparity_range_from_matches(Matches.empty())


# ----------------------------------------------------------------------------- comparison


def comparison_pair() -> Pair:
    reference, target, truth = piecewise_pair(4, 11)
    labels_ref = np.zeros(reference.shape, np.int32)
    labels_ref[10:50, 30:90] = 1
    labels_ref[80:120, 40:100] = 2
    labels_tgt = np.zeros(reference.shape, np.int32)
    labels_tgt[10:50, 26:86] = 1
    labels_tgt[80:120, 29:89] = 2
    return Pair(
        Raster(reference), Raster(target), disparity=truth,
        reference_objects=labels_ref, target_objects=labels_tgt, name="synthetic",
    )


def test_evaluate_methods_table_and_json():
    pair = comparison_pair()
    reference, target = pair.reference.data, pair.target.data
    noise = np.random.default_rng(5).uniform(100, 900, target.shape).astype(np.float32)
    images = {"original": (reference, target), "scrambled": (reference, noise)}
    comparison = evaluate_methods(pair, images, matcher=MatcherParams())
    assert comparison.object_pairs == ((1, 1), (2, 2))
    original, scrambled = comparison.method("original"), comparison.method("scrambled")
    # the target's objects are the reference's objects moved: identical histograms
    assert original.similarity == {1: 1.0, 2: 1.0}
    assert original.correct_rate > 0.85 and scrambled.correct_rate < 0.2
    assert set(original.object_rates) == {1, 2} and min(original.object_rates.values()) > 0.85
    assert original.disparity.shape == reference.shape
    table = comparison.format_table()
    assert "original" in table and "scrambled" in table and "mean" in table and "all pixels" in table
    document = json.loads(json.dumps(comparison.to_json_dict()))
    assert document["methods"]["original"]["similarity"] == {"1": 1.0, "2": 1.0}
    assert "disparity" not in document["methods"]["original"]


def test_evaluate_matchers_measures_each_matcher_and_shares_the_rest():
    pair = comparison_pair()
    reference, target = pair.reference.data, pair.target.data
    noise = np.random.default_rng(5).uniform(100, 900, target.shape).astype(np.float32)
    squeezed = (500.0 + 0.5 * (target - target.min()) / (target.max() - target.min())).astype(np.float32)
    images = {"original": (reference, target), "squeezed": (reference, squeezed), "scrambled": (reference, noise)}
    evaluation = evaluate_matchers(pair, images, matchers=(MatcherParams(), CensusParams()))
    sgbm, census = evaluation.comparisons["sgbm"], evaluation.comparisons["census"]
    assert evaluation.first is sgbm and census.matcher == CensusParams()
    assert sgbm.disparity_range == census.disparity_range
    for comparison in (sgbm, census):
        assert comparison.method("original").correct_rate > 0.85 and comparison.method("scrambled").correct_rate < 0.2
    # grey levels squeezed into half a level: an increasing map census ignores, SGBM's 8 bits do not
    assert census.method("squeezed").correct_rate > 0.85 > 0.3 > sgbm.method("squeezed").correct_rate
    assert census.method("squeezed").similarity is sgbm.method("squeezed").similarity  # measured once
    document = json.loads(json.dumps(evaluation.to_json_dict()))
    assert list(document["matchers"]) == ["sgbm", "census"]
    rates = document["matchers"]["census"]["methods"]["squeezed"]
    assert rates["rate_all"] == pytest.approx(census.method("squeezed").correct_rate)
    assert rates["rate_objects"] == pytest.approx(census.method("squeezed").mean_object_rate)
    assert document["methods"]["original"]["similarity"] == {"1": 1.0, "2": 1.0}
    table = evaluation.format_table()
    assert "correct-matching rate, sgbm" in table and "correct-matching rate, census" in table
    assert table.count("object similarity C") == 1
    with pytest.raises(ParamsError, match="distinct"):
        evaluate_matchers(pair, images, matchers=(CensusParams(), CensusParams(p2=40.0)))


def test_evaluate_without_ground_truth_needs_a_range():
    pair = comparison_pair()
    pair.disparity = None
    images = {"original": (pair.reference.data, pair.target.data)}
    with pytest.raises(ParamsError, match="disparity range"):
        evaluate_methods(pair, images)
    comparison = evaluate_methods(pair, images, [(2, 2)], disparity_range=(0, 15))
    result = comparison.method("original")
    assert result.correct_rate is None and result.object_rates == {} and set(result.similarity) == {2}
    assert "correct-matching" not in comparison.format_table()


def test_baseline_images_and_unknown_names():
    pair = comparison_pair()
    seconds: dict[str, float] = {}
    images = baseline_images(pair, ["meanstd", "histmatch"], seconds)
    assert list(images) == ["meanstd", "histmatch"] and set(seconds) == {"meanstd", "histmatch"}
    reference, normalised = images["meanstd"]
    assert reference is not None and normalised.dtype == np.float32
    with pytest.raises(ParamsError, match="unknown baseline"):
        baseline_images(pair, ["magic"])
