"""One declaration per stage parameter: its default, range or choices, unit, help and level.

A stage's frozen params dataclass declares each field with :func:`param`; everything
else is made from that declaration:

- validation (:func:`check_declared`, called in each params class's ``__post_init__``):
  the type of the default, finite numbers, the range, the choices;
- the parameter file (``radcons params`` writes the help above each key);
- the inspector's controls (a slider over the range, a dropdown of the choices, the help
  as hover hint; the basic parameters shown, the advanced ones in a closed folder).

Cross-field rules (one parameter below another) stay in the class's ``__post_init__``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from radcons.errors import ParamsError
from radcons.validate import check_fields

__all__ = ["ParamSpec", "param", "spec_of", "specs_of", "check_declared", "describe"]


@dataclass(frozen=True)
class ParamSpec:
    """What one parameter is and which values it takes.

    Attributes
    ----------
    help : str
        One sentence: what the parameter does.
    unit : str
        Unit of a number (``"px"``, ``"m"``, ...); empty where it has none.
    low, high : float or None
        Inclusive bounds of a number (each element of a list); None where unbounded.
    step : float or None
        Step of the inspector's slider; None: a hundredth of the range.
    choices : tuple of str
        The allowed values of a string parameter.
    basic : bool
        Shown first in the inspector; the others are advanced.
    """

    help: str
    unit: str = ""
    low: float | None = None
    high: float | None = None
    step: float | None = None
    choices: tuple[str, ...] = ()
    basic: bool = False

    @property
    def bounded(self) -> bool:
        """True when the number has both bounds (the inspector then shows a slider)."""
        return self.low is not None and self.high is not None


def param(
    default: Any,
    help: str,
    *,
    unit: str = "",
    range: tuple[float | None, float | None] | None = None,
    step: float | None = None,
    choices: tuple[str, ...] = (),
    basic: bool = False,
) -> Any:
    """Declare a field of a stage's params dataclass.

    Parameters
    ----------
    default : object
        The default value (the paper's where it gives one).
    help : str
        One sentence on what the parameter does.
    unit : str, optional
        Unit of a number.
    range : (low, high), optional
        Inclusive bounds of a number; either may be None.
    step : float, optional
        Slider step in the inspector.
    choices : tuple of str, optional
        Allowed values of a string.
    basic : bool, optional
        Whether the inspector shows it among the stage's basic parameters.

    Returns
    -------
    dataclasses.Field
        The field, with its :class:`ParamSpec` in ``metadata["spec"]``.
    """
    low, high = range if range is not None else (None, None)
    spec = ParamSpec(help, unit, low, high, step, tuple(choices), basic)
    if choices and default is not None and default not in choices:
        raise ValueError(f"default {default!r} is not among the choices {choices}")
    return field(default=default, metadata={"spec": spec})


def spec_of(field_: dataclasses.Field) -> ParamSpec:
    """The declaration of a field made by :func:`param`."""
    spec = field_.metadata.get("spec") if field_.metadata else None
    if spec is None:
        raise TypeError(f"parameter {field_.name!r} is not declared with radcons.param_spec.param")
    return spec


def specs_of(params: Any) -> dict[str, ParamSpec]:
    """Name -> declaration of every field of a params dataclass (class or instance)."""
    return {f.name: spec_of(f) for f in dataclasses.fields(params)}


def check_declared(params: Any, stage: str) -> None:
    """Refuse a parameter outside its declaration: type, finiteness, range, choices.

    Parameters
    ----------
    params : dataclass instance
        A stage's frozen params.
    stage : str
        The stage's name, for the message (``[stage] name ...``).

    Raises
    ------
    ParamsError
        The first field whose value its declaration does not allow.
    """
    check_fields(params, stage)
    for f in dataclasses.fields(params):
        spec = spec_of(f)
        value = getattr(params, f.name)
        if value is None:
            continue
        where = f"[{stage}] {f.name}"
        if spec.choices and value not in spec.choices:
            raise ParamsError(f"{where} must be one of {', '.join(spec.choices)}, got {value!r}")
        items = value if isinstance(value, tuple) else (value,)
        for item in items:
            if isinstance(item, bool) or not isinstance(item, (int, float)):
                continue
            if (spec.low is not None and item < spec.low) or (spec.high is not None and item > spec.high):
                raise ParamsError(f"{where} must be in {_range_text(spec)}, got {item!r}")


def _range_text(spec: ParamSpec) -> str:
    low = "-inf" if spec.low is None else f"{spec.low:g}"
    high = "inf" if spec.high is None else f"{spec.high:g}"
    unit = f" {spec.unit}" if spec.unit else ""
    return f"[{low}, {high}]{unit}"


def describe(spec: ParamSpec) -> str:
    """The help of a parameter with its unit, range or choices: one line for hints and files."""
    extra = ""
    if spec.choices:
        extra = f" ({' | '.join(spec.choices)})"
    elif spec.low is not None or spec.high is not None:
        extra = f" ({_range_text(spec)})"
    elif spec.unit:
        extra = f" ({spec.unit})"
    return spec.help + extra

