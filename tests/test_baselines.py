"""Baselines on pairs whose true radiometric relation is known."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from radcons.baselines import BASELINES
from radcons.baselines.irmad import IrmadParams, irmad_fit
from radcons.baselines.linear import dominant_disparity, orthogonal_regression
from radcons.baselines.statistics import histogram_matching, mean_std_matching
from radcons.baselines.zhang import ZhangParams, contrast, zhang_normalisation
from radcons.baselines.zhong import zhong_fit
from radcons.errors import InputError

GAIN, OFFSET = 0.7, 25.0


def changed_pair(seed: int = 0, n: int = 128, noise: float = 2.0):
    """``target = GAIN * reference + OFFSET`` plus noise, with changed patches (21 % of pixels).

    Returns reference, target and the change mask.
    """
    rng = np.random.default_rng(seed)
    field = ndimage.gaussian_filter(rng.normal(size=(n, n)), 1.5)
    clean = field / field.std() * 40.0 + 120.0
    reference = clean + rng.normal(0.0, noise, clean.shape)
    target = GAIN * clean + OFFSET + rng.normal(0.0, noise, clean.shape)
    changed = np.zeros(clean.shape, bool)
    for y, x in ((10, 10), (60, 80), (90, 20)):
        target[y:y + 30, x:x + 30] = rng.uniform(20.0, 230.0, (30, 30))  # new content
        changed[y:y + 30, x:x + 30] = True
    target[100:128, 100:128] += 60.0  # brightened roofs
    changed[100:128, 100:128] = True
    return reference.astype(np.float32), target.astype(np.float32), changed


@pytest.mark.parametrize("fit", [irmad_fit, zhong_fit])
@pytest.mark.parametrize("seed", [0, 1])
def test_regression_baselines_recover_gain_and_offset_despite_changes(fit, seed):
    reference, target, changed = changed_pair(seed)
    result = fit(reference, target)  # reference ~ gain * target + offset
    assert 1.0 / result.gain == pytest.approx(GAIN, rel=0.02)
    assert -result.offset / result.gain == pytest.approx(OFFSET, rel=0.05)
    # an ordinary fit over all pixels is thrown far off by the changes
    naive = orthogonal_regression(target.ravel().astype(float), reference.ravel().astype(float))
    assert abs(1.0 / naive.gain - GAIN) > 0.1


def test_normalised_target_matches_reference_on_unchanged_pixels():
    reference, target, changed = changed_pair(2)
    for name in ("irmad", "zhong"):
        normalised = BASELINES[name](reference, target)
        error = normalised[~changed] - reference[~changed]
        assert abs(error.mean()) < 1.5, name  # noise is 2 / 0.7 in the target, 2 in the reference
        assert error.std() < 5.0, name


def test_irmad_no_change_threshold_matters():
    reference, target, _ = changed_pair(3)
    strict = irmad_fit(reference, target, IrmadParams(no_change_probability=0.99))
    loose = irmad_fit(reference, target, IrmadParams(no_change_probability=0.5))
    assert strict.n_used < loose.n_used


def test_histogram_matching_matches_the_cdf():
    reference, target, _ = changed_pair(4)
    matched = histogram_matching(reference, target)
    grid = np.linspace(0.0, 300.0, 601)
    cdf_ref = np.searchsorted(np.sort(reference.ravel()), grid, side="right") / reference.size
    cdf_out = np.searchsorted(np.sort(matched.ravel()), grid, side="right") / matched.size
    assert np.abs(cdf_ref - cdf_out).max() < 0.005
    # the mapping is monotone: the target's order of grey levels is kept
    order = np.argsort(target.ravel(), kind="stable")
    assert np.all(np.diff(matched.ravel()[order]) >= 0)


def test_mean_std_matching():
    reference, target, _ = changed_pair(5)
    out = mean_std_matching(reference, target)
    assert out.mean() == pytest.approx(reference.mean(), rel=1e-5)
    assert out.std() == pytest.approx(reference.std(), rel=1e-4)
    assert np.corrcoef(out.ravel(), target.ravel())[0, 1] == pytest.approx(1.0, abs=1e-6)


def test_zhang_layers_against_full_svd():
    reference = changed_pair(6, noise=0.0)[0][:64, :64]
    target = (GAIN * reference + OFFSET).astype(np.float32)
    out = zhang_normalisation(reference, target, ZhangParams(contrast_scale=0.0))
    # contrast layer: the gradient field of a gain is the gain times the field, so the
    # stretch undoes it exactly: stretched = mean_t + (target - mean_t) / GAIN
    stretched = target.mean(dtype=np.float64) + (target - target.mean(dtype=np.float64)) / GAIN
    # brightness layer (eq 5-6) with the largest singular value from a full SVD
    sigma_max = np.linalg.svd(stretched, compute_uv=False)[0]
    lam = reference.mean(dtype=np.float64) * np.sqrt(stretched.size) / sigma_max
    np.testing.assert_allclose(out, lam * stretched, rtol=1e-4)
    # singular value equalisation toward the reference's mean brings the mean there
    assert out.mean() == pytest.approx(reference.mean(), rel=0.02)


def test_zhang_contrast_ignores_blur_at_its_scale():
    reference, _, _ = changed_pair(7, noise=0.0)
    blurred = ndimage.gaussian_filter(reference, 1.0)
    raw_ratio = contrast(reference, 0.0) / contrast(blurred, 0.0)
    scaled_ratio = contrast(reference, 2.0) / contrast(blurred, 2.0)
    # a 1 px blur passes for a large loss of contrast on the raw images, a much smaller
    # one at the 2 px scale (the texture here has a 1.5 px correlation length)
    assert raw_ratio > 1.35
    assert scaled_ratio - 1.0 < (raw_ratio - 1.0) / 2.0


def test_dominant_disparity_sign():
    reference, _, _ = changed_pair(8, noise=0.0)
    d = 9
    target = np.empty_like(reference)
    target[:, : reference.shape[1] - d] = reference[:, d:]  # reference(x) = target(x - d)
    target[:, reference.shape[1] - d:] = reference[:, -1:]
    assert dominant_disparity(reference, target) == d
    assert dominant_disparity(target, reference) == -d


@pytest.mark.parametrize("name", sorted(BASELINES))
def test_every_baseline_keeps_nan_and_returns_float32(name):
    reference, target, _ = changed_pair(9)
    target[5:9, 40:60] = np.nan
    reference[70:72, :] = np.nan
    out = BASELINES[name](reference, target)
    assert out.dtype == np.float32 and out.shape == target.shape
    np.testing.assert_array_equal(np.isnan(out), np.isnan(target))
    with pytest.raises(InputError):
        BASELINES[name](reference, target[:, :50])


def test_registry_names():
    assert set(BASELINES) == {"histmatch", "meanstd", "irmad", "zhang", "zhong"}


@pytest.mark.realdata
def test_irmad_stops_before_its_band_narrows_onto_one_grey_level(shared_data):
    # Cones with the held-out compression difference of seed 16, stored in 8 bits: the
    # reweighting narrowed the no-change band onto 16 pixels of one level in each image
    # and the regression failed ("uncorrelated").
    from radcons.baselines import irmad
    from radcons.evaluate.simulate import sample_difference, simulate_pair
    from radcons.evaluate.truth_pairs import load_cones

    pair = simulate_pair(load_cones(shared_data / "middlebury_cones"), sample_difference(16))
    reference, target = pair.reference.as_float32(), pair.target.as_float32()
    fit = irmad_fit(reference, target)
    x, y, _ = irmad.paired_pixels(*irmad.aligned_views(reference, target, True))
    used = np.abs(y - (fit.gain * x + fit.offset)) < 3.0
    assert fit.n_used > 100 and np.isfinite([fit.gain, fit.offset]).all()
    assert np.ptp(x[used]) > 10 and np.ptp(y[used]) > 10
