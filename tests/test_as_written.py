"""The images radcons writes are measured as its output files hold them."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from demo_data_gen import generate
from radcons.baselines import BASELINES
from radcons.evaluate.matching import dense_disparity
from radcons.evaluate.measure import as_written
from radcons.evaluate.rates import correct_matching_rate
from radcons.io import Raster, load_pair
from radcons.numerics.census import CensusParams
from radcons.params import Params
from radcons.pipeline import Pipeline
from radcons.summary import write_outputs
from radcons.workflow import evaluate_run_matchers


def _pair(dtype):
    pair = generate(size=96, seed=0, scenario="mixed")
    return replace(
        pair,
        reference=Raster(pair.reference.data.astype(dtype)),
        target=Raster(pair.target.data.astype(dtype)),
    )


def test_an_integer_pair_is_rounded_to_whole_levels():
    pair = _pair(np.uint8)
    rng = np.random.default_rng(0)
    reference = rng.uniform(-20, 280, (96, 96)).astype(np.float32)
    target = reference + np.float32(0.3)
    target[5, 7] = np.nan
    got_reference, got_target = as_written(pair, reference, target)
    expected = np.clip(np.floor(reference.astype(np.float64) + 0.5), 0, 255)  # no value sits at .5
    np.testing.assert_array_equal(got_reference, expected.astype(np.float32))
    assert np.isnan(got_target[5, 7]) and np.isfinite(np.delete(got_target.ravel(), 5 * 96 + 7)).all()
    assert got_reference.dtype == np.float32 and set(np.unique(got_reference)) <= set(range(256))


def test_a_float_pair_is_measured_as_it_is():
    pair = _pair(np.float32)
    reference = np.linspace(0, 1, 96 * 96, dtype=np.float32).reshape(96, 96)
    got = as_written(pair, reference, reference + np.float32(1e-3))
    assert got[0] is reference and np.array_equal(got[1], reference + np.float32(1e-3))


def test_the_evaluation_reads_what_process_writes(tmp_path):
    """Census on the files written by ``radcons process`` gives the evaluation's rate for
    ``ours``; on the float images it gives another disparity (the test is not vacuous)."""
    pair = generate(size=128, seed=1, scenario="mixed")
    run = Pipeline(Params.from_preset("radcons")).run(pair)
    census = CensusParams()
    comparison = evaluate_run_matchers(run, ["zhang", "ours"], [census]).first
    write_outputs(run, tmp_path / "out")
    written = load_pair(tmp_path / "out")
    assert written.target.data.dtype == pair.target.data.dtype
    disparity = dense_disparity(written.reference.as_float32(), written.target.as_float32(), census, comparison.disparity_range)
    zhang, ours = comparison.methods
    np.testing.assert_array_equal(disparity, ours.disparity)
    assert correct_matching_rate(disparity, run.working_pair.disparity) == ours.correct_rate
    floats = dense_disparity(*run.images(), census, comparison.disparity_range)
    assert not np.array_equal(floats, disparity, equal_nan=True)
    # a baseline, which radcons does not write, is measured as computed (this one's values
    # leave the 16-bit range, which a file would clip)
    reference, target = run.images("original")
    computed = BASELINES["zhang"](reference, target)
    assert np.nanmin(computed) < 0
    np.testing.assert_array_equal(zhang.disparity, dense_disparity(reference, computed, census, comparison.disparity_range))
