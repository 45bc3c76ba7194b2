"""GUI controls made from the stage parameters' declarations.

Each stage of :data:`radcons.stages.STAGES` gets a folder with one control per parameter,
made from its declaration (:func:`radcons.param_spec.param`): a slider over a bounded
number's range, a number input for an unbounded one, a checkbox for a bool, a dropdown of
a string's choices and a text input for a list or an optional value. The hover hint is the
declaration's help with its unit and range, and the paper's default. The basic parameters
come first; the advanced ones wait in a closed folder, ``<stage> (advanced)``. Switchable stages get an
``enabled`` checkbox, every stage a reset button that restores the preset's values.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields
from typing import Any, Callable

from radcons.param_spec import ParamSpec, describe, spec_of

__all__ = ["FieldSpec", "field_spec", "StageControls"]


@dataclass(frozen=True)
class FieldSpec:
    """How one parameter is edited.

    Attributes
    ----------
    kind : {"slider", "number", "checkbox", "dropdown", "text"}
    minimum, maximum, step : float or None
        Range and step of a slider or number input.
    choices : tuple of str
        Options of a dropdown.
    optional : bool
        The parameter may be None (a text input; empty means None).
    """

    kind: str
    minimum: float | None = None
    maximum: float | None = None
    step: float | None = None
    choices: tuple[str, ...] = ()
    optional: bool = False


def field_spec(spec: ParamSpec, default: Any) -> FieldSpec:
    """Decide how a parameter with declaration ``spec`` and default ``default`` is edited."""
    if spec.choices:
        return FieldSpec("dropdown", choices=spec.choices)
    if isinstance(default, bool):
        return FieldSpec("checkbox")
    if default is None or isinstance(default, (tuple, list)):
        return FieldSpec("text", optional=default is None)
    if isinstance(default, (int, float)):
        integer = isinstance(default, int)
        if spec.bounded:
            step = spec.step if spec.step is not None else (1 if integer else (spec.high - spec.low) / 100)
            return FieldSpec("slider", float(spec.low), float(spec.high), float(step))
        step = spec.step if spec.step is not None else (1 if integer else _magnitude(default))
        return FieldSpec("number", spec.low, spec.high, step)
    return FieldSpec("text")


def _magnitude(value: float) -> float:
    """A step a tenth of the value's order of magnitude (0.01 for zero)."""
    return 10.0 ** (math.floor(math.log10(abs(value))) - 1) if value else 0.01


def _text_value(text: str, default: Any) -> Any:
    """Parse a text input: empty is None; a number when it reads as one; a tuple for lists."""
    text = text.strip()
    if not text or text.lower() == "none":
        return None
    if isinstance(default, (tuple, list)):
        return tuple(_text_value(part, 0) for part in text.strip("()[]").split(",") if part.strip())
    for convert in (int, float):
        try:
            return convert(text)
        except ValueError:
            continue
    return text


def _text_of(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, (tuple, list)):
        return ", ".join(str(v) for v in value)
    return str(value)


