"""GUI controls generated from the stage parameter dataclasses.

Each stage of :data:`radcons.params.STAGES` gets a folder with one control per field of its
params dataclass: a slider where a sensible range is known, a number input otherwise, a
checkbox for a bool and a dropdown for a string with known choices. The choices and ranges
come, in this order, from the field's ``metadata`` (``choices``, ``range``, ``step``), a
``Literal[...]`` annotation, the table :data:`KNOWN` below, the stage module's own tuple of
allowed values (the one holding the default, e.g. ``_FITS = ("wls", "moments")``), and
finally the type and default value. Hover hints are the field descriptions of the
dataclass's numpydoc ``Attributes`` section and the paper's default. Switchable stages get
an ``enabled`` checkbox, every stage a reset button that restores the preset's values.
"""

from __future__ import annotations

import dataclasses
import math
import re
import sys
import typing
from dataclasses import dataclass, fields
from typing import Any, Callable

__all__ = ["FieldSpec", "KNOWN", "field_spec", "module_choices", "StageControls", "parse_attribute_docs"]


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


#: Ranges and choices known for the paper's parameters, ``(stage, field) -> FieldSpec``.
#: Only what the dataclass itself cannot tell (its type and default tell the rest).
KNOWN: dict[tuple[str, str], FieldSpec] = {
    ("association", "ratio"): FieldSpec("slider", 0.5, 1.0, 0.01),
    # the objects stage's method and the height method's thresholds
    # (radcons.stages.objects_height.check_height_params holds the allowed values)
    ("objects", "method"): FieldSpec("dropdown", choices=("mbi", "height")),
    ("objects", "census_cross_check"): FieldSpec("dropdown", choices=("accurate", "fast", "none")),
    ("objects", "census_side"): FieldSpec("slider", 64, 4096, 64),
    ("objects", "ground_window_m"): FieldSpec("slider", 20.0, 500.0, 10.0),
    ("objects", "ground_percentile"): FieldSpec("slider", 0.0, 50.0, 1.0),
    ("objects", "min_height_m"): FieldSpec("slider", 0.5, 20.0, 0.5),
    ("objects", "min_height_px"): FieldSpec("slider", 0.5, 20.0, 0.5),
    ("objects", "split_jump_m"): FieldSpec("slider", 0.5, 30.0, 0.5),
    ("objects", "split_jump_px"): FieldSpec("slider", 0.5, 20.0, 0.5),
    ("objects", "assumed_gsd_m"): FieldSpec("slider", 0.05, 5.0, 0.05),
    ("objects", "tree_texture"): FieldSpec("slider", 0.5, 5.0, 0.05),
    ("objects", "flat_edges"): FieldSpec("slider", 0.0, 10.0, 0.1),
    ("objects", "min_match_score"): FieldSpec("slider", -1.0, 1.0, 0.05),
    ("association", "invariant_threshold"): FieldSpec("slider", 0.5, 10.0, 0.5),
    ("smoothness", "gamma"): FieldSpec("slider", 0.05, 2.0, 0.05),
    ("uniformity", "mu"): FieldSpec("slider", 0.01, 1.0, 0.01),
    ("uniformity", "zeta"): FieldSpec("slider", 0.05, 1.0, 0.01),
    ("uniformity", "sigma"): FieldSpec("slider", 0.5, 20.0, 0.5),
    ("uniformity", "epsilon"): FieldSpec("slider", 0.001, 0.2, 0.001),
}


def parse_attribute_docs(cls: type) -> dict[str, str]:
    """Return ``name -> description`` from the numpydoc ``Attributes`` section of ``cls``."""
    doc = cls.__doc__ or ""
    match = re.search(r"Attributes\n\s*-+\n(.*?)(?:\n\s*\n\s*[A-Z][a-z]+\n\s*-+\n|\Z)", doc, re.S)
    if not match:
        return {}
    described: dict[str, str] = {}
    names: list[str] = []
    for line in match.group(1).splitlines():
        header = re.match(r"^\s{0,4}([A-Za-z_][\w, ]*?)\s*:\s*\S", line)
        if header and not line.startswith(" " * 8):
            names = [n.strip() for n in header.group(1).split(",")]
            for name in names:
                described[name] = ""
        elif names and line.strip():
            for name in names:
                described[name] = (described[name] + " " + line.strip()).strip()
    return described


