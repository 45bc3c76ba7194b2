"""Tests of the smoothness consistency stage (union group sparse model, eq 13-19).

The compiled kernels are checked against NumPy's SVD and eigensolvers and against brute
force block matching; the stage against its defining properties (a zero threshold returns
the input exactly, borders included; the union threshold brings two noise levels
together; NaN stays NaN).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from skimage import data

from radcons.errors import InputError, ParamsError
from radcons.noise import noise_sigma
from radcons.results import Association, Matches, ObjectAssociation
from radcons.stages.smoothness.group_sparse import (
    low_rank_estimate,
    union_low_rank_estimate,
)
from radcons.stages.smoothness.group_sparse_linalg import (
    eigen_workspace,
    largest_eigenvalues,
    tridiagonalize,
)
from radcons.stages.smoothness.inverse_iteration import eigenvectors
from radcons.stages.smoothness.patch_matching import block_match
from radcons.stages.smoothness.run import (
    SmoothnessParams,
    _union_centres,
    group_sparse_denoise,
    preview_params,
    smoothness_consistency,
    smoothness_preview,
)

RNG = np.random.default_rng(20180613)


# ------------------------------------------------------------------ NumPy references


def _thresholds(singular: np.ndarray, n_columns: int, sigma_w: float, c: float) -> np.ndarray:
    """Eq 17: tau_i = c sigma_w^2 / sqrt(max(lambda_i^2 / m - sigma_w^2, 0))."""
    variance = singular**2 / n_columns - sigma_w**2
    with np.errstate(divide="ignore"):
        return np.where(variance > 0, c * sigma_w**2 / np.sqrt(np.maximum(variance, 1e-300)), np.inf)


def _svd_shrink(group: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Centre, soft-threshold the singular values by tau, add the mean back (full SVD)."""
    mean = group.mean(axis=0)
    u, s, vt = np.linalg.svd(group - mean, full_matrices=False)
    return (u * np.maximum(s - tau[: s.size], 0.0)) @ vt + mean


def _reference_single(group: np.ndarray, sigma_w: float, c: float) -> np.ndarray:
    singular = np.linalg.svd(group - group.mean(axis=0), compute_uv=False)
    return _svd_shrink(group, _thresholds(singular, group.shape[0], sigma_w, c))


def _reference_union(g1: np.ndarray, g2: np.ndarray, sigma_w: float, c: float) -> tuple[np.ndarray, np.ndarray]:
    union = np.vstack([g1 - g1.mean(axis=0), g2 - g2.mean(axis=0)])
    tau = _thresholds(np.linalg.svd(union, compute_uv=False), union.shape[0], sigma_w, c)
    return _svd_shrink(g1, tau), _svd_shrink(g2, tau)


def _random_group(m: int = 31, p: int = 64, rank: int = 3, noise: float = 5.0) -> np.ndarray:
    structure = RNG.normal(size=(m, rank)) @ RNG.normal(size=(rank, p)) * RNG.uniform(5, 40)
    return 100.0 + structure + RNG.normal(size=(m, p)) * noise


# --------------------------------------------------------------------- eigen solver