class StageControls:
    """The folder of one stage: a control per parameter, ``enabled`` and ``reset``.

    Parameters
    ----------
    gui : viser.GuiApi
        Where to add the controls (inside the current container).
    stage : str
        Stage name.
    params : dataclass instance
        The stage's current parameters (their class gives the fields, the paper's
        defaults and the docs).
    enabled : bool or None
        Current enabled state; None for a stage that cannot be switched off.
    defaults : dataclass instance
        What the reset button restores (the preset's values).
    on_change : callable
        ``on_change(stage, changes, client)`` with ``changes`` a dict of new values
        (``enabled`` included) when the user edits a control.
    on_reset : callable
        ``on_reset(stage, client)`` when the reset button is pressed.
    """

    def __init__(
        self,
        gui: Any,
        stage: str,
        params: Any,
        enabled: bool | None,
        defaults: Any,
        on_change: Callable[[str, dict[str, Any], Any], None],
        on_reset: Callable[[str, Any], None],
    ) -> None:
        self.stage = stage
        self.defaults = defaults
        paper = type(params)()
        self._on_change = on_change
        self._syncing = False
        self.handles: dict[str, Any] = {}
        self.specs: dict[str, FieldSpec] = {}
        self.enabled = None
        if enabled is not None:
            self.enabled = gui.add_checkbox("enabled", enabled, hint=f"Run the {stage} stage (off: its images pass through)")
            self.enabled.on_update(lambda event: self._changed("enabled", event))
        declared = [(field, spec_of(field)) for field in fields(params)]
        for field, spec in declared:
            if spec.basic:
                self._add_control(gui, field, spec, params, paper)
        advanced = [(field, spec) for field, spec in declared if not spec.basic]
        if advanced:
            with gui.add_folder(f"{stage} (advanced)", expand_by_default=False):
                for field, spec in advanced:
                    self._add_control(gui, field, spec, params, paper)
        self.reset = gui.add_button("Reset to defaults", hint=f"Restore the preset's values of {stage}")
        self.reset.on_click(lambda event: on_reset(stage, event.client))

    def _add_control(self, gui: Any, field: dataclasses.Field, spec: ParamSpec, params: Any, paper: Any) -> None:
        """One parameter's control, its hint made from the declaration."""
        default = getattr(paper, field.name)
        control = field_spec(spec, default)
        self.specs[field.name] = control
        hint = f"{describe(spec)} (paper: {_text_of(default) or 'None'})"
        handle = self._add(gui, field.name, control, getattr(params, field.name), hint)
        handle.on_update(lambda event, name=field.name: self._changed(name, event))
        self.handles[field.name] = handle

    @staticmethod
    def _add(gui: Any, name: str, spec: FieldSpec, value: Any, hint: str) -> Any:
        if spec.kind == "checkbox":
            return gui.add_checkbox(name, bool(value), hint=hint)
        if spec.kind == "dropdown":
            options = spec.choices if str(value) in spec.choices else (*spec.choices, str(value))
            return gui.add_dropdown(name, options, initial_value=str(value), hint=hint)
        if spec.kind == "slider":
            low = min(spec.minimum, value)
            high = max(spec.maximum, value)
            return gui.add_slider(name, min=low, max=high, step=spec.step, initial_value=value, hint=hint)
        if spec.kind == "number":
            return gui.add_number(name, value, min=spec.minimum, max=spec.maximum, step=spec.step, hint=hint)
        return gui.add_text(name, _text_of(value), hint=hint)

    def value_of(self, name: str) -> Any:
        """The current value of control ``name``, converted to the parameter's type."""
        handle = self.handles[name]
        spec = self.specs[name]
        default = getattr(self.defaults, name)
        if spec.kind == "text":
            return _text_value(handle.value, default)
        if isinstance(default, int) and not isinstance(default, bool):
            value = handle.value  # NaN or inf (sent by a client) go on to be refused with a message
            return int(round(value)) if isinstance(value, (int, float)) and math.isfinite(value) else value
        if isinstance(default, float):
            return float(handle.value)
        return handle.value

    def _changed(self, name: str, event: Any) -> None:
        if self._syncing:
            return
        if name == "enabled":
            self._on_change(self.stage, {"enabled": bool(self.enabled.value)}, event.client)
            return
        self._on_change(self.stage, {name: self.value_of(name)}, event.client)

    def show(self, params: Any, enabled: bool | None) -> None:
        """Set every control to ``params`` (and ``enabled``) without firing ``on_change``."""
        self._syncing = True
        try:
            if self.enabled is not None and enabled is not None:
                self.enabled.value = enabled
            for name, handle in self.handles.items():
                value = getattr(params, name)
                spec = self.specs[name]
                handle.value = _text_of(value) if spec.kind == "text" else (str(value) if spec.kind == "dropdown" else value)
        finally:
            self._syncing = False
