"""Presets: ``paper`` keeps the paper's values, ``radcons`` the measured options; both run."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from demo_data_gen import generate
from radcons.errors import ParamsError
from radcons.params import ADDED, PRESETS, STAGES, Params
from radcons.pipeline import Pipeline
from radcons.stages.refine.run import RefineParams


def test_presets_are_named():
    assert PRESETS == ("paper", "radcons")


def test_paper_preset_is_the_papers_values_with_every_paper_stage_on():
    paper = Params.from_preset("paper")
    assert paper == Params() and paper.preset == "paper"
    assert ADDED == {"sharpness"}
    assert all(paper.enabled(name) == (name not in ADDED) for name in STAGES)
    assert paper.refine == RefineParams()
    assert (paper.refine.points, paper.refine.fit, paper.refine.background) == ("matches", "wls", "global")
    assert paper.uniformity.mu == 0.1 and paper.uniformity.zeta == 0.8


def test_radcons_preset_changes_only_what_it_names():
    paper, ours = Params.from_preset("paper"), Params.from_preset("radcons")
    assert ours.preset == "radcons"
    assert ours.disabled == frozenset({"uniformity", "smoothness"})
    assert ours.refine == RefineParams(
        points="dense", fit="moments", background="local", blend_width=0.0, clip_to_reference=True,
        agreement_gate=True, background_noise=True,
    )
    assert ours.sharpness == replace(paper.sharpness, noise="cleaner")
    assert ours.objects == replace(paper.objects, method="height")
    for name in STAGES:
        if name not in ("refine", "sharpness", "objects"):
            assert ours.stage(name) == paper.stage(name), name


def test_unknown_preset():
    with pytest.raises(ParamsError, match="unknown preset 'fast'"):
        Params.from_preset("fast")
    with pytest.raises(ParamsError, match="unknown preset"):
        Params.from_dict({"preset": "fast"})


def test_radcons_preset_round_trips_through_toml(tmp_path):
    ours = Params.from_preset("radcons").with_stage("refine", min_points=5)
    assert ours.preset == "radcons"
    back = Params.load(ours.save(tmp_path / "ours.toml"))
    assert back == ours


def test_a_partial_file_starts_from_its_preset(tmp_path):
    path = tmp_path / "few.toml"
    path.write_text('preset = "radcons"\n\n[refine]\nblend_width = 2.0\n')
    params = Params.load(path)
    assert params.refine.fit == "moments" and params.refine.blend_width == 2.0
    assert not params.enabled("uniformity") and not params.enabled("smoothness")


@pytest.fixture(scope="module")
def demo_pair():
    return generate(size=128, seed=0, scenario="mixed")


def test_both_presets_run(demo_pair):
    pipeline = Pipeline()
    ours = pipeline.run(demo_pair, Params.from_preset("radcons"))
    assert ours.final_stage == "smoothness" and ours.params.enabled("sharpness")
    assert ours.results["sharpness"].info["blurred"] in ("reference", "target", "none")
    original = ours.images("original")
    for stage in ("uniformity", "smoothness"):  # switched off: the images pass through
        assert ours.results[stage].info == {"enabled": False}
    np.testing.assert_array_equal(ours.images("uniformity")[1], original[1])
    reference, target = ours.images()
    assert np.array_equal(np.isfinite(target), np.isfinite(original[1]))
    np.testing.assert_array_equal(reference, ours.images("sharpness")[0])
    paper = pipeline.run(demo_pair, Params.from_preset("paper"), until="refine")
    assert paper.final_stage == "refine"
    assert not np.array_equal(paper.images("refine")[1], target)
