"""Refined object-oriented normalisation (eq 7-11)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.ndimage

from radcons.errors import InputError, ParamsError
from radcons.results import Association, Matches, ObjectAssociation
from radcons.stages.refine.light import local_light_correction
from radcons.stages.refine.run import (
    RefineParams,
    clipped_mask,
    fit_moments,
    fit_object,
    histogram_mapping,
    object_agreement,
    refine_target,
)


def test_fit_recovers_exact_gain_and_offset():
    x = np.linspace(20, 200, 25)
    gain, offset, weights = fit_object(x, 1.7 * x + 12.0)
    assert gain == pytest.approx(1.7)
    assert offset == pytest.approx(12.0)
    np.testing.assert_allclose(weights, 1.0)  # every standardised difference is zero


def test_weights_reduce_the_influence_of_outliers_compared_with_plain_least_squares():
    rng = np.random.default_rng(0)
    x = rng.uniform(30, 220, 30)
    y = 2.0 * x + 5.0 + rng.normal(0, 1.0, x.size)
    x = np.concatenate([x, [60.0, 90.0, 200.0]])
    y = np.concatenate([y, [400.0, 420.0, 60.0]])  # three changed / mismatched points
    gain, offset, weights = fit_object(x, y)
    ls_gain, ls_offset = np.polyfit(x, y, 1)
    assert abs(gain - 2.0) < abs(ls_gain - 2.0)
    assert abs(offset - 5.0) < abs(ls_offset - 5.0)
    assert weights[-3:].max() < np.median(weights[:-3])


def test_weights_follow_eq_11():
    rng = np.random.default_rng(1)
    x = rng.uniform(0, 100, 12)
    y = 0.5 * x + rng.normal(0, 5, 12)
    _, _, weights = fit_object(x, y)
    t = np.abs((y - y.mean()) / y.std() - (x - x.mean()) / x.std())
    np.testing.assert_allclose(weights, 1 - (t - t.min()) / (t.max() - t.min()))
    assert weights.min() == 0.0 and weights.max() == 1.0


def test_constant_target_values_give_a_pure_offset():
    gain, offset, weights = fit_object(np.full(5, 50.0), np.array([60.0, 62.0, 61.0, 59.0, 63.0]))
    assert gain == 1.0
    assert 9.0 <= offset <= 13.0
    assert np.all((weights >= 0) & (weights <= 1))
    gain, offset, _ = fit_object(np.full(4, 50.0), np.full(4, 70.0))
    assert (gain, offset) == (1.0, 20.0)


def test_fit_rejects_bad_input():
    with pytest.raises(InputError):
        fit_object(np.zeros(3), np.zeros(4))
    with pytest.raises(InputError):
        fit_object(np.zeros(0), np.zeros(0))
    with pytest.raises(InputError):
        fit_object(np.array([1.0, np.nan]), np.array([1.0, 2.0]))
    with pytest.raises(ParamsError):
        RefineParams(min_points=1)
    with pytest.raises(ParamsError):
        RefineParams(gain_range=(1.5, 3.0))
    with pytest.raises(ParamsError):
        RefineParams(points="all")
    with pytest.raises(ParamsError, match="max_clipped"):
        RefineParams(max_clipped=1.5)


# ------------------------------------------------------------------ refine_target


def _scene(n=96, gain=1.5, offset=-20.0):
    """Reference ramp; target = reference mapped by the inverse line inside one object."""
    yy, xx = np.mgrid[0:n, 0:n]
    reference = (80.0 + 0.5 * xx + 0.3 * yy + 3 * np.sin(xx / 3.0) * np.cos(yy / 4.0)).astype(np.float32)
    labels = np.zeros((n, n), np.int32)
    labels[30:70, 20:75] = 1
    target = reference.copy()
    inside = labels == 1
    target[inside] = (reference[inside] - offset) / gain
    return reference, target, labels


def _association(points, ref_id=1, tgt_id=1, n_points=None):
    xy = np.asarray(points, np.float32)
    matches = Matches(xy.copy(), xy.copy())
    idx = np.arange(len(xy) if n_points is None else n_points)
    return Association(matches, (ObjectAssociation(ref_id, tgt_id, "sift", 0.0, idx, idx),))


_POINTS = [(25, 35), (40, 40), (60, 45), (70, 50), (30, 60), (50, 65), (65, 33), (45, 55)]


def test_refine_maps_the_object_back_and_leaves_the_rest_untouched():
    reference, target, labels = _scene()
    refined, fits = refine_target(reference, target, labels, _association(_POINTS), RefineParams(blend_width=3.0))
    (fit,) = fits
    assert fit.applied and fit.n_points == len(_POINTS)
    assert fit.gain == pytest.approx(1.5, rel=1e-4)
    assert fit.offset == pytest.approx(-20.0, abs=1e-2)
    core = np.zeros_like(labels, bool)
    core[34:66, 24:71] = True  # farther than blend_width from the object's border
    np.testing.assert_allclose(refined[core], reference[core], atol=1e-2)
    outside = labels == 0
    assert np.array_equal(refined[outside], target[outside])


def test_feathering_leaves_no_seam_at_the_object_border():
    """The correction (refined - global) must not jump at the border, as a hard one does."""
    reference, target, labels = _scene()
    association = _association(_POINTS)
    hard, _ = refine_target(reference, target, labels, association, RefineParams(blend_width=0.0))
    soft, _ = refine_target(reference, target, labels, association, RefineParams(blend_width=4.0))

    def largest_jump(field, across_border):
        jumps = []
        for a, b, la, lb in (
            (field[:, :-1], field[:, 1:], labels[:, :-1], labels[:, 1:]),
            (field[:-1, :], field[1:, :], labels[:-1, :], labels[1:, :]),
        ):
            jumps.append(np.abs(a - b)[(la != lb) == across_border])
        return np.concatenate(jumps).max()

    hard_jump = largest_jump(hard - target, True)
    assert hard_jump > 20.0  # the correction is about 40 grey levels here
    assert largest_jump(soft - target, True) < 0.3 * hard_jump
    # nowhere inside does the feathered correction step by more than a quarter of it
    assert largest_jump(soft - target, False) < 0.3 * hard_jump


def test_objects_with_too_few_points_are_untouched():
    reference, target, labels = _scene()
    refined, fits = refine_target(reference, target, labels, _association(_POINTS, n_points=2))
    assert not fits[0].applied
    assert (fits[0].gain, fits[0].offset) == (1.0, 0.0)
    assert np.array_equal(refined, target)


def test_object_without_target_partner_is_untouched():
    reference, target, labels = _scene()
    refined, fits = refine_target(reference, target, labels, _association(_POINTS, tgt_id=0))
    assert not fits[0].applied
    assert np.array_equal(refined, target)


def test_one_fit_per_target_object_the_one_with_most_points():
    reference, target, labels = _scene()
    xy = np.asarray(_POINTS, np.float32)
    matches = Matches(xy.copy(), xy.copy())
    few, many = np.arange(3), np.arange(len(xy))
    association = Association(
        matches,
        (
            ObjectAssociation(1, 1, "sift", 0.0, few, few),
            ObjectAssociation(2, 1, "sift", 0.0, many, many),
        ),
    )
    _, fits = refine_target(reference, target, labels, association)
    assert [f.applied for f in fits] == [False, True]


def test_nan_pixels_stay_nan_and_nan_points_are_dropped():
    reference, target, labels = _scene()
    target[50, 50] = np.nan
    points = _POINTS + [(50, 50)]
    refined, fits = refine_target(reference, target, labels, _association(points))
    assert np.isnan(refined[50, 50])
    assert np.isnan(refined).sum() == 1
    assert fits[0].n_points == len(_POINTS)


def test_shape_mismatch_raises():
    reference, target, labels = _scene()
    with pytest.raises(InputError, match="shape"):
        refine_target(reference, target, labels[:-1], _association(_POINTS))


def test_dense_points_fit_a_template_object_through_its_disparity():
    n, d = 96, 7
    yy, xx = np.mgrid[0:n, 0:n]
    reference = (90.0 + 0.4 * xx + 20 * np.sin(xx / 5.0) * np.cos(yy / 7.0)).astype(np.float32)
    labels_tgt = np.zeros((n, n), np.int32)
    labels_tgt[30:70, 20:60] = 1
    target = np.roll(reference, -d, axis=1)  # target(x) = reference(x + d)
    inside = labels_tgt == 1
    target[inside] = (target[inside] - 12.0) / 1.25
    association = Association(
        Matches.empty(),
        (ObjectAssociation(1, 1, "template", float(d), np.zeros(0, np.int64), np.zeros(0, np.int64), 0.9),),
    )
    paper, paper_fits = refine_target(reference, target, labels_tgt, association)
    assert not paper_fits[0].applied and np.array_equal(paper, target)
    dense, (fit,) = refine_target(reference, target, labels_tgt, association, RefineParams(points="dense"))
    assert fit.applied and fit.n_points > 500
    assert fit.gain == pytest.approx(1.25, rel=1e-4)
    assert fit.offset == pytest.approx(12.0, abs=1e-2)
    core = np.zeros_like(inside)
    core[36:64, 26:54] = True
    np.testing.assert_allclose(dense[core], np.roll(reference, -d, axis=1)[core], atol=1e-2)


# ------------------------------------------------------------------ moments fit, histogram background


def test_moments_fit_recovers_an_exact_line():
    x = np.linspace(20, 200, 25)
    gain, offset, weights = fit_moments(x, 1.7 * x + 12.0)
    assert gain == pytest.approx(1.7)
    assert offset == pytest.approx(12.0)
    np.testing.assert_array_equal(weights, 1.0)


def test_moments_fit_keeps_the_gain_that_misregistration_dilutes_in_least_squares():
    """Point pairs a little apart along the texture: least squares' gain is the true gain
    times the correlation of the shifted texture; the moments gain is the true one."""
    t = np.arange(0, 2 * np.pi * 20, 0.05)  # whole periods of the texture
    texture = np.sin(3 * t) + 0.5 * np.cos(7 * t)
    y = 2.0 * texture[:-4] + 5.0  # reference
    x = texture[4:]  # target, 0.2 rad further along: misregistered
    correlation = np.corrcoef(x, y)[0, 1]
    ls_gain = np.polyfit(x, y, 1)[0]
    assert ls_gain == pytest.approx(2.0 * correlation, rel=1e-2)  # regression dilution
    assert ls_gain < 1.6
    gain, offset, _ = fit_moments(x, y)
    assert gain == pytest.approx(2.0, rel=1e-3)
    assert offset == pytest.approx(5.0, abs=1e-2)
    wls_gain, _, _ = fit_object(x, y)
    assert abs(wls_gain - 2.0) > 10 * abs(gain - 2.0)


def test_moments_fit_of_constant_target_values_is_a_pure_offset():
    gain, offset, _ = fit_moments(np.full(6, 50.0), np.array([60.0, 62.0, 61.0, 59.0, 63.0, 61.0]))
    assert (gain, offset) == (1.0, pytest.approx(11.0))


def test_moments_fit_rejects_bad_input():
    with pytest.raises(InputError):
        fit_moments(np.zeros(3), np.zeros(4))
    with pytest.raises(InputError):
        fit_moments(np.zeros(0), np.zeros(0))
    with pytest.raises(InputError):
        fit_moments(np.array([1.0, np.inf]), np.array([1.0, 2.0]))
    with pytest.raises(ParamsError, match="fit"):
        RefineParams(fit="ols")
    with pytest.raises(ParamsError, match="background"):
        RefineParams(background="quantile")


def test_histogram_mapping_undoes_a_monotone_grey_level_change():
    rng = np.random.default_rng(3)
    reference = rng.permutation(np.linspace(10.0, 240.0, 64 * 64)).reshape(64, 64).astype(np.float32)
    target = (255.0 * (reference / 255.0) ** 0.6 * 0.8 + 15.0).astype(np.float32)  # gamma, gain, offset
    target[5, 7] = np.nan
    mapped = histogram_mapping(reference, target)
    assert np.isnan(mapped[5, 7]) and np.isnan(mapped).sum() == 1
    # one pixel fewer in the target: each value lands within one quantile step of its own
    step = 230.0 / (64 * 64 - 1)
    np.testing.assert_allclose(mapped[np.isfinite(mapped)], reference[np.isfinite(mapped)], atol=1.01 * step)


def test_dense_moments_fit_a_misregistered_object_where_least_squares_flattens_it():
    """D̄m 1 px off the true disparity (a slanted roof): the moments line keeps the gain."""
    n, d = 128, 7
    yy, xx = np.mgrid[0:n, 0:n]
    reference = (120.0 + 40 * np.sin(xx / 1.5) * np.cos(yy / 9.0) + 0.2 * xx).astype(np.float32)
    labels_tgt = np.zeros((n, n), np.int32)
    labels_tgt[30:100, 20:90] = 1
    target = np.roll(reference, -d, axis=1)
    inside = labels_tgt == 1
    target[inside] = (target[inside] - 12.0) / 1.25
    association = Association(
        Matches.empty(),
        (ObjectAssociation(1, 1, "template", float(d + 1), np.zeros(0, np.int64), np.zeros(0, np.int64), 0.9),),
    )
    _, (wls,) = refine_target(reference, target, labels_tgt, association, RefineParams(points="dense"))
    _, (moments,) = refine_target(
        reference, target, labels_tgt, association, RefineParams(points="dense", fit="moments")
    )
    assert moments.applied and moments.gain == pytest.approx(1.25, rel=0.03)
    assert wls.gain < 0.9 * 1.25


def test_histogram_background_maps_the_pixels_outside_the_fitted_objects():
    reference, target, labels = _scene()
    target = target.copy()
    outside = labels == 0
    target[outside] = 0.5 * reference[outside] + 30.0  # a date difference the scalar of eq 5 leaves
    params = RefineParams(background="histogram", blend_width=0.0)
    refined, (fit,) = refine_target(reference, target, labels, _association(_POINTS), params)
    assert fit.applied and fit.gain == pytest.approx(1.5, rel=1e-3)
    inside = labels == 1
    np.testing.assert_allclose(refined[inside], reference[inside], atol=0.05)
    np.testing.assert_array_equal(refined[outside], histogram_mapping(reference, target)[outside])
    # the background now has the reference's grey levels, as the global result did not
    before = np.abs(target[outside] - reference[outside]).mean()
    assert np.abs(refined[outside] - reference[outside]).mean() < 0.1 * before


def test_clip_to_reference_keeps_the_refined_target_in_the_reference_range():
    reference, target, labels = _scene()
    target = target.copy()
    target[60, 60] = 400.0  # a glare pixel in the object: its line throws it far out
    target[5, 5] = np.nan
    association = _association(_POINTS)
    loose, _ = refine_target(reference, target, labels, association, RefineParams(blend_width=0.0))
    assert loose[60, 60] > reference.max() + 100
    params = RefineParams(blend_width=0.0, clip_to_reference=True)
    clipped, _ = refine_target(reference, target, labels, association, params)
    expected = np.clip(loose, reference.min(), reference.max())
    np.testing.assert_array_equal(clipped, expected)
    assert clipped[60, 60] == reference.max() and np.isnan(clipped[5, 5])


# ------------------------------------------------------------------ clipped pixels


def test_clipped_mask_finds_the_extremes_where_they_pile_up():
    rng = np.random.default_rng(4)
    image = rng.uniform(10.0, 240.0, (100, 100)).astype(np.float32)  # extremes held once
    assert not clipped_mask(image).any()
    image[10:15, 20:30] = 255.0  # a bright roof clipped: 50 pixels at the top value
    image[60:62, 0:10] = 0.0  # a shadow clipped: 20 pixels at the bottom value
    image[0:3, 90] = 250.0  # 3 pixels at one value below the top: not a clipping level
    image[99, 99] = np.nan
    expected = np.zeros(image.shape, bool)
    expected[10:15, 20:30] = expected[60:62, 0:10] = True
    np.testing.assert_array_equal(clipped_mask(image), expected)
    image[60:62, 0:10] = 5.0  # a clipping level need not be 0

    np.testing.assert_array_equal(clipped_mask(image), expected)
    image[60:61, 0:10] = 7.0  # 10 pixels left at the minimum: fewer than 16, not clipping
    expected[60:62, 0:10] = False
    np.testing.assert_array_equal(clipped_mask(image), expected)
    assert not clipped_mask(np.full((8, 8), np.nan, np.float32)).any()


def _clipped_scene(share):
    """The dense-point scene (disparity 0) with the target clipped at the grey value above
    which ``share`` of the object's pixels lie; the true line is gain 1.5, offset -20."""
    reference, target, labels = _scene()
    inside = labels == 1
    level = np.quantile(target[inside], 1.0 - share)
    clipped = np.minimum(target, np.float32(level))
    association = Association(
        Matches.empty(),
        (ObjectAssociation(1, 1, "template", 0.0, np.zeros(0, np.int64), np.zeros(0, np.int64), 0.9),),
    )
    return reference, clipped, labels, association


