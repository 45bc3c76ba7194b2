"""The Tune tab: a preset, one folder of controls per stage, and the stage timings.

Every change sets the session's parameters and asks for a run
(:meth:`inspector.runner.Runner.request_run`). A value goes through the checks of the
command line first (the stage parameters' own checks, :func:`radcons.validate.check_fields`
among them, then :func:`radcons.validate.check_params_for_shape` against the pair tuned on):
a bad one is refused with its message in the page, its control is set back and the last
good result stays on screen. Each stage's reset button gives it the preset's values back. The smoothness
stage runs when asked for ("Run smoothness now") or after each change, in a fast mode on
previews and regions unless told otherwise.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from inspector.context import Context
from inspector.panels.base import Panel
from inspector.runner import Runner
from inspector.widgets import StageControls
from radcons.errors import ParamsError
from radcons.io import Pair
from radcons.stages import STAGE
from radcons.validate import check_params_for_shape

__all__ = ["TuningPanel", "SMOOTHNESS_MODES"]

#: When the smoothness stage runs during tuning.
SMOOTHNESS_MODES: tuple[str, ...] = ("on request", "after each change")


def smallest_shape(pair: Pair) -> tuple[int, int]:
    """Rows and columns of the smaller of a pair's two images, as the pipeline checks them."""
    (r1, c1), (r2, c2) = pair.reference.data.shape[:2], pair.target.data.shape[:2]
    return min(r1, r2), min(c1, c2)


class TuningPanel(Panel):
    """Edits the session's parameters and asks for runs.

    Parameters
    ----------
    context : Context
    runner : Runner
        Runs the pipeline after each change.

    Attributes
    ----------
    stages : dict
        Stage name -> its :class:`~inspector.widgets.StageControls`.
    """

    def __init__(self, context: Context, runner: Runner) -> None:
        super().__init__(context)
        self.runner = runner
        self.stages: dict[str, StageControls] = {}

    def build(self, gui: Any) -> None:
        """Add the preset choice, the timings, a folder per stage and the global reset,
        all set to the session's parameters."""
        from radcons.params import PRESETS, STAGES, SWITCHABLE

        session = self.context.session
        params = session.params
        self.preset = gui.add_dropdown(
            "Preset", tuple(PRESETS), initial_value=params.preset,
            hint="paper: the paper's method and values; radcons: the measured improvements (changing it resets every stage)",
        )
        self.preset.on_update(self.on_preset)
        self.timings = gui.add_markdown("")
        for stage in STAGES:
            with gui.add_folder(stage, expand_by_default=False):
                if stage == "smoothness":
                    self._build_smoothness_runs(gui)
                self.stages[stage] = StageControls(
                    gui, stage, params.stage(stage), params.enabled(stage) if stage in SWITCHABLE else None,
                    params.stage(stage), self.on_param_change, self.on_stage_reset,
                )
        self.reset_all = gui.add_button("Reset every stage")
        self.reset_all.on_click(self.on_reset_all)

    def _build_smoothness_runs(self, gui: Any) -> None:
        """The controls of when and how the slow smoothness stage runs."""
        session = self.context.session
        self.smoothness_mode = gui.add_dropdown(
            "runs", SMOOTHNESS_MODES, initial_value=SMOOTHNESS_MODES[int(session.smoothness_live)],
            hint="Union group sparse denoising is slow: run it when asked, or after every change",
        )
        self.smoothness_mode.on_update(self.on_smoothness_mode)
        self.fast_smoothness = gui.add_checkbox(
            "fast on previews", session.fast_previews,
            hint="On a downsampled preview or a region, half the similar patches and a "
            "15 px search window (a 512 px pair in under 2 s); full resolution runs "
            "the values below",
        )
        self.fast_smoothness.on_update(self.on_fast_smoothness)
        self.run_smoothness = gui.add_button("Run smoothness now")
        self.run_smoothness.on_click(self.on_run_smoothness)

    # ------------------------------------------------------------------ parameters

    def on_param_change(self, stage: str, changes: dict[str, Any], client: Any) -> None:
        """Apply edited values of ``stage`` (refused, and the controls set back, when invalid)."""
        session = self.context.session
        with session.lock:
            try:
                params = session.params.with_stage(stage, **changes)
                if session.work is not None:
                    check_params_for_shape(params, smallest_shape(session.work.pair))
            except ParamsError as exc:
                controls = self.stages[stage]
                current = session.params
                controls.show(current.stage(stage), current.enabled(stage) if controls.enabled is not None else None)
                self.context.notify(client, f"Invalid {stage} parameter", exc.reason)
                return
            if params == session.params:
                return
            session.params = params
        self.runner.request_run()

    def on_stage_reset(self, stage: str, client: Any) -> None:
        """Give a stage its preset's values back (and switch it as the preset does)."""
        from radcons.params import SWITCHABLE, Params

        session = self.context.session
        with session.lock:
            preset = Params.from_preset(session.params.preset)
            params = replace(session.params, **{STAGE[stage].package: preset.stage(stage)})
            if stage in SWITCHABLE:
                params = params.with_stage(stage, enabled=preset.enabled(stage))
            session.params = params
            self._show_params(params)
        self.runner.request_run()

    def on_preset(self, event: Any) -> None:
        """Another preset was chosen: every stage takes its values."""
        if self.quiet:
            return
        self.use_preset(self.preset.value)

    def on_reset_all(self, event: Any) -> None:
        """Give every stage the current preset's values back."""
        self.use_preset(self.context.session.params.preset)

    def use_preset(self, name: str) -> None:
        """Set every stage to the values of preset ``name``."""
        from radcons.params import Params

        session = self.context.session
        with session.lock:
            session.params = Params.from_preset(name)
            self._show_params(session.params)
        self.set_quietly(self.preset, name)
        for controls in self.stages.values():
            controls.defaults = session.params.stage(controls.stage)
        self.runner.request_run()

    def _show_params(self, params: Any) -> None:
        for stage, controls in self.stages.items():
            controls.show(params.stage(stage), params.enabled(stage) if controls.enabled is not None else None)

    # ------------------------------------------------------------------ smoothness

    def on_smoothness_mode(self, event: Any) -> None:
        """Run the smoothness stage after each change, or on request only."""
        with self.context.session.lock:
            self.context.session.smoothness_live = self.smoothness_mode.value == SMOOTHNESS_MODES[1]
        self.runner.request_run()

    def on_fast_smoothness(self, event: Any) -> None:
        """Run the smoothness stage in its fast mode on previews and regions, or not."""
        with self.context.session.lock:
            self.context.session.fast_previews = bool(self.fast_smoothness.value)
        self.runner.request_run()

    def on_run_smoothness(self, event: Any) -> None:
        """Run on to the smoothness stage once."""
        with self.context.session.lock:
            self.context.session.smoothness_asked = True
        self.runner.request_run()

    # ------------------------------------------------------------------ timings

    def show_timings(self, run: Any, final: bool) -> None:
        """Show the seconds each stage of a published run took (and "Ready" once final)."""
        cells = [
            f"{name} {'cached' if run.cached.get(name) else f'{seconds:.2f} s'}"
            for name, seconds in run.timings.items()
        ]
        self.timings.content = "<sub>" + " · ".join(cells) + "</sub>"
        if final:
            self.context.set_status(f"Ready · computed in {run.total_time:.2f} s", 100.0)
