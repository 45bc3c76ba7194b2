"""Census + SGM dense matching through Pandora: sign, accuracy, invariance, CLI parity, errors."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import rasterio
from scipy import ndimage

from demo_data_gen import generate
from radcons.numerics.census import CensusParams, census_disparity, census_memory_bytes, to_census_input
from radcons.errors import InputError, ParamsError, StageError
from radcons.evaluate import MATCHERS, matcher_name, matcher_params
from radcons.evaluate.matching import MatcherParams, dense_disparity, disparity_range_from_truth
from radcons.evaluate.rates import correct_matching_rate
from radcons.evaluate.truth_pairs import load_motorcycle

from pandora_cli import run_pandora_cli

ROWS, COLS = 128, 192
#: Disparity of each band of 32 rows, in the project's convention.
BANDS = (-3, 2, 7, 12)


def banded_pair() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Textured reference, target and truth with ``reference(x, y) = target(x - d, y)``.

    Four bands of rows move by the disparities of :data:`BANDS`; where the match falls
    outside the target the truth is unknown (NaN).
    """
    rng = np.random.default_rng(0)
    margin = 16
    wide = ndimage.gaussian_filter(rng.normal(size=(ROWS, COLS + 2 * margin)), 1.2)
    wide = (800.0 + 600.0 * wide / np.abs(wide).max()).astype(np.float32)
    reference = wide[:, margin:margin + COLS].copy()
    target = np.empty_like(reference)
    truth = np.empty(reference.shape, np.float32)
    height = ROWS // len(BANDS)
    for index, d in enumerate(BANDS):
        rows = slice(index * height, (index + 1) * height)
        # target(x') = wide(x' + margin + d), so target(x - d) = wide(x + margin) = reference(x)
        target[rows] = wide[rows, margin + d:margin + d + COLS]
        truth[rows] = d
    columns = np.arange(COLS)[None, :]
    truth[(columns - truth < 0) | (columns - truth >= COLS)] = np.nan
    return reference, target, truth


def same_fraction(first: np.ndarray, second: np.ndarray, tolerance: float = 0.5) -> float:
    """Share of the pixels valid in either map where both are valid and within ``tolerance``."""
    both = np.isfinite(first) & np.isfinite(second)
    either = np.isfinite(first) | np.isfinite(second)
    return float((np.abs(first - second)[both] <= tolerance).sum() / either.sum())