def test_points_on_clipped_pixels_are_left_out_of_the_fit():
    reference, target, labels, association = _clipped_scene(0.2)
    params = RefineParams(points="dense", blend_width=0.0)
    blind = (np.zeros(target.shape, bool), np.zeros(target.shape, bool))
    _, (biased,) = refine_target(reference, target, labels, association, params, blind)
    assert biased.clipped == 0 and abs(biased.gain - 1.5) > 0.05  # the clipped roof bends the line
    refined, (fit,) = refine_target(reference, target, labels, association, params)
    assert fit.applied and fit.note == ""
    n_object = fit.n_points + fit.clipped
    assert fit.clipped == pytest.approx(0.2 * n_object, rel=0.15)
    assert fit.gain == pytest.approx(1.5, rel=1e-4)
    assert fit.offset == pytest.approx(-20.0, abs=1e-2)
    unclipped = (labels == 1) & ~clipped_mask(target)
    np.testing.assert_allclose(refined[unclipped], reference[unclipped], atol=1e-2)


def test_a_mostly_clipped_object_gets_an_offset_only():
    reference, target, labels, association = _clipped_scene(0.7)
    refined, (fit,) = refine_target(
        reference, target, labels, association, RefineParams(points="dense", blend_width=0.0)
    )
    # the dense points: the object 2 px inside its border (every pixel: 36 x 51 < dense_max_points)
    points = scipy.ndimage.binary_erosion(labels == 1, np.ones((5, 5), bool))
    assert fit.n_points == points.sum()
    assert fit.applied and fit.note.startswith("offset only")
    assert fit.clipped > 0.6 * fit.n_points
    assert fit.gain == 1.0
    assert fit.offset == pytest.approx(reference[points].mean() - target[points].mean(), rel=1e-5)
    inside = labels == 1
    np.testing.assert_allclose(refined[inside], target[inside] + fit.offset, rtol=1e-6)
    np.testing.assert_array_equal(refined[~inside], target[~inside])
    _, (allowed,) = refine_target(
        reference, target, labels, association, RefineParams(points="dense", max_clipped=0.8)
    )
    assert allowed.applied and allowed.note == "" and allowed.gain == pytest.approx(1.5, rel=1e-4)


