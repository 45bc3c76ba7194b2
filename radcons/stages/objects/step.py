"""The objects stage's step: the pair's own label rasters, else the method its parameters name."""

from __future__ import annotations

from typing import Any

import numpy as np

from radcons.io import Pair
from radcons.results import ObjectLabels, StageImages
from radcons.stages import StageInputs

__all__ = ["compute", "uses_supplied", "finds_objects_from_height", "height_geometry"]


def compute(inputs: StageInputs) -> ObjectLabels:
    """Objects of both images of the working pair (see :func:`objects_of`)."""
    pair = inputs.working_pair
    params = inputs.params.stage("objects")
    matching = inputs.pair_matching() if finds_objects_from_height(pair, params) else None
    rectification = inputs.results.get("rectify")
    return objects_of(pair, inputs.results["original"], params, rectification, matching)


def uses_supplied(pair: Pair, params: Any) -> bool:
    """Whether the objects stage takes the pair's own label rasters (``params``: its ``[objects]``)."""
    return bool(params.use_supplied and pair.reference_objects is not None and pair.target_objects is not None)


def finds_objects_from_height(pair: Pair, params: Any) -> bool:
    """Whether the objects stage runs the height method (census matching and all) on ``pair``."""
    return params.method == "height" and not uses_supplied(pair, params)


def height_geometry(pair: Pair, rectification: Any = None) -> dict[str, Any]:
    """The height method's ``gsd_m``, ``base_to_height``, ``disparity_range`` and ``px_per_m`` for ``pair``.

    The ground sample distance and base-to-height ratio come from the pair's metadata
    (``gsd_m``, ``base_to_height``), the disparity range, the metres of one disparity
    pixel and the ground sample distance (RPC rectification, when the metadata has none)
    from the rectification, when there are.
    """

    def number(key: str) -> float | None:
        value = pair.metadata.get(key)
        return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else None

    known = getattr(rectification, "disparity_range", None)
    metres = getattr(rectification, "metres_per_pixel", None)
    return {
        "gsd_m": number("gsd_m") or getattr(rectification, "gsd_m", None),
        "base_to_height": number("base_to_height"),
        "disparity_range": tuple(float(v) for v in known) if known is not None else None,
        "px_per_m": 1.0 / metres if metres else None,
    }


def objects_of(
    pair: Pair, original: StageImages, params: Any, rectification: Any = None, matching: Any = None
) -> ObjectLabels:
    """Objects of both images: the pair's own label rasters win over segmentation.

    The ``"height"`` method reads the pair's geometry (:func:`height_geometry`) and the
    green leaf index of an RGB reference (:attr:`radcons.io.Raster.greenness`), and uses
    ``matching``, the pair's kept census matching
    (:class:`radcons.stages.objects.matching.PairMatching`), when given.
    """
    if uses_supplied(pair, params):
        return ObjectLabels(pair.reference_objects.astype(np.int32), pair.target_objects.astype(np.int32), "user")
    if params.method == "height":
        from radcons.stages.objects.run import height_objects

        return height_objects(
            original.reference, original.target, params, greenness=pair.reference.greenness, matching=matching,
            **height_geometry(pair, rectification),
        )
    from radcons.stages.objects.mbi import extract_objects

    return ObjectLabels(
        extract_objects(original.reference, params),
        extract_objects(original.target, params),
        "segmented",
    )
