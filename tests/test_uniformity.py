"""Illumination uniformity (eq 1-3) and the DCT Poisson solver it rebuilds images with."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse
import scipy.sparse.linalg

from radcons.errors import InputError, ParamsError
from radcons.numerics.poisson import divergence, gradient, solve_poisson_neumann
from radcons.stages.uniformity.run import (
    UniformityParams,
    attenuation,
    illumination_uniformity,
    relative_gradient,
)


def _smooth_random(shape, seed=0, low=20.0, high=220.0):
    rng = np.random.default_rng(seed)
    field = rng.random(shape)
    for axis in (0, 1):
        field = (field + np.roll(field, 1, axis) + np.roll(field, -1, axis)) / 3
    field = (field - field.min()) / np.ptp(field)
    return (low + (high - low) * field).astype(np.float32)


def _neumann_laplacian(m: int, n: int) -> scipy.sparse.csr_matrix:
    """5-point Laplacian with reflecting borders, built from difference matrices."""

    def forward(k):
        return scipy.sparse.diags([-np.ones(k - 1), np.ones(k - 1)], [0, 1], shape=(k - 1, k))

    dx = scipy.sparse.kron(scipy.sparse.identity(m), forward(n))
    dy = scipy.sparse.kron(forward(m), scipy.sparse.identity(n))
    return -(dx.T @ dx + dy.T @ dy).tocsr()


# ------------------------------------------------------------------------- Poisson


def test_divergence_of_gradient_solves_back_to_image_minus_mean():
    image = np.random.default_rng(1).random((37, 53))
    solved = solve_poisson_neumann(divergence(*gradient(image)))
    np.testing.assert_allclose(solved, image - image.mean(), atol=1e-10)


def test_float32_round_trip_stays_float32_and_accurate():
    image = _smooth_random((64, 48))
    solved = solve_poisson_neumann(divergence(*gradient(image)))
    assert solved.dtype == np.float32
    np.testing.assert_allclose(solved, image - image.mean(), atol=1e-4 * np.ptp(image))


def test_dct_solver_agrees_with_direct_sparse_solve():
    m, n = 12, 17
    laplacian = _neumann_laplacian(m, n)
    rng = np.random.default_rng(2)
    rhs = rng.standard_normal(m * n)
    rhs -= rhs.mean()  # the Neumann problem needs a zero-mean right-hand side
    # pin the first unknown to remove the constant null space, then centre
    direct = np.zeros(m * n)
    direct[1:] = scipy.sparse.linalg.spsolve(laplacian[1:, 1:].tocsc(), rhs[1:])
    direct -= direct.mean()
    np.testing.assert_allclose(solve_poisson_neumann(rhs.reshape(m, n)).ravel(), direct, atol=1e-9)


def test_divergence_is_the_sparse_laplacian_of_the_gradient():
    m, n = 9, 11
    image = np.random.default_rng(3).random((m, n))
    expected = _neumann_laplacian(m, n) @ image.ravel()
    np.testing.assert_allclose(divergence(*gradient(image)).ravel(), expected, atol=1e-12)


def test_divergence_of_any_field_sums_to_zero():
    rng = np.random.default_rng(4)
    assert abs(divergence(rng.random((20, 30)), rng.random((20, 30))).sum()) < 1e-10


def test_poisson_rejects_nan_and_bad_shapes():
    with pytest.raises(InputError, match="NaN"):
        solve_poisson_neumann(np.full((4, 4), np.nan))
    with pytest.raises(InputError, match="2-D"):
        gradient(np.zeros(5))
    with pytest.raises(InputError, match="shape"):
        divergence(np.zeros((3, 3)), np.zeros((3, 4)))


# ----------------------------------------------------------------------- uniformity


@pytest.mark.parametrize("mapping", ["mean_std", "percentile"])
def test_zeta_one_gives_the_image_back(mapping):
    image = _smooth_random((64, 80), seed=5)
    out = illumination_uniformity(image, UniformityParams(zeta=1.0, range_mapping=mapping))
    assert out.dtype == np.float32
    assert np.max(np.abs(out - image)) < 1e-4 * np.ptp(image)


def test_zeta_one_with_nan_pixels_keeps_valid_pixels_and_nan():
    image = _smooth_random((64, 80), seed=6)
    image[10, 12] = np.nan
    image[30:40, :15] = np.nan
    out = illumination_uniformity(image, UniformityParams(zeta=1.0))
    invalid = np.isnan(image)
    assert np.array_equal(np.isnan(out), invalid)
    assert np.max(np.abs(out[~invalid] - image[~invalid])) < 1e-4 * np.nanmax(image)


def test_default_keeps_nan_pixels_nan_and_others_finite():
    image = _smooth_random((48, 48), seed=7)
    image[5:9, 20:30] = np.nan
    out = illumination_uniformity(image)
    assert np.array_equal(np.isnan(out), np.isnan(image))
    assert np.isfinite(out[~np.isnan(image)]).all()


def test_attenuation_compresses_a_large_step_relative_to_small_texture():
    rows, cols = 64, 128
    x = np.arange(cols)
    texture = 2.0 * np.sin(2 * np.pi * x / 6.0)[None, :].repeat(rows, 0)
    image = np.where(x[None, :] < cols // 2, 60.0, 180.0) + texture
    image = image.astype(np.float32)

    def step_over_texture(img):
        left, right = img[:, 8 : cols // 2 - 8], img[:, cols // 2 + 8 : -8]
        step = np.median(right) - np.median(left)
        texture_amplitude = np.std(left - left.mean(axis=1, keepdims=True))
        return step / texture_amplitude

    out = illumination_uniformity(image)
    assert step_over_texture(out) < 0.5 * step_over_texture(image)


def test_attenuation_factor_below_one_above_threshold_and_above_one_below():
    relative = np.array([[0.01, 0.05, 1.0, 5.0]], np.float32)
    valid = np.ones_like(relative, bool)
    theta = attenuation(relative, valid, UniformityParams(mu=0.1, zeta=0.8))
    threshold = 0.1 * relative.mean()  # 0.1515
    assert np.all(theta[relative < threshold] > 1)
    assert np.all(theta[relative > threshold] < 1)
    # the attenuated magnitude keeps the order of the originals (monotone for zeta > 0)
    assert np.all(np.diff((relative * theta).ravel()) > 0)


def test_constant_image_comes_back_constant():
    out = illumination_uniformity(np.full((16, 16), 42.0, np.float32))
    np.testing.assert_allclose(out, 42.0)


def test_f_one_and_local_mean_both_run_and_differ():
    image = _smooth_random((40, 40), seed=8)
    a = illumination_uniformity(image, UniformityParams(f="local_mean"))
    b = illumination_uniformity(image, UniformityParams(f="one"))
    assert np.isfinite(a).all() and np.isfinite(b).all()
    assert not np.allclose(a, b)


def test_bad_input_and_params():
    with pytest.raises(InputError, match="single-band 2-D"):
        illumination_uniformity(np.zeros((3, 3, 3), np.float32))
    with pytest.raises(InputError, match="every pixel of the image is NaN"):
        illumination_uniformity(np.full((8, 8), np.nan, np.float32))
    with pytest.raises(InputError, match=r"shape \(1, 8\) is too small for a gradient"):
        illumination_uniformity(np.zeros((1, 8), np.float32))
    with pytest.raises(InputError, match="real numbers"):
        illumination_uniformity(np.zeros((8, 8), complex))
    with pytest.raises(ParamsError):
        UniformityParams(zeta=1.5)
    with pytest.raises(ParamsError):
        UniformityParams(f="log")
    with pytest.raises(ParamsError):
        UniformityParams(range_mapping="minmax")


@pytest.mark.parametrize("mapping", ["mean_std", "percentile"])
def test_mu_scales_every_factor_alike_so_the_output_ignores_it(mapping):
    image = _smooth_random((48, 64), seed=5)
    valid = np.ones(image.shape, bool)
    relative = np.abs(np.gradient(image)[1]) + 0.5
    low, high = (attenuation(relative, valid, UniformityParams(mu=mu)) for mu in (0.1, 0.5))
    np.testing.assert_allclose(high / low, 5.0 ** (1 - 0.8), rtol=1e-5)
    a, b = (illumination_uniformity(image, UniformityParams(mu=mu, range_mapping=mapping)) for mu in (0.1, 0.5))
    np.testing.assert_allclose(a, b, atol=1e-3 * np.ptp(image))


def test_relative_gradient_does_not_depend_on_where_its_arrays_lie_in_memory():
    # the same image and gradient, copied to every 4-byte offset of a 64-byte line, give the
    # same relative gradient bit for bit, and it is |grad I| / f(I * g) rounded once from
    # float64 (a SIMD kernel whose rounding follows the buffer's alignment made the paper
    # preset's output change from run to run)
    rng = np.random.default_rng(4)
    image = rng.uniform(10.0, 200.0, (97, 131)).astype(np.float32)
    gx, gy = gradient(image)
    params = UniformityParams(f="one")

    def placed(array: np.ndarray, offset: int) -> np.ndarray:
        buffer = np.empty(array.size + 16, np.float32)
        out = buffer[offset : offset + array.size].reshape(array.shape)
        out[...] = array
        return out

    results = [relative_gradient(placed(image, k), placed(gx, k), placed(gy, k), params) for k in range(16)]
    for result in results[1:]:
        np.testing.assert_array_equal(result, results[0])
    exact = np.hypot(gx.astype(np.float64), gy.astype(np.float64)).astype(np.float32)
    np.testing.assert_array_equal(results[0], exact)