def test_clipped_masks_must_match_the_images():
    reference, target, labels, association = _clipped_scene(0.2)
    wrong = (np.zeros((4, 4), bool), np.zeros(target.shape, bool))
    with pytest.raises(InputError, match="clipped masks"):
        refine_target(reference, target, labels, association, RefineParams(points="dense"), wrong)


def test_the_notes_say_why_a_fit_was_not_applied():
    reference, target, labels = _scene()
    _, (few,) = refine_target(reference, target, labels, _association(_POINTS, n_points=2))
    assert few.note.startswith("too few points")
    _, (alone,) = refine_target(reference, target, labels, _association(_POINTS, tgt_id=0))
    assert alone.note == "no target object"
    _, (steep,) = refine_target(reference, target, labels, _association(_POINTS), RefineParams(gain_range=(0.5, 1.2)))
    assert not steep.applied and "gain_range" in steep.note


def test_a_fit_states_whether_it_was_applied_and_why():
    from radcons.results import ObjectFit

    points = np.ones(3)
    plain = ObjectFit(1, 1, 1.2, 3.0, points, points, points, True)
    assert plain.state == "applied"
    limited = ObjectFit(1, 1, 1.2, 3.0, points, points, points, True, clipped=2)
    assert limited.state == "applied; 2 points on clipped pixels left out"
    refused = ObjectFit(1, 1, 1.0, 0.0, points, points, points, False, 0, "too few points (2, min_points 3)")
    assert refused.state == "not applied: too few points (2, min_points 3)"


