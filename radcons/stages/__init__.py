"""The stages of the method, one package each, and the record that describes them.

Each stage lives in ``radcons/stages/<package>/``: its parameters in ``params.py``
(declared once with :func:`radcons.param_spec.param`), its computation in ``run.py`` and
helper modules, and ``step.py``, the one function the pipeline calls with the results so
far (:class:`StageInputs`). :data:`STAGE_LIST` is the only place that says what a stage
is: the pipeline, scene mode, :class:`radcons.params.Params`, the command line's
``--until`` and the inspector's Tune tab all read it.

Shared numerics (census cost, coarse disparity, Poisson solver, subpixel peaks, 8-bit
stretch, relabelling) live below the stages in :mod:`radcons.numerics`; a stage imports
from there and from its own package, never from another stage.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable

from radcons.stages.association.params import AssociationParams
from radcons.stages.global_norm.params import GlobalParams
from radcons.stages.objects.params import ObjectsParams
from radcons.stages.rectify.params import RectifyParams
from radcons.stages.refine.params import RefineParams
from radcons.stages.sharpness.params import SharpnessParams
from radcons.stages.smoothness.params import SmoothnessParams
from radcons.stages.uniformity.params import UniformityParams

if TYPE_CHECKING:
    from radcons.io import Pair

__all__ = ["Stage", "StageInputs", "STAGE_LIST", "STAGE", "STAGES", "IMAGE_STAGES", "TILE_STAGES"]


@dataclass(frozen=True)
class Stage:
    """What one stage is.

    Attributes
    ----------
    name : str
        The stage's name: its table in the parameter file, ``--until``'s value.
    package : str
        Its package under ``radcons/stages/`` (also the :class:`~radcons.params.Params`
        attribute holding its parameters).
    title : str
        A few words on what it does.
    equations : str
        The paper's equations it implements (empty for stages the paper does not have).
    depends : tuple of str
        The stages whose results it reads.
    params : type
        Its frozen params dataclass.
    image_stage : bool
        It produces a pair of images (and passes its input through when switched off).
    switchable : bool
        It may be switched off.
    added : bool
        Not the paper's: off unless a preset or the user switches it on.
    tiled : bool
        Scene mode runs it tile by tile.
    """

    name: str
    package: str
    title: str
    equations: str
    depends: tuple[str, ...]
    params: type
    image_stage: bool = False
    switchable: bool = True
    added: bool = False
    tiled: bool = False

    def step(self) -> Callable[["StageInputs"], Any]:
        """The stage's computation, ``compute(inputs) -> result`` (its ``step`` module, imported on use)."""
        return importlib.import_module(f"radcons.stages.{self.package}.step").compute


#: Every stage, in pipeline order.
STAGE_LIST: tuple[Stage, ...] = (
    Stage("rectify", "rectify", "epipolar resampling of an unrectified pair", "", (), RectifyParams),
    Stage("objects", "objects", "buildings of both images", "", ("rectify",), ObjectsParams, switchable=False),
    Stage(
        "association", "association", "SIFT matches, object pairs, D̄m, invariant points", "",
        ("objects",), AssociationParams, switchable=False,
    ),
    Stage(
        "uniformity", "uniformity", "relative-gradient attenuation of each image", "eq 1-3",
        ("rectify",), UniformityParams, image_stage=True,
    ),
    Stage(
        "global", "global_norm", "singular value equalisation of the pair", "eq 4-6",
        ("uniformity",), GlobalParams, image_stage=True, tiled=True,
    ),
    Stage(
        "refine", "refine", "per-object weighted least squares on invariant points", "eq 7-12",
        ("global", "association"), RefineParams, image_stage=True, tiled=True,
    ),
    Stage(
        "sharpness", "sharpness", "one point spread and noise level for both images", "",
        ("refine",), SharpnessParams, image_stage=True, added=True, tiled=True,
    ),
    Stage(
        "smoothness", "smoothness", "union group sparse denoising of both images", "eq 13-19",
        ("sharpness", "objects", "association"), SmoothnessParams, image_stage=True, tiled=True,
    ),
)

#: Stage name -> its record.
STAGE: dict[str, Stage] = {stage.name: stage for stage in STAGE_LIST}
#: Stage names in pipeline order; also the parameter file's table names.
STAGES: tuple[str, ...] = tuple(STAGE)
#: Stages that produce a pair of images, in order; "original" is the input itself.
IMAGE_STAGES: tuple[str, ...] = ("original", *(s.name for s in STAGE_LIST if s.image_stage))
#: The image stages scene mode runs tile by tile, in order.
TILE_STAGES: tuple[str, ...] = tuple(s.name for s in STAGE_LIST if s.tiled)


@dataclass
class StageInputs:
    """What a stage's ``compute`` reads: the pair, the parameters and the results so far.

    Attributes
    ----------
    pair : Pair
        The pair as given.
    working_pair : Pair or None
        The pair every stage after ``rectify`` works on (None before it).
    params : Params
        Every stage's parameters.
    results : dict
        Stage name -> result of the stages already run (``"original"`` included).
    matches : callable
        ``matches() -> Matches``: the SIFT matches of the working pair, kept by the pipeline.
    pair_matching : callable
        ``pair_matching() -> PairMatching``: the height method's census matching of the
        working pair, kept by the pipeline.
    """

    pair: "Pair"
    working_pair: "Pair | None"
    params: Any
    results: dict[str, Any]
    matches: Callable[[], Any]
    pair_matching: Callable[[], Any]

    def images(self, stage: str) -> tuple[Any, Any]:
        """``(reference, target)`` float32 images of an image stage."""
        result = self.results[stage]
        return result.reference, result.target

    def previous_images(self, stage: str) -> tuple[Any, Any]:
        """The images an image stage starts from: those of the image stage before it."""
        return self.images(IMAGE_STAGES[IMAGE_STAGES.index(stage) - 1])
