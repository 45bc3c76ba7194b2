"""Parameters of every stage, nested in one :class:`Params`, with a TOML round trip.

The TOML file has one table per stage, named as the stage (``[rectify]``, ``[objects]``,
``[association]``, ``[uniformity]``, ``[global]``, ``[refine]``, ``[sharpness]``, ``[smoothness]``); each table holds that
stage's parameters and an optional ``enabled = false`` that switches the stage off (its
images then pass through unchanged). Keys left out keep their defaults, so a file may hold
only what differs. A top-level ``preset`` key names the preset the file starts from
(default :data:`DEFAULT_PRESET`).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from radcons.errors import ParamsError
from radcons.stages import STAGE, STAGES
from radcons.stages.association.params import AssociationParams
from radcons.stages.global_norm.params import GlobalParams
from radcons.stages.objects.params import ObjectsParams
from radcons.stages.rectify.params import RectifyParams
from radcons.stages.refine.params import RefineParams
from radcons.stages.sharpness.params import SharpnessParams
from radcons.stages.smoothness.params import SmoothnessParams
from radcons.stages.uniformity.params import UniformityParams

__all__ = ["Params", "STAGES", "SWITCHABLE", "ADDED", "PRESETS", "DEFAULT_PRESET"]

#: Stages that may be switched off (their images pass through). ``rectify`` only ever runs
#: on pairs not marked rectified; switched off, such a pair is taken as it is.
SWITCHABLE: frozenset[str] = frozenset(s.name for s in STAGE.values() if s.switchable)
#: Stages that are not the paper's: off unless a preset or the user switches them on.
ADDED: frozenset[str] = frozenset(s.name for s in STAGE.values() if s.added)
#: Named starting points. ``paper`` follows the text exactly (its equations, defaults,
#: order). ``radcons`` keeps the paper's stages and values except where a measured option
#: matches better (``benchmarks/bench_method.py``; see :func:`Params.from_preset`).
PRESETS: tuple[str, ...] = ("paper", "radcons")

#: The preset the command line and the inspector start from. ``radcons`` beats every
#: baseline on the degraded real pairs where ``paper`` does not (docs/results.md);
#: ``Params()`` itself holds the paper's values.
DEFAULT_PRESET = "radcons"

@dataclass(frozen=True)
class Params:
    """All stage parameters of one pipeline run (defaults: the paper's values).

    Attributes
    ----------
    rectify, objects, association, uniformity, global_norm, refine, sharpness, smoothness
        Each stage's frozen params dataclass (``global_norm`` is the ``[global]`` table).
    disabled : frozenset of str
        Stages switched off (among :data:`SWITCHABLE`); by default the stages that are
        not the paper's (:data:`ADDED`).
    preset : str
        The preset these parameters started from.
    """

    rectify: RectifyParams = field(default_factory=RectifyParams)
    objects: ObjectsParams = field(default_factory=ObjectsParams)
    association: AssociationParams = field(default_factory=AssociationParams)
    uniformity: UniformityParams = field(default_factory=UniformityParams)
    global_norm: GlobalParams = field(default_factory=GlobalParams)
    refine: RefineParams = field(default_factory=RefineParams)
    sharpness: SharpnessParams = field(default_factory=SharpnessParams)
    smoothness: SmoothnessParams = field(default_factory=SmoothnessParams)
    disabled: frozenset[str] = ADDED
    preset: str = "paper"

    def __post_init__(self) -> None:
        unknown = set(self.disabled) - SWITCHABLE
        if unknown:
            raise ParamsError(
                f"stage(s) {', '.join(sorted(unknown))} cannot be switched off "
                f"(switchable: {', '.join(sorted(SWITCHABLE))})"
            )
        if self.preset not in PRESETS:
            raise ParamsError(f"unknown preset {self.preset!r} (known: {', '.join(PRESETS)})")

    @classmethod
    def from_preset(cls, name: str = "paper") -> "Params":
        """Return the parameters of a named preset (one of :data:`PRESETS`).

        ``paper``: the paper's equations and values, every stage of the paper on, the
        stages it does not have (:data:`ADDED`) off.

        ``radcons``: the paper's stages and values except where measurement on a tuning
        split chose otherwise (the figures and commands: ``docs/tuning.md``):

        * ``[uniformity]`` off: relative-gradient attenuation lowers the matching rate;
        * ``[refine]`` ``points = "dense"``, ``fit = "moments"``, ``background =
          "local"`` (the whole-image histogram mapping, then the tile-wise light
          correction where light varies across the scene), ``blend_width = 0``,
          ``clip_to_reference``, ``agreement_gate`` (an object's line applied only where
          it lowers the object's difference to the reference) and ``background_noise``
          (the background's histogram mapping fitted as if the target were as noisy as
          the reference);
        * ``[sharpness]`` on, with ``noise = "cleaner"`` (the noisier image smoothed to
          the cleaner one's level where the gap is large and reliable);
        * ``[smoothness]`` off: it lowers the noise but also the matching rate, for
          15-80 s a pair;
        * ``[objects]`` ``method = "height"``: objects standing above the ground in the
          pair's census disparity, where the image-only building index finds fragments.
        """
        if name not in PRESETS:
            raise ParamsError(f"unknown preset {name!r} (known: {', '.join(PRESETS)})")
        if name == "paper":
            return cls()
        return cls(
            refine=RefineParams(
                points="dense", fit="moments", background="local", blend_width=0.0, clip_to_reference=True,
                agreement_gate=True, background_noise=True,
            ),
            sharpness=SharpnessParams(noise="cleaner"),
            objects=ObjectsParams(method="height"),
            disabled=frozenset({"uniformity", "smoothness"}),
            preset=name,
        )

    def stage(self, name: str) -> Any:
        """Return the params dataclass of stage ``name``."""
        if name not in STAGES:
            raise ParamsError(f"unknown stage {name!r} (known: {', '.join(STAGES)})")
        return getattr(self, STAGE[name].package)

    def enabled(self, name: str) -> bool:
        """True unless stage ``name`` was switched off."""
        return name not in self.disabled

    def with_stage(self, name: str, **changes: Any) -> "Params":
        """Return a copy with some parameters of stage ``name`` changed.

        ``enabled=False`` switches the stage off, ``enabled=True`` on again.
        """
        enabled = changes.pop("enabled", None)
        current = self.stage(name)
        try:
            updated = replace(current, **changes) if changes else current
        except TypeError as exc:
            raise ParamsError(f"[{name}] {exc}") from exc
        disabled = set(self.disabled)
        if enabled is not None:
            (disabled.discard if enabled else disabled.add)(name)
        return replace(self, **{STAGE[name].package: updated}, disabled=frozenset(disabled))

    # ------------------------------------------------------------------ dict / TOML

    def to_dict(self) -> dict[str, Any]:
        """Nested plain dict, one table per stage, ready for TOML.

        Parameters whose value is None ("automatic") are left out: TOML has no null, and
        a missing key keeps the default.
        """
        out: dict[str, Any] = {"preset": self.preset}
        for name in STAGES:
            stage = self.stage(name)
            table = {
                f.name: _plain(getattr(stage, f.name)) for f in fields(stage) if getattr(stage, f.name) is not None
            }
            if name in SWITCHABLE:
                table["enabled"] = self.enabled(name)
            out[name] = table
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str | Path | None = None) -> "Params":
        """Build parameters from a nested dict; unknown tables or keys are errors."""
        data = dict(data)
        params = cls.from_preset(str(data.pop("preset", DEFAULT_PRESET)))
        for name, table in data.items():
            if name not in STAGES:
                raise ParamsError(f"unknown table [{name}] (stages: {', '.join(STAGES)})", source)
            if not isinstance(table, dict):
                raise ParamsError(f"[{name}] must be a table", source)
            table = dict(table)
            enabled = table.pop("enabled", None)
            if enabled is not None and name not in SWITCHABLE and enabled is not True:
                raise ParamsError(f"[{name}] cannot be switched off", source)
            current = params.stage(name)
            known = {f.name: f for f in fields(current)}
            changes = {}
            for key, value in table.items():
                if key not in known:
                    raise ParamsError(f"[{name}] has no parameter {key!r} (known: {', '.join(known)})", source)
                changes[key] = _coerce(value, getattr(current, key), f"[{name}] {key}", source)
            if name in SWITCHABLE and enabled is not None:
                changes["enabled"] = bool(enabled)
            params = params.with_stage(name, **changes)
        return params

    def to_toml(self) -> str:
        """The parameters as TOML, each key under a comment with its help, unit and range.

        :meth:`load` reads it back to the same parameters.
        """
        import tomli_w

        from radcons.param_spec import describe, spec_of

        data = self.to_dict()
        lines = [tomli_w.dumps({"preset": data["preset"]}).rstrip("\n")]
        for name in STAGES:
            stage = STAGE[name]
            equations = f" ({stage.equations})" if stage.equations else ""
            lines += ["", f"# {stage.title}{equations}", f"[{name}]"]
            table = data[name]
            specs = {f.name: spec_of(f) for f in fields(stage.params)}
            for key, value in table.items():
                help_text = "run this stage (false: its images pass through)" if key == "enabled" else describe(specs[key])
                lines += [f"# {help_text}", tomli_w.dumps({key: value}).rstrip("\n")]
        return "\n".join(lines) + "\n"

    def save(self, path: str | Path) -> Path:
        """Write the parameters as commented TOML (:meth:`to_toml`), atomically."""
        from radcons.io import atomic_write_bytes

        path = Path(path)
        atomic_write_bytes(path, self.to_toml().encode("utf-8"))
        return path

    @classmethod
    def load(cls, path: str | Path) -> "Params":
        """Read parameters written by :meth:`save` (or by hand)."""
        path = Path(path)
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError as exc:
            raise ParamsError("parameter file not found", path) from exc
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise ParamsError(f"malformed TOML: {exc}", path) from exc
        return cls.from_dict(data, path)


def _plain(value: Any) -> Any:
    if isinstance(value, tuple):
        return list(value)
    return value


def _coerce(value: Any, default: Any, where: str, source: str | Path | None) -> Any:
    """Convert a TOML value to the type of the parameter's current value."""
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ParamsError(f"{where} must be true or false, not {value!r}", source)
        return value
    if isinstance(default, int):
        if isinstance(value, bool) or not isinstance(value, int):
            raise ParamsError(f"{where} must be an integer, not {value!r}", source)
        return value
    if isinstance(default, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ParamsError(f"{where} must be a number, not {value!r}", source)
        return float(value)
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ParamsError(f"{where} must be a string, not {value!r}", source)
        return value
    if isinstance(default, tuple):
        if not isinstance(value, list):
            raise ParamsError(f"{where} must be a list, not {value!r}", source)
        return tuple(value)
    if default is None:
        return value
    raise ParamsError(f"{where}: unsupported parameter type {type(default).__name__}", source)