def test_local_background_is_histogram_matching_then_the_light_correction():
    """A gain growing from left to right: one global mapping cannot undo it, the local
    background (the same mapping, then a gain and offset per tile) can."""
    rng = np.random.default_rng(5)
    reference = scipy.ndimage.gaussian_filter(rng.uniform(20.0, 230.0, (256, 256)), 2.0)
    reference = (20.0 + 210.0 * (reference - reference.min()) / np.ptp(reference)).astype(np.float32)
    light = np.linspace(0.6, 1.2, 256)[None, :]
    target = (reference * light + 10.0).astype(np.float32)
    target[3, 4] = np.nan
    labels = np.zeros(reference.shape, np.int32)
    none = Association(np.zeros((0, 4)), ())
    local, _ = refine_target(reference, target, labels, none, RefineParams(background="local", local_tiles=8, local_min_light=0.0))
    whole = histogram_mapping(reference, target)
    valid = np.isfinite(target)
    assert np.isnan(local[3, 4]) and np.isfinite(local[valid]).all()
    local_error = np.abs(local[valid] - reference[valid]).mean()
    assert local_error < 0.4 * np.abs(whole[valid] - reference[valid]).mean()
    assert local_error < 4.0
    np.testing.assert_allclose(local, local_light_correction(reference, whole, 8), atol=1e-3, equal_nan=True)
    assert RefineParams(background="local").local_tiles == 6
    with pytest.raises(ParamsError):
        RefineParams(local_tiles=0)