@pytest.fixture(scope="module")
def banded() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The banded pair and its census disparity (the first call also pays numba's compile)."""
    reference, target, truth = banded_pair()
    return reference, target, truth, census_disparity(reference, target, (-6, 15))


@pytest.fixture(scope="module")
def demo():
    """The demo pair without radiometric difference, its search range and census disparity."""
    pair = generate(size=256, seed=0, scenario="none")
    reference, target = pair.reference.as_float32(), pair.target.as_float32()
    search = disparity_range_from_truth(pair.disparity)
    return pair, search, census_disparity(reference, target, search)


# ----------------------------------------------------------------------------- accuracy


def test_recovers_banded_disparity_with_sign(banded):
    reference, _, truth, disparity = banded
    assert disparity.dtype == np.float32 and disparity.shape == reference.shape
    assert correct_matching_rate(disparity, truth) > 0.9
    known = np.isfinite(truth) & np.isfinite(disparity)
    assert (np.abs(disparity - truth)[known] < 1).mean() > 0.97
    height = ROWS // len(BANDS)
    for index, d in enumerate(BANDS):
        inside = disparity[index * height + 6:(index + 1) * height - 6, 24:COLS - 24]
        assert np.nanmedian(inside) == pytest.approx(d, abs=0.25)


def test_demo_pair_against_its_ground_truth(demo):
    pair, _, disparity = demo
    assert correct_matching_rate(disparity, pair.disparity) > 0.85


def test_motorcycle_against_its_ground_truth():
    pair = load_motorcycle(downsample=3)  # 166 x 247, Middlebury truth in the project's sign
    disparity = census_disparity(
        pair.reference.as_float32(), pair.target.as_float32(), disparity_range_from_truth(pair.disparity)
    )
    assert correct_matching_rate(disparity, pair.disparity) > 0.8


def test_no_data_pixels_give_nan(banded):
    reference, target, truth, _ = banded
    reference, target = reference.copy(), target.copy()
    reference[10:20, 60:70] = np.nan
    target[40:50, 100:110] = np.nan  # band 2 (d = 2): seen from reference columns 102..111
    disparity = census_disparity(reference, target, (-6, 15))
    assert np.isnan(disparity[10:20, 60:70]).all()
    assert np.isnan(disparity[40:50, 102:112]).all()
    assert correct_matching_rate(disparity, truth) > 0.85


# ----------------------------------------------------------------------------- invariance


def test_monotone_stretch_leaves_census_unchanged_but_not_sgbm(demo):
    pair, search, disparity = demo
    reference, target = pair.reference.as_float32(), pair.target.as_float32().astype(np.float64)
    low, high = target.min(), target.max()
    stretched = (low + (high - low) * ((target - low) / (high - low)) ** 0.5).astype(np.float32)  # gamma 0.5
    stretched = 1.7 * stretched + 25.0  # gain and offset
    census_same = same_fraction(disparity, census_disparity(reference, stretched, search))
    sgbm = dense_disparity(reference, target.astype(np.float32), MatcherParams(), search)
    sgbm_same = same_fraction(sgbm, dense_disparity(reference, stretched, MatcherParams(), search))
    assert census_same >= 0.95
    assert sgbm_same < census_same - 0.05


# ----------------------------------------------------------------------------- Pandora's CLI


@pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")
def test_agrees_with_pandoras_command_line(banded, tmp_path):
    command = Path(sys.executable).with_name("pandora")
    if not command.exists():
        pytest.skip("Pandora's command line is not installed beside this Python")
    from pandora.criteria import Criteria

    reference, target, _, _ = banded
    reference, target = reference.copy(), target.copy()
    reference[10:20, 60:70] = np.nan
    target[70:80, 120:130] = np.nan
    low, high = -6, 15
    ours = census_disparity(reference, target, (low, high))

    profile = {"driver": "GTiff", "width": COLS, "height": ROWS, "count": 1, "dtype": "float32"}
    for name, image in (("left.tif", reference), ("right.tif", target)):
        with rasterio.open(tmp_path / name, "w", **profile) as dst:
            dst.write(to_census_input(image), 1)
    theirs, validity = run_pandora_cli(command, tmp_path / "left.tif", tmp_path / "right.tif", low, high, tmp_path / "out")
    theirs = -theirs  # Pandora's sign is the opposite of the project's
    invalid = (validity.astype(np.int64) & int(Criteria.PANDORA_MSK_PIXEL_INVALID)) != 0
    theirs[invalid] = np.nan

    assert (np.isnan(ours) != np.isnan(theirs)).mean() < 0.001
    both = np.isfinite(ours) & np.isfinite(theirs)
    np.testing.assert_allclose(ours[both], theirs[both], atol=1e-4)


# ----------------------------------------------------------------------------- interface


def test_dense_disparity_runs_the_matcher_of_its_parameters(banded):
    reference, target, _, disparity = banded
    np.testing.assert_array_equal(dense_disparity(reference, target, CensusParams(), (-6, 15)), disparity)
    assert set(MATCHERS) == {"sgbm", "census"}
    assert matcher_name(matcher_params("census")) == "census"
    assert matcher_name(MatcherParams()) == "sgbm"
    assert matcher_params("census", p2=40.0) == CensusParams(p2=40.0)
    with pytest.raises(ParamsError, match="unknown matcher"):
        matcher_params("mc-cnn")
    with pytest.raises(ParamsError, match="census"):
        matcher_params("census", block_size=5)
    with pytest.raises(ParamsError, match="disparity range"):
        dense_disparity(reference, target, CensusParams())


def test_each_image_is_mapped_on_its_own_range():
    image = np.linspace(-50.0, 4000.0, 1000, dtype=np.float32).reshape(20, 50)
    image[0, 0] = np.nan
    mapped = to_census_input(image)
    assert mapped.dtype == np.float32 and np.isnan(mapped[0, 0])
    finite = image[np.isfinite(image)]
    low, high = np.percentile(finite, [0.5, 99.5])
    np.testing.assert_allclose(mapped[1:, :], (image[1:, :] - low) * 255.0 / (high - low), rtol=1e-5, atol=1e-3)
    assert np.all(np.diff(mapped.ravel()[1:]) > 0)  # increasing, nothing clipped
    np.testing.assert_allclose(to_census_input(3.0 * image + 7.0), mapped, rtol=1e-4, atol=1e-3)


# ----------------------------------------------------------------------------- errors


def test_bad_input_gives_clear_errors(banded):
    reference, target, _, _ = banded
    with pytest.raises(InputError, match="same shape"):
        census_disparity(reference, target[:, :-1], (0, 10))
    with pytest.raises(InputError, match="2-D"):
        census_disparity(np.stack([reference, reference]), target, (0, 10))
    with pytest.raises(InputError, match="census window"):
        census_disparity(reference[:4, :4], target[:4, :4], (0, 1))
    with pytest.raises(InputError, match="NaN"):
        census_disparity(np.full_like(reference, np.nan), target, (0, 10))
    with pytest.raises(ParamsError, match="high >= low"):
        census_disparity(reference, target, (10, 2))
    with pytest.raises(ParamsError, match="finite"):
        census_disparity(reference, target, (0, np.inf))
    with pytest.raises(ParamsError, match=r"-1e\+06\.\.1e\+06 would need about .* GiB"):
        census_disparity(reference, target, (-1e6, 1e6))
    with pytest.raises(ParamsError, match="memory limit"):
        census_disparity(reference, target, (-6, 15), CensusParams(memory_limit_gib=0.001))


def test_memory_estimate_grows_with_the_range_and_the_cross_check():
    narrow = census_memory_bytes((1000, 1000), (0, 63))
    assert narrow > 1000 * 1000 * 64 * 4 * 4  # at least four cost volumes' worth
    assert census_memory_bytes((1000, 1000), (0, 127)) > 1.7 * narrow
    assert census_memory_bytes((1000, 1000), (0, 63), CensusParams(cross_check="none")) < narrow


def test_pandora_failure_is_one_line(banded, monkeypatch):
    import pandora

    def fail(*args, **kwargs):
        raise ValueError("something broke\n  in a second line")

    monkeypatch.setattr(pandora, "run", fail)
    reference, target, _, _ = banded
    with pytest.raises(StageError, match="^Pandora census matching failed: something broke in a second line$"):
        census_disparity(reference, target, (0, 10))


def test_pandora_failure_names_the_pair_and_method(banded, monkeypatch):
    import pandora

    from radcons.evaluate.compare import evaluate_methods
    from radcons.io import Pair, Raster

    def fail(*args, **kwargs):
        raise RuntimeError("cost volume\nbroken")

    monkeypatch.setattr(pandora, "run", fail)
    reference, target, truth, _ = banded
    pair = Pair(Raster(reference), Raster(target), disparity=truth, name="bands")
    with pytest.raises(StageError, match="^pair bands, method 'ours': Pandora census matching failed: cost volume broken$"):
        evaluate_methods(pair, {"ours": (reference, target)}, matcher=CensusParams())


@pytest.mark.parametrize(
    "changes",
    [
        {"window_size": 4},
        {"p1": 32.0, "p2": 8.0},
        {"refinement": "spline"},
        {"median_size": 4},
        {"cross_check": "both"},
        {"cross_check_threshold": 0.0},
        {"memory_limit_gib": -1.0},
    ],
)
def test_census_params_are_checked(changes):
    with pytest.raises(ParamsError):
        CensusParams(**changes)


@pytest.mark.parametrize("cross_check", ["fast", "none"])
def test_other_settings_run(banded, cross_check):
    reference, target, truth, _ = banded
    params = CensusParams(cross_check=cross_check, refinement="quadratic", median_size=0)
    assert correct_matching_rate(census_disparity(reference, target, (-6, 15), params), truth) > 0.9


def test_repeated_calls_free_pandoras_cost_volumes_without_a_collection():
    import gc
    import tracemalloc

    reference, target, _ = banded_pair()
    census_disparity(reference, target, (-40, 40), CensusParams())  # warm-up: imports, numba
    volume = census_memory_bytes(reference.shape, (-40, 40), CensusParams())
    gc.collect()
    gc.disable()  # only reference counting frees memory: a cycle that holds the volumes would stay
    try:
        tracemalloc.start()
        for _ in range(6):
            census_disparity(reference, target, (-40, 40), CensusParams())
        held = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
        gc.enable()
    # six runs' volumes (about 6 x volume) would stay without freeing; one run's tables may
    assert held < volume


@pytest.mark.parametrize("size", [3, 5])
@pytest.mark.parametrize("rows_at_once", ["all", "one"])
def test_median_filter_is_the_windowed_nan_median(size, rows_at_once, monkeypatch):
    """Pandora's median step, as radcons gives it: each inner window's NaN-ignoring median."""
    from types import SimpleNamespace

    import radcons.numerics.census
    from radcons.numerics.census import _median_filter

    if rows_at_once == "one":  # the blocks that bound the memory of a large map, one row each
        monkeypatch.setattr(radcons.numerics.census, "_MEDIAN_CHUNK_VALUES", 1)

    rng = np.random.default_rng(size)
    data = (rng.integers(-20, 20, (23, 31)) / 2).astype(np.float32)  # ties and half pixels
    data[rng.random(data.shape) < 0.35] = np.nan  # even counts of valid neighbours too
    data[4:10, 5:12] = np.nan  # windows with no valid value
    radius = size // 2

    expected = data.copy()
    for row in range(radius, data.shape[0] - radius):
        for col in range(radius, data.shape[1] - radius):
            window = data[row - radius : row + radius + 1, col - radius : col + radius + 1]
            if np.isfinite(data[row, col]):
                expected[row, col] = np.nanmedian(window)

    filtered = _median_filter(SimpleNamespace(_filter_size=size), data)

    np.testing.assert_array_equal(filtered, expected)  # NaN where NaN, borders as given
    assert filtered.dtype == data.dtype
