"""Global illumination normalisation (eq 4-6) against full SVDs."""

from __future__ import annotations

import numpy as np
import pytest

from radcons.errors import InputError, ParamsError
from radcons.stages.global_norm.run import (
    GlobalParams,
    global_normalisation,
    largest_singular_value,
    pair_mean,
)


def _image(shape, seed, low=10.0, high=250.0):
    rng = np.random.default_rng(seed)
    return (low + (high - low) * rng.random(shape)).astype(np.float32)


@pytest.mark.parametrize("shape", [(40, 60), (75, 32)])
def test_scaled_image_equals_full_svd_reconstruction(shape):
    image = _image(shape, 0)
    other = _image(shape, 1, 40.0, 120.0)
    a = float(np.concatenate([image.ravel(), other.ravel()]).astype(np.float64).mean())
    d, sigma, vt = np.linalg.svd(image.astype(np.float64), full_matrices=False)
    sigma_a = np.linalg.svd(np.full(shape, a), compute_uv=False)
    lam = sigma_a.max() / sigma.max()  # eq 5
    expected = d @ np.diag(lam * sigma) @ vt  # eq 6
    out, got_lambda = global_normalisation(image, pair_mean(image, other))
    assert np.max(np.abs(out - expected)) / np.max(np.abs(expected)) < 1e-5
    assert got_lambda == pytest.approx(lam, rel=1e-6)


@pytest.mark.parametrize(
    "maker",
    [
        lambda: _image((50, 70), 2),
        lambda: _image((90, 30), 3),
        lambda: np.random.default_rng(4).standard_normal((60, 60)).astype(np.float32),
    ],
    ids=["positive-wide", "positive-tall", "zero-mean"],
)
def test_largest_singular_value_agrees_with_numpy(maker):
    image = maker()
    expected = np.linalg.svd(image.astype(np.float64), compute_uv=False)[0]
    assert largest_singular_value(image) == pytest.approx(expected, rel=1e-5)


def test_fallback_to_arpack_when_power_iteration_does_not_converge():
    image = np.random.default_rng(5).standard_normal((50, 40)).astype(np.float32)
    expected = np.linalg.svd(image.astype(np.float64), compute_uv=False)[0]
    assert largest_singular_value(image, GlobalParams(max_iterations=1)) == pytest.approx(expected, rel=1e-5)


def test_constant_image_sigma_is_a_sqrt_mn():
    m, n, a = 23, 41, 137.5
    assert largest_singular_value(np.full((m, n), a, np.float32)) == pytest.approx(a * np.sqrt(m * n), rel=1e-6)
    assert np.linalg.svd(np.full((m, n), a), compute_uv=False)[0] == pytest.approx(a * np.sqrt(m * n))


def test_pair_mean_pools_valid_pixels_of_both_images():
    ref = _image((10, 12), 6)
    tgt = _image((8, 9), 7)
    ref[0, :5] = np.nan
    expected = np.nanmean(np.concatenate([ref.ravel(), tgt.ravel()]).astype(np.float64))
    assert pair_mean(ref, tgt) == pytest.approx(expected)


def test_nan_pixels_stay_nan_and_are_filled_with_the_mean_for_sigma():
    image = _image((30, 40), 8)
    image[3:6, 10:20] = np.nan
    filled = np.where(np.isnan(image), np.nanmean(image.astype(np.float64)), image)
    expected = np.linalg.svd(filled, compute_uv=False)[0]
    assert largest_singular_value(image) == pytest.approx(expected, rel=1e-5)
    out, lam = global_normalisation(image, 100.0)
    assert np.array_equal(np.isnan(out), np.isnan(image))
    np.testing.assert_allclose(out[~np.isnan(image)], lam * image[~np.isnan(image)], rtol=1e-6)


def test_tile_with_scene_values_matches_the_scene_result():
    scene = _image((60, 80), 9)
    whole, lam = global_normalisation(scene, 90.0)
    tile, tile_lam = global_normalisation(
        scene[10:30, 20:50], 90.0, largest_singular_value(scene), shape=scene.shape
    )
    assert tile_lam == pytest.approx(lam)
    np.testing.assert_allclose(tile, whole[10:30, 20:50], rtol=1e-6)


def test_invalid_inputs():
    with pytest.raises(InputError, match="positive"):
        global_normalisation(_image((5, 5), 10), 0.0)
    with pytest.raises(InputError, match="all-zero"):
        global_normalisation(np.zeros((5, 5), np.float32), 10.0)
    with pytest.raises(InputError, match="NaN"):
        largest_singular_value(np.full((4, 4), np.nan, np.float32))
    with pytest.raises(InputError, match="no valid"):
        pair_mean(np.full((3, 3), np.nan), np.full((3, 3), np.nan))
    with pytest.raises(InputError, match="sigma_max"):
        global_normalisation(_image((5, 5), 11), 10.0, shape=(10, 10))
    with pytest.raises(ParamsError):
        GlobalParams(tolerance=0.0)


def test_the_pipeline_computes_sigma_max_with_the_global_parameters(monkeypatch):
    """The [global] table reaches the power iteration the pipeline runs."""
    import radcons.stages.global_norm.run as global_run
    from demo_data_gen import generate
    from radcons.params import Params
    from radcons.pipeline import Pipeline

    seen = []
    real = global_run.largest_singular_value

    def recorded(image, params=global_run.GlobalParams()):
        seen.append(params)
        return real(image, params)

    monkeypatch.setattr(global_run, "largest_singular_value", recorded)
    params = Params().with_stage("global", tolerance=1e-3, max_iterations=7)
    Pipeline(params).run(generate(size=64, seed=0, scenario="none"), until="global")
    assert seen and all(p == params.global_norm for p in seen)
