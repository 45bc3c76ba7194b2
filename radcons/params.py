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
from radcons.stages import STAGES
from radcons.stages.association import AssociationParams
from radcons.stages.global_norm import GlobalParams
from radcons.stages.objects import ObjectsParams
from radcons.stages.rectify import RectifyParams
from radcons.stages.refine import RefineParams
from radcons.stages.sharpness import SharpnessParams
from radcons.stages.smoothness import SmoothnessParams
from radcons.stages.uniformity import UniformityParams

__all__ = ["Params", "STAGES", "SWITCHABLE", "ADDED", "PRESETS", "DEFAULT_PRESET"]

#: Stages that may be switched off (their images pass through). ``rectify`` only ever runs
#: on pairs not marked rectified; switched off, such a pair is taken as it is.
SWITCHABLE: frozenset[str] = frozenset({"rectify", "uniformity", "global", "refine", "sharpness", "smoothness"})
#: Stages that are not the paper's: off unless a preset or the user switches them on.
ADDED: frozenset[str] = frozenset({"sharpness"})
#: Named starting points. ``paper`` follows the text exactly (its equations, defaults,
#: order). ``radcons`` keeps the paper's stages and values except where a measured option
#: matches better (``benchmarks/bench_method.py``; see :func:`Params.from_preset`).
PRESETS: tuple[str, ...] = ("paper", "radcons")

#: The preset the command line and the inspector start from. ``radcons`` beats every
#: baseline on the degraded real pairs where ``paper`` does not (docs/results.md);
#: ``Params()`` itself holds the paper's values.
DEFAULT_PRESET = "radcons"

_ATTR = {"global": "global_norm"}


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

        ``radcons``: the paper's stages and values except where measurement on degraded
        Middlebury Cones and Motorcycle and the demo pairs (``benchmarks/bench_method.py``,
        SGBM correct-matching rate) chose otherwise:

        * ``[uniformity]`` off: relative-gradient attenuation lowered the rate on every
          pair measured (Cones 0.625 -> 0.563, demo 'mixed' seed 0 0.446 -> 0.396), the
          more the stronger it is (zeta 0.8, 0.9, 0.95: Cones 0.563, 0.599, 0.612);
        * ``[refine]`` ``points = "dense"``, ``fit = "moments"``, ``background =
          "histogram"``, ``blend_width = 0``, ``clip_to_reference = true`` (see
          :mod:`radcons.stages.refine`): Cones 0.575 -> 0.650, Motorcycle 0.603 -> 0.675
          after the refine stage; ``agreement_gate = true``: an object's line is applied
          only where it lowers the object's difference to the reference
          (``benchmarks/bench_generalisation.py``, tuning split, SGBM: shadows kind -0.003
          -> +0.002 against the best baseline; US3D JAX_122 SGBM 3 px 0.497 -> 0.505, the
          lines had lowered it below histogram matching); ``background_noise = true``
          (the background's histogram mapping fitted as if the target were as noisy as
          the reference; chosen on the tuning split, 162 pair-seeds: SGBM 0.750 -> 0.753,
          census 0.805 -> 0.805, no kind lower by more than 0.001; held-out, run once:
          SGBM 0.710 -> 0.726, noise kind 0.696 -> 0.727, census 0.761 -> 0.765; scene
          mode builds the same mapping from grey-value counts);
        * ``[sharpness]`` on (:mod:`radcons.stages.sharpness`): Cones 0.650 -> 0.685,
          Motorcycle 0.675 -> 0.687, demo 'multi-sensor' 0.760 -> 0.806; ``noise =
          "cleaner"`` (:mod:`radcons.stages.noise_match`: where the pair's noise gap is
          large and reliable, the noisier image smoothed to the cleaner one's level;
          chosen on the tuning split, 162 pair-seeds, against ``"keep"`` with the other
          defaults as here: SGBM 0.7527 -> 0.7532, census 0.8053 -> 0.8074, noise kind
          +0.011 with census, no kind lower by more than 0.001; the noise ratio's median
          1.17 -> 1.15, that of the noise kind 3.69 -> 1.23; a JPEG-coded cleaner image
          opens the gate at a ratio of 1.3 instead of 2.0, ``noise_coded_gate``: 11
          JPEG-coded pair-seeds changed, SGBM +0.0001, census +0.0003, the compression
          kind's noise ratio median 1.84 -> 1.15);
        * ``[smoothness]`` off: on the radcons images it changed the rate of Cones by
          +0.008 and of Motorcycle by -0.022 (-0.03 after sharpness consistency), for
          15-80 s a pair; on the tuning split of ``benchmarks/bench_generalisation.py`` it
          brings the noise ratio's median from 1.15 to 1.06 but lowers the mean rate with
          SGBM from 0.776 to 0.759 and with census from 0.836 to 0.826;
        * ``[objects]`` ``method = "height"`` (:func:`radcons.stages.objects.height_objects`:
          objects standing above the ground in the pair's census disparity; the ``paper``
          preset keeps the image-only building index, ``"mbi"``). It finds buildings where
          the index finds fragments (``benchmarks/bench_objects.py``, demo pairs, labels
          withheld: mean best IoU per building 0.66-0.72 against 0.44; Gizeh 21 objects
          against more than 100) and, on the tuning split with the labels withheld (162
          pair-seeds, ``bench_generalisation.py --split tuning --blocks 6
          --withhold-labels``), raises the matching rate a little: SGBM 0.749 -> 0.752,
          no kind lower, census 0.808 -> 0.808, no kind lower by more than 0.001; the
          US3D tiles' rates are unchanged. It costs about 0.7 s more on a 1024 px pair
          (``benchmarks/bench_objects.py --only timing``).
        """
        if name not in PRESETS:
            raise ParamsError(f"unknown preset {name!r} (known: {', '.join(PRESETS)})")
        if name == "paper":
            return cls()
        return cls(
            refine=RefineParams(
                points="dense", fit="moments", background="histogram", blend_width=0.0, clip_to_reference=True,
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
        return getattr(self, _ATTR.get(name, name))

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
        return replace(self, **{_ATTR.get(name, name): updated}, disabled=frozenset(disabled))

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

    def save(self, path: str | Path) -> Path:
        """Write the parameters as TOML (atomically)."""
        import tomli_w

        from radcons.io import atomic_write_bytes

        path = Path(path)
        atomic_write_bytes(path, tomli_w.dumps(self.to_dict()).encode("utf-8"))
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