def _literal_choices(annotation: Any) -> tuple[str, ...]:
    if typing.get_origin(annotation) is typing.Literal:
        return tuple(str(a) for a in typing.get_args(annotation))
    for argument in typing.get_args(annotation):
        choices = _literal_choices(argument)
        if choices:
            return choices
    return ()


def module_choices(cls: type, default: Any) -> tuple[str, ...]:
    """The allowed values of a string parameter, read from its module.

    A stage module validates a string parameter against a module-level tuple (or dict) of
    strings; the smallest such collection holding ``default`` is taken as the choices.
    """
    if not isinstance(default, str) or isinstance(default, bool):
        return ()
    module = sys.modules.get(cls.__module__)
    best: tuple[str, ...] = ()
    for value in vars(module).values() if module is not None else ():
        if isinstance(value, dict):
            value = tuple(value)
        if (
            isinstance(value, tuple)
            and len(value) > 1
            and all(isinstance(v, str) for v in value)
            and default in value
            and (not best or len(value) < len(best))
        ):
            best = value
    return best


def field_spec(
    stage: str, field: dataclasses.Field, default: Any, annotation: Any = None, owner: type | None = None
) -> FieldSpec:
    """Decide how parameter ``field`` of ``stage`` is edited (see the module docstring).

    ``owner`` is the params dataclass, whose module may list the allowed strings.
    """
    meta = field.metadata or {}
    if "choices" in meta:
        return FieldSpec("dropdown", choices=tuple(str(c) for c in meta["choices"]))
    if "range" in meta:
        low, high = meta["range"]
        return FieldSpec("slider", float(low), float(high), float(meta.get("step", (high - low) / 100)))
    choices = _literal_choices(annotation)
    if choices:
        return FieldSpec("dropdown", choices=choices)
    if (stage, field.name) in KNOWN:
        return KNOWN[(stage, field.name)]
    choices = module_choices(owner, default) if owner is not None else ()
    if choices:
        return FieldSpec("dropdown", choices=choices)
    if isinstance(default, bool):
        return FieldSpec("checkbox")
    if default is None or isinstance(default, (tuple, list)):
        return FieldSpec("text", optional=default is None)
    if isinstance(default, int):
        low = 0 if default >= 0 else None
        return FieldSpec("number", low, None, 1)
    if isinstance(default, float):
        if 0.0 < default <= 1.0:
            return FieldSpec("slider", 0.0, 1.0, 0.01)
        magnitude = 10.0 ** (math.floor(math.log10(abs(default))) - 1) if default else 0.01
        return FieldSpec("number", 0.0 if default >= 0 else None, None, magnitude)
    return FieldSpec("text")


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
        docs = parse_attribute_docs(type(params))
        try:
            hints = typing.get_type_hints(type(params))
        except Exception:  # noqa: BLE001 - unresolvable annotations: fall back to values
            hints = {}
        self.enabled = None
        if enabled is not None:
            self.enabled = gui.add_checkbox("enabled", enabled, hint=f"Run the {stage} stage (off: its images pass through)")
            self.enabled.on_update(lambda event: self._changed("enabled", event))
        for field in fields(params):
            value = getattr(params, field.name)
            default = getattr(paper, field.name)
            spec = field_spec(stage, field, default, hints.get(field.name), type(params))
            self.specs[field.name] = spec
            hint = (docs.get(field.name) or field.name) + f" (paper: {_text_of(default) or 'None'})"
            handle = self._add(gui, field.name, spec, value, hint)
            handle.on_update(lambda event, name=field.name: self._changed(name, event))
            self.handles[field.name] = handle
        self.reset = gui.add_button("Reset to defaults", hint=f"Restore the preset's values of {stage}")
        self.reset.on_click(lambda event: on_reset(stage, event.client))

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