def test_agreement_gate_keeps_a_line_that_helps_and_refuses_one_that_harms():
    reference, target, labels = _scene()
    gated = RefineParams(blend_width=0.0, agreement_gate=True)
    refined, (fit,) = refine_target(reference, target, labels, _association(_POINTS), gated)
    assert fit.applied and fit.gain == pytest.approx(1.5, rel=1e-4)  # the object's true line
    inside = labels == 1
    np.testing.assert_allclose(refined[inside], reference[inside], atol=1e-2)
    # an unchanged object whose few points disagree (say, cars parked there on one date only):
    # their line (gain 2) would move the whole object away from the reference
    target = reference.copy()
    misleading = reference.copy()
    for x, y in _POINTS:
        misleading[y, x] = 2.0 * reference[y, x] - 50.0
    harmful, (fit,) = refine_target(misleading, target, labels, _association(_POINTS), RefineParams(blend_width=0.0))
    assert fit.applied and fit.gain == pytest.approx(2.0, rel=1e-3)
    assert np.abs(harmful[inside] - reference[inside]).mean() > 50.0
    kept, (fit,) = refine_target(misleading, target, labels, _association(_POINTS), gated)
    assert not fit.applied and "agreement" in fit.note
    np.testing.assert_array_equal(kept, target)
    assert object_agreement(reference, target, inside, (slice(0, 96), slice(0, 96)), 0.0) == 0.0


