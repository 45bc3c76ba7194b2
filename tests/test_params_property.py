"""Property: any parameter value is either refused at once with a ParamsError, or the stages
run with it and fail, if at all, with a clear RadconsError (never a crash, a hang or a
memory blow-up)."""

from __future__ import annotations

import dataclasses

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from demo_data_gen import generate
from radcons.errors import ParamsError, RadconsError
from radcons.params import STAGES, Params
from radcons.pipeline import Pipeline

PAIR = generate(size=64, seed=1, scenario="mixed")
# The pair is rectified, so the rectify stage never runs: its values are checked on their own.
RUN_STAGES = [stage for stage in STAGES if stage != "rectify"]

_NUMBERS = st.one_of(
    st.integers(min_value=-(10**12), max_value=10**12),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, 1, 2, 3, 7, 64, 65, 1000, 10**9, -1, 0.5, 1e-12, 1e30]),
)


def _values_for(default: object) -> st.SearchStrategy:
    if isinstance(default, bool):
        return st.one_of(st.booleans(), _NUMBERS)
    if isinstance(default, (int, float)):
        return _NUMBERS
    if isinstance(default, str):
        return st.one_of(st.text(max_size=8), st.sampled_from(["dense", "moments", "both", "dark"]))
    if isinstance(default, tuple):
        return st.one_of(st.lists(_NUMBERS, max_size=4).map(tuple), st.just(default))
    return st.one_of(st.none(), _NUMBERS)


@st.composite
def stage_change(draw: st.DrawFn) -> tuple[str, str, object]:
    stage = draw(st.sampled_from(list(STAGES)))
    spec = draw(st.sampled_from(dataclasses.fields(Params().stage(stage))))
    default = Params().stage(stage).__getattribute__(spec.name)
    return stage, spec.name, draw(_values_for(default))


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(stage_change())
def test_any_parameter_value_is_refused_clearly_or_runs(change):
    stage, name, value = change
    try:
        params = Params.from_preset("paper").with_stage(stage, **{name: value}, enabled=True)
        from radcons.validate import check_params_for_shape

        check_params_for_shape(params, PAIR.shape)
    except ParamsError:
        event("refused")
        return
    if stage not in RUN_STAGES:
        return
    try:
        Pipeline(params).run(PAIR, until=stage)
        event("ran")
    except RadconsError:
        event("clear error from the stage")


@pytest.mark.parametrize("stage", RUN_STAGES)
def test_defaults_run_on_a_small_pair(stage):
    run = Pipeline(Params.from_preset("paper")).run(PAIR, until=stage)
    assert stage in run.results
