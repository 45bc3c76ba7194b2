"""The notice of a noise ratio a run leaves above 1.5: its rule, and summary.json carrying it."""

from __future__ import annotations

import json
import math

import pytest

from radcons.noise import NOTICE_RATIO, noise_notice
from radcons.params import STAGES, Params

RADCONS = Params.from_preset("radcons")
PAPER = Params.from_preset("paper")


@pytest.mark.parametrize(
    ("ratio", "params", "sharpness", "stages", "names"),
    [
        # the radcons preset's noise matching smoothed by its widest Gaussian
        (4.39, RADCONS, {"denoise_sigma": 0.6}, None, "[sharpness] noise_max_sigma = 0.6 px"),
        (4.39, RADCONS.with_stage("smoothness", enabled=True), {"denoise_sigma": 0.6}, None, "noise_max_sigma"),
        # the noise matching stopped short of its widest: the paper's smoothness stage is off
        (2.0, RADCONS, {"denoise_sigma": 0.31}, None, "the paper's smoothness stage ([smoothness] enabled = true)"),
        (2.0, RADCONS, {"denoise_sigma": 0.0}, None, "[smoothness] enabled = true"),
        # the paper's preset: smoothness on, the sharpness stage off
        (3.68, PAPER, None, None, '[sharpness] enabled = true, noise = "cleaner"'),
        (3.68, PAPER.with_stage("sharpness", enabled=True), {"denoise_sigma": 0.0}, None, '[sharpness] noise = "cleaner"'),
        # a run stopped before the smoothness stage it has on
        (3.68, PAPER, None, STAGES[: STAGES.index("refine") + 1], "smoothness stage (the run stopped before it)"),
        # both ran
        (1.6, PAPER.with_stage("sharpness", enabled=True, noise="cleaner"), {"denoise_sigma": 0.2}, None, "both ran"),
    ],
)
def test_the_notice_names_the_option_that_closes_the_gap(ratio, params, sharpness, stages, names):
    notice = noise_notice(ratio, params, sharpness, stages)
    assert notice.startswith(f"The noise ratio is {ratio:.2f} after the run, above 1.5: ")
    assert names in notice
    assert notice.endswith(".") and ". " not in notice  # one sentence


def test_no_notice_at_or_below_the_limit():
    for ratio in (1.0, 1.2, NOTICE_RATIO, math.nan):
        assert noise_notice(ratio, RADCONS, {"denoise_sigma": 0.6}) is None
    assert noise_notice(math.inf, PAPER) is not None  # one image noise-free, the other not


def test_a_fixed_denoise_is_not_taken_for_the_widest_smoothing():
    params = RADCONS.with_stage("sharpness", denoise=0.6)
    assert "[smoothness] enabled = true" in noise_notice(3.0, params, {"denoise_sigma": 0.6})


def test_summary_json_carries_the_noise_ratios_and_the_notice(tmp_path):
    from demo_data_gen import generate
    from radcons.io import load_pair
    from radcons.noise import noise_ratio
    from radcons.pipeline import Pipeline
    from radcons.summary import run_noise_notice, write_outputs

    # the pair of `radcons demo --size 256 --seed 4 --scenario multi-sensor`: its noise ratio of
    # 2.0 leaves the radcons preset at about 4.4, its noise matching at its widest smoothing
    pair = generate(size=256, seed=4, scenario="multi-sensor")
    run = Pipeline(RADCONS).run(pair)
    write_outputs(run, tmp_path / "out")
    noise = json.loads((tmp_path / "out" / "summary.json").read_text())["noise"]
    assert noise["ratio_original"] == pytest.approx(noise_ratio(*run.images("original")))
    written = load_pair(tmp_path / "out")  # the ratio is the written files'
    assert noise["ratio"] == pytest.approx(noise_ratio(written.reference.as_float32(), written.target.as_float32()))
    assert noise["ratio"] > 3.0
    assert noise["notice"] == run_noise_notice(run, noise["ratio"])
    assert "[sharpness] noise_max_sigma = 0.6 px" in noise["notice"]
    wider = Pipeline(RADCONS.with_stage("sharpness", noise_max_sigma=1.2)).run(pair)
    write_outputs(wider, tmp_path / "wider")
    noise = json.loads((tmp_path / "wider" / "summary.json").read_text())["noise"]
    assert noise["ratio"] <= NOTICE_RATIO and noise["notice"] is None  # the option named closes it