def _eigen(matrix: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    n = matrix.shape[0]
    ws = eigen_workspace(n)
    reduced = matrix.copy()
    tridiagonalize(reduced, n, ws)
    largest_eigenvalues(ws, n, k, -np.inf)
    values = ws.values[:k].copy()
    return values, eigenvectors(ws, n, k).copy()


@pytest.mark.parametrize("n", [2, 3, 31, 62])
def test_eigen_solver_matches_numpy(n):
    group = RNG.normal(size=(n, 64)) * RNG.uniform(0.1, 100)
    gram = group @ group.T
    values, vectors = _eigen(gram, n)
    expected = np.sort(np.linalg.eigvalsh(gram))[::-1]
    np.testing.assert_allclose(values, expected, rtol=0, atol=1e-11 * expected[0])
    np.testing.assert_allclose(vectors @ vectors.T, np.eye(n), atol=1e-9)
    np.testing.assert_allclose(gram @ vectors.T, vectors.T * values, atol=1e-9 * expected[0])


@pytest.mark.parametrize("k", [8, 62])  # bisection and Newton, and QL
def test_eigen_solver_repeated_eigenvalues(k):
    # the same 31 patches in two disjoint halves of the patch: every eigenvalue twice
    half = RNG.normal(size=(31, 32))
    group = np.block([[half, np.zeros((31, 32))], [np.zeros((31, 32)), half]])
    gram = group @ group.T
    values, vectors = _eigen(gram, k)
    expected = np.sort(np.linalg.eigvalsh(gram))[::-1][:k]
    np.testing.assert_allclose(values, expected, atol=1e-11 * expected[0])
    np.testing.assert_allclose(vectors @ vectors.T, np.eye(k), atol=1e-8)
    np.testing.assert_allclose(gram @ vectors.T, vectors.T * values, atol=1e-8 * expected[0])


def test_eigen_solver_null_space():
    # rank 10 out of 21: eleven zero eigenvalues
    half = RNG.normal(size=(10, 64))
    group = np.vstack([half, half, np.zeros((1, 64))])
    gram = group @ group.T
    values, _ = _eigen(gram, 21)
    expected = np.sort(np.linalg.eigvalsh(gram))[::-1]
    np.testing.assert_allclose(values, expected, atol=1e-11 * expected[0])


def test_eigen_solver_only_the_leading_ones():
    group = RNG.normal(size=(31, 64))
    gram = group @ group.T
    values, vectors = _eigen(gram, 4)
    w, v = np.linalg.eigh(gram)
    np.testing.assert_allclose(values, w[::-1][:4], atol=1e-11 * w[-1])
    # same eigenvectors up to sign
    np.testing.assert_allclose(np.abs(np.sum(vectors * v[:, ::-1][:, :4].T, axis=1)), 1.0, atol=1e-9)


# ------------------------------------------------------------------ group shrinkage


def test_zero_threshold_returns_group_unchanged():
    group = _random_group(rank=31)
    np.testing.assert_allclose(low_rank_estimate(group, 0.0, 2.0 * math.sqrt(2.0)), group, rtol=0, atol=1e-9)
    other = _random_group(rank=31)
    out1, out2 = union_low_rank_estimate(group, other, 0.0, 2.0 * math.sqrt(2.0))
    np.testing.assert_allclose(out1, group, atol=1e-9)
    np.testing.assert_allclose(out2, other, atol=1e-9)


def test_rank_one_group_keeps_its_rank_one_part():
    m, p, sigma_w, c = 31, 64, 4.0, 2.0 * math.sqrt(2.0)
    u = RNG.normal(size=m)
    u -= u.mean()  # survives centring
    u /= np.linalg.norm(u)
    v = RNG.normal(size=p)
    v /= np.linalg.norm(v)
    s = 900.0
    mean = RNG.uniform(50, 150, size=p)
    group = mean + s * np.outer(u, v)
    estimate = low_rank_estimate(group, sigma_w, c)
    tau = c * sigma_w**2 / math.sqrt(s**2 / m - sigma_w**2)
    np.testing.assert_allclose(estimate, mean + (s - tau) * np.outer(u, v), atol=1e-9)


@pytest.mark.parametrize("trial", range(12))
def test_group_estimate_matches_svd_shrinkage(trial):
    group = _random_group(rank=int(RNG.integers(1, 8)), noise=RNG.uniform(0.5, 20))
    sigma_w, c = RNG.uniform(0.5, 20), RNG.uniform(1.0, 6.0)
    expected = _reference_single(group, sigma_w, c)
    np.testing.assert_allclose(low_rank_estimate(group, sigma_w, c), expected, atol=1e-6 * np.abs(group).max())


@pytest.mark.parametrize("trial", range(12))
def test_union_estimate_matches_svd_shrinkage(trial):
    g1 = _random_group(rank=int(RNG.integers(1, 8)), noise=RNG.uniform(0.5, 5))
    g2 = g1 + RNG.normal(size=g1.shape) * RNG.uniform(0, 20)
    sigma_w, c = RNG.uniform(0.5, 20), RNG.uniform(1.0, 6.0)
    expected1, expected2 = _reference_union(g1, g2, sigma_w, c)
    out1, out2 = union_low_rank_estimate(g1, g2, sigma_w, c)
    scale = 1e-6 * max(np.abs(g1).max(), np.abs(g2).max())  # below float32 resolution
    np.testing.assert_allclose(out1, expected1, atol=scale)
    np.testing.assert_allclose(out2, expected2, atol=scale)


def test_union_threshold_differs_from_own_thresholds():
    # the union's thresholds are not either image's own: the results must differ from
    # per-image shrinkage, or the test above would not tell the two models apart
    g1 = _random_group(rank=2, noise=1.0)
    g2 = g1 + RNG.normal(size=g1.shape) * 15.0
    out1, _ = union_low_rank_estimate(g1, g2, 15.0, 2.8)
    assert np.abs(out1 - _reference_single(g1, 15.0, 2.8)).max() > 1e-3


# ------------------------------------------------------------------- block matching


def test_block_match_finds_the_nearest_patches():
    image = RNG.normal(size=(40, 44)).astype(np.float32)
    labels = np.zeros(image.shape, np.int32)
    labels[:, 22:] = 1
    patch, radius, m = 4, 5, 9
    cy = np.array([0, 10, 18, 36], np.int32)
    cx = np.array([0, 20, 12, 40], np.int32)
    regions = np.array([0, 1, 0, 1], np.int32)
    ys, xs = block_match(image, cy, cx, labels, regions, patch, radius, m)
    for g in range(cy.size):
        assert (ys[g, 0], xs[g, 0]) == (cy[g], cx[g])
        ref = image[cy[g] : cy[g] + patch, cx[g] : cx[g] + patch]
        candidates = []
        for y in range(max(cy[g] - radius, 0), min(cy[g] + radius, image.shape[0] - patch) + 1):
            for x in range(max(cx[g] - radius, 0), min(cx[g] + radius, image.shape[1] - patch) + 1):
                if (y, x) == (cy[g], cx[g]):
                    continue
                outside = labels[y + patch // 2, x + patch // 2] != regions[g]
                distance = float(np.sum((image[y : y + patch, x : x + patch] - ref) ** 2))
                candidates.append((outside, distance, y, x))
        candidates.sort()
        expected = {(y, x) for _, _, y, x in candidates[: m - 1]}
        assert set(zip(ys[g, 1:].tolist(), xs[g, 1:].tolist())) == expected


# ------------------------------------------------------------------------- the stage


def _camera(size: int = 96, offset: int = 0) -> np.ndarray:
    return data.camera()[200 : 200 + size, 150 + offset : 150 + offset + size].astype(np.float32)


def _association(*objects: tuple[int, int, float]) -> Association:
    empty = np.zeros(0, np.int64)
    return Association(
        Matches.empty(),
        tuple(ObjectAssociation(r, t, "sift", d, empty, empty) for r, t, d in objects),
    )


@pytest.mark.parametrize("shape", [(37, 53), (64, 64)])
def test_zero_noise_returns_the_image_exactly(shape):
    image = RNG.uniform(0, 255, size=shape).astype(np.float32)
    out = group_sparse_denoise(image, 0.0, SmoothnessParams(step=5, iterations=2))
    np.testing.assert_allclose(out, image, rtol=0, atol=1e-3)


def test_zero_noise_union_returns_both_images_exactly():
    reference = RNG.uniform(0, 255, size=(45, 60)).astype(np.float32)
    target = RNG.uniform(0, 255, size=(45, 60)).astype(np.float32)
    labels = np.zeros(reference.shape, np.int32)
    labels[10:30, 20:40] = 3
    result = smoothness_consistency(
        reference, target, labels, labels, _association((3, 3, 7.0)), SmoothnessParams(step=7, iterations=2), (0.0, 0.0)
    )
    np.testing.assert_allclose(result.reference, reference, atol=1e-3)
    np.testing.assert_allclose(result.target, target, atol=1e-3)


def test_denoising_removes_noise():
    clean = _camera(128)
    noisy = clean + RNG.normal(0, 15, clean.shape).astype(np.float32)
    out = group_sparse_denoise(noisy, 15.0, SmoothnessParams(c=5.6))
    before = np.sqrt(np.mean((noisy - clean) ** 2))
    after = np.sqrt(np.mean((out - clean) ** 2))
    assert after < 0.55 * before


def test_union_threshold_brings_noise_levels_together():
    # a textured scene seen by a clean and a noisy sensor, 4 px apart
    disparity = 4
    scene = data.gravel()[100:228, 100:232].astype(np.float32)
    rng = np.random.default_rng(1)
    reference = scene[:, disparity:] + rng.normal(0, 3, (128, 128)).astype(np.float32)
    target = scene[:, :128] + rng.normal(0, 12, (128, 128)).astype(np.float32)  # target(x - d) = ref(x)
    labels = np.zeros(reference.shape, np.int32)
    params = SmoothnessParams(iterations=6, background_disparity=disparity)
    result = smoothness_consistency(reference, target, labels, labels, _association(), params)
    assert result.info["noise_ratio_initial"] > 2.0
    union = noise_sigma(result.target) / noise_sigma(result.reference)
    assert 1 / 1.15 < union < 1.15
    # each image denoised alone at its own noise level ends further apart
    alone = noise_sigma(group_sparse_denoise(target, noise_sigma(target), params)) / noise_sigma(
        group_sparse_denoise(reference, noise_sigma(reference), params)
    )
    assert abs(math.log(alone)) > 1.5 * abs(math.log(union))


def test_union_groups_pair_patches_at_the_object_disparity():
    shape = (40, 60)
    regions_ref = np.zeros(shape, np.int32)
    regions_ref[8:32, 30:50] = 1
    regions_tgt = np.zeros(shape, np.int32)
    regions_tgt[8:32, 20:40] = 1
    disparities = np.array([3, 10], np.int32)  # background, object 1
    ys_ref, xs_ref, ys_tgt, xs_tgt, regions, extra = _union_centres(regions_ref, regions_tgt, disparities, 8, 4)
    assert np.array_equal(ys_ref, ys_tgt) and np.all(np.diff(ys_ref) >= 0)
    half = 4
    # reference grid groups: region of the reference centre, partner at x - D
    on_ref = (regions == regions_ref[ys_ref + half, xs_ref + half]) & (
        xs_tgt == np.clip(xs_ref - disparities[regions], 0, shape[1] - 8)
    )
    # groups added for the target: region of the target centre, partner at x + D
    on_tgt = (regions == regions_tgt[ys_tgt + half, xs_tgt + half]) & (
        xs_ref == np.clip(xs_tgt + disparities[regions], 0, shape[1] - 8)
    )
    assert np.all(on_ref | on_tgt)
    assert np.count_nonzero(on_ref) >= ys_ref.size - extra and extra > 0
    # every target pixel lies in some partner patch
    covered = np.zeros(shape, bool)
    for y, x in zip(ys_tgt, xs_tgt):
        covered[y : y + 8, x : x + 8] = True
    assert covered.all()


def test_nan_pixels_stay_nan():
    reference = _camera(64)
    target = _camera(64, offset=2)
    reference[5:9, 10:30] = np.nan
    target[40:, :3] = np.nan
    labels = np.zeros(reference.shape, np.int32)
    result = smoothness_consistency(reference, target, labels, labels, _association(), SmoothnessParams(iterations=2))
    np.testing.assert_array_equal(np.isnan(result.reference), np.isnan(reference))
    np.testing.assert_array_equal(np.isnan(result.target), np.isnan(target))
    denoised = group_sparse_denoise(reference, 5.0, SmoothnessParams(iterations=1))
    np.testing.assert_array_equal(np.isnan(denoised), np.isnan(reference))


def test_info_reports_noise_and_iterations():
    reference = _camera(64) + RNG.normal(0, 2, (64, 64)).astype(np.float32)
    target = _camera(64, offset=1) + RNG.normal(0, 8, (64, 64)).astype(np.float32)
    labels = np.zeros(reference.shape, np.int32)
    params = SmoothnessParams(iterations=3)
    info = smoothness_consistency(reference, target, labels, labels, _association(), params).info
    assert info["iterations"] == 3 and len(info["sigma_w"]) == 3
    assert info["sigma_initial"] == (noise_sigma(reference), noise_sigma(target))
    assert info["sigma_w"][0] == max(info["sigma_initial"])
    assert info["noise_ratio_initial"] == pytest.approx(info["sigma_initial"][1] / info["sigma_initial"][0])


@pytest.mark.parametrize("fast", [False, True])
def test_preview_is_the_stage_on_the_window(fast):
    reference = _camera(96)
    target = _camera(96, offset=3)
    labels = np.zeros(reference.shape, np.int32)
    labels[20:60, 30:70] = 1
    association = _association((1, 1, 3.0))
    params = SmoothnessParams(iterations=2)
    sigma = (noise_sigma(reference), noise_sigma(target))
    preview = smoothness_preview(reference, target, labels, labels, association, (10, 20, 74, 84), params, fast=fast)
    cut = (slice(20, 84), slice(10, 74))
    ran = preview_params(params) if fast else params
    direct = smoothness_consistency(reference[cut], target[cut], labels[cut], labels[cut], association, ran, sigma)
    np.testing.assert_array_equal(preview.reference, direct.reference)
    np.testing.assert_array_equal(preview.target, direct.target)
    assert preview.info["window"] == (10, 20, 74, 84) and preview.info["params"] == ran
    assert ran.n_similar == (15 if fast else 30)


def test_bad_inputs_are_reported():
    image = _camera(32)
    labels = np.zeros(image.shape, np.int32)
    with pytest.raises(InputError, match="target"):
        smoothness_consistency(image, image[:, :20], labels, labels, _association())
    with pytest.raises(InputError, match="labels_tgt"):
        smoothness_consistency(image, image, labels, labels[:10], _association())
    with pytest.raises(InputError, match="smaller than one"):
        group_sparse_denoise(image[:5, :5], 1.0)
    with pytest.raises(ParamsError, match="sigma"):
        group_sparse_denoise(image, -1.0)
    with pytest.raises(ParamsError, match="window"):
        smoothness_preview(image, image, labels, labels, _association(), (0, 0, 40, 10))


@pytest.mark.parametrize(
    "field, value",
    [("patch_size", 1), ("n_similar", 0), ("search_window", 20), ("step", 0), ("c", -1.0), ("delta", 1.5),
     ("gamma", 0.0), ("iterations", 0), ("rematch_every", -1), ("union_sigma", "mean"),
     ("background_disparity", float("nan"))],
)
def test_params_are_validated(field, value):
    with pytest.raises(ParamsError, match=field):
        SmoothnessParams(**{field: value})


def test_no_more_similar_patches_than_the_window_holds():
    assert SmoothnessParams(n_similar=440, search_window=21).n_similar == 440  # 21 x 21 positions
    with pytest.raises(ParamsError, match="n_similar"):
        SmoothnessParams(n_similar=441, search_window=21)
    wide = SmoothnessParams(n_similar=600, search_window=31)
    assert preview_params(wide).n_similar == 15 * 15 - 1
