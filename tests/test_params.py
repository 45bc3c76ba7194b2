"""Params: paper defaults, TOML round trip, switching stages off, clear errors."""

from __future__ import annotations

import math

import pytest

from radcons.errors import ParamsError
from radcons.params import ADDED, STAGES, Params


def test_paper_defaults():
    params = Params()
    assert params.uniformity.mu == 0.1 and params.uniformity.zeta == 0.8
    assert params.association.min_matches == 2
    assert params.association.invariant_threshold == 2.0
    assert params.smoothness.patch_size == 8 and params.smoothness.n_similar == 30
    assert math.isclose(params.smoothness.c, 2 * math.sqrt(2))
    assert all(params.enabled(name) == (name not in ADDED) for name in STAGES)


def test_toml_round_trip(tmp_path):
    params = (
        Params()
        .with_stage("uniformity", mu=0.2, zeta=0.7)
        .with_stage("smoothness", enabled=False)
        .with_stage("association", min_matches=4)
    )
    path = params.save(tmp_path / "p.toml")
    back = Params.load(path)
    assert back == params
    assert not back.enabled("smoothness") and back.uniformity.mu == 0.2
    text = path.read_text()
    assert "[uniformity]" in text and "[global]" in text and "enabled = false" in text


def test_partial_file_keeps_defaults(tmp_path):
    path = tmp_path / "few.toml"
    path.write_text("[uniformity]\nzeta = 0.9\n\n[refine]\nenabled = false\n")
    params = Params.load(path)
    assert params.uniformity.zeta == 0.9 and params.uniformity.mu == 0.1
    assert not params.enabled("refine") and params.enabled("global")


@pytest.mark.parametrize(
    "text, message",
    [
        ("[uniformty]\nmu = 0.1\n", r"unknown table \[uniformty\]"),
        ("[uniformity]\nmoo = 0.1\n", "has no parameter 'moo'"),
        ("[uniformity]\nmu = \"high\"\n", "mu must be a number"),
        ("[association]\nmin_matches = 2.5\n", "min_matches must be an integer"),
        ("[objects]\nenabled = false\n", "cannot be switched off"),
        ("[uniformity\n", "malformed TOML"),
    ],
)
def test_bad_files(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ParamsError, match=message) as info:
        Params.load(path)
    assert "bad.toml" in str(info.value)


def test_missing_file(tmp_path):
    with pytest.raises(ParamsError, match="not found"):
        Params.load(tmp_path / "nope.toml")


def test_a_file_starts_from_its_preset(tmp_path):
    from radcons.params import DEFAULT_PRESET

    path = tmp_path / "p.toml"
    path.write_text('preset = "paper"\n[uniformity]\nzeta = 0.9\n')
    assert Params.load(path) == Params().with_stage("uniformity", zeta=0.9)
    path.write_text("[uniformity]\nzeta = 0.9\n")
    assert Params.load(path) == Params.from_preset(DEFAULT_PRESET).with_stage("uniformity", zeta=0.9)
    path.write_text('preset = "fancy"\n')
    with pytest.raises(ParamsError, match="unknown preset 'fancy'"):
        Params.load(path)