def test_smoothed_histogram_mapping_keeps_the_signal_contrast_of_a_noisier_target():
    """Target = half the reference's contrast plus noise: matching its raw histogram
    flattens the signal (its spread is partly noise); fitted on smoothed copies it does not."""
    rng = np.random.default_rng(8)
    signal = scipy.ndimage.gaussian_filter(rng.normal(0.0, 1.0, (256, 256)), 6.0)
    reference = (120.0 + 50.0 * signal / signal.std()).astype(np.float32)
    target = (0.5 * reference + 20.0 + rng.normal(0.0, 20.0, reference.shape)).astype(np.float32)
    target[0, 0] = np.nan

    def slope(mapped):  # gain of the mapped target against the reference (least squares)
        valid = np.isfinite(mapped)
        return np.polyfit(reference[valid], mapped[valid], 1)[0]

    assert slope(histogram_mapping(reference, target)) < 0.82  # 25 / sqrt(25**2 + 20**2) = 0.78
    smoothed = histogram_mapping(reference, target, smoothing=2.0)
    assert slope(smoothed) == pytest.approx(1.0, abs=0.06)
    assert np.isnan(smoothed[0, 0]) and np.isfinite(smoothed).sum() == target.size - 1
    assert (np.diff(histogram_mapping(reference, np.sort(target[1:].ravel())[None, :], 2.0)) >= 0).all()
    with pytest.raises(ParamsError):
        RefineParams(background_smoothing=-1.0)
