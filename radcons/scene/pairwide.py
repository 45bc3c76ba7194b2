"""Pass 1 on a decimated copy: objects, their association and each object's fit.

The scene is reduced ``k`` times along each side (block means, GDAL overviews where the
file has them) to at most :data:`DECIMATED_SIDE` px, small enough for the in-memory
stages. On it:

* objects: the pair's own label rasters (read at full resolution where the tiles need
  them) or the image-only segmentation (``method = "mbi"``; the height method's
  whole-pair disparity has no tiled form) of the decimated images with its lengths
  divided by ``k``;
  one segmentation of the whole scene, so an object cut by a tile border is one object
  and ids are unique over the scene;
* association: at full resolution, by the stage's rule (SIFT matches of the whole scene,
  :mod:`radcons.scene.features`, then template matching in each object's window,
  :mod:`radcons.scene.window_association`);
* fits (eq 7-12): each associated object on a full-resolution window around it
  (:mod:`radcons.scene.object_fits`), with the :class:`FitContext` built here.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.ndimage

from radcons.params import Params
from radcons.results import Matches
from radcons.scene.source import SceneImage, ScenePair, Window
from radcons.stages.refine.light import LightField

__all__ = [
    "DECIMATED_SIDE", "HEIGHT_NOTE", "SceneLabels", "decimation_factor", "decimated_images", "scene_labels",
    "FitContext", "object_boxes",
]

#: Longest side, px, of the decimated copy pass 1 works on. It bounds pass 1's memory
#: whatever the scene's size: SIFT's scale space of a 4096 px copy took 3.9 GB resident
#: (measured on the 4096 px demo pair), of a 2048 px one a quarter of that.
DECIMATED_SIDE = 2048


def decimation_factor(shape: tuple[int, int], side: int = DECIMATED_SIDE) -> int:
    """Smallest ``k`` that brings the longer side of ``shape`` to at most ``side`` px."""
    return max(1, math.ceil(max(shape) / side))


def decimated_images(pair: ScenePair, factor: int) -> tuple[np.ndarray, np.ndarray]:
    """Both images reduced ``factor`` times, float32 with NaN at nodata."""
    return tuple(image.to_float(image.read_decimated(factor)) for image in (pair.reference, pair.target))


@dataclass(frozen=True)
class SceneLabels:
    """Object labels of both images at full resolution, window by window.

    Either the pair's own label rasters (read by window) or the labels of the decimated
    copy, each full-resolution pixel taking the label of the decimated pixel it falls in.
    """

    shape: tuple[int, int]
    reference_file: SceneImage | None = None
    target_file: SceneImage | None = None
    decimated: tuple[np.ndarray, np.ndarray] | None = None

    def window(self, which: str, window: Window) -> np.ndarray:
        """Labels of ``"reference"`` or ``"target"`` in ``window``, int32."""
        r0, r1, c0, c1 = window
        if self.decimated is None:
            source = self.reference_file if which == "reference" else self.target_file
            return source.read(window).astype(np.int32)
        small = self.decimated[0 if which == "reference" else 1]
        rows = np.arange(r0, r1) * small.shape[0] // self.shape[0]
        columns = np.arange(c0, c1) * small.shape[1] // self.shape[1]
        return small[np.ix_(rows, columns)]


def _scaled_objects(params: Params, factor: int) -> Params:
    if factor == 1:
        return params
    stage = params.objects
    min_size = max(1, round(stage.min_size / factor))
    return params.with_stage(
        "objects",
        min_size=min_size,
        max_size=max(min_size + 1, round(stage.max_size / factor)),
        min_area=max(1, round(stage.min_area / factor**2)),
        smooth_sigma=stage.smooth_sigma / factor,
    )


#: Why a scene run finds its objects with the image-only method when the height method is asked for.
HEIGHT_NOTE = (
    "scene mode has no tiled form of the height method's whole-pair census disparity: "
    "image-only objects (mbi) instead"
)


def scene_labels(
    pair: ScenePair, decimated: tuple[np.ndarray, np.ndarray], factor: int, params: Params
) -> tuple[SceneLabels, tuple[np.ndarray, np.ndarray], str, str]:
    """Labels of the scene: the pair's own rasters or the segmentation of the decimated copy.

    Returns
    -------
    labels : SceneLabels
        Full-resolution access for the tiles.
    small : (ndarray, ndarray)
        The labels at the decimated copy's resolution (for the association).
    source : str
        ``"user"`` or ``"segmented"``.
    method : str
        How the objects were found: ``"user"``, or the segmentation method used
        (``"mbi"``: the height method asked for is replaced, see :data:`HEIGHT_NOTE`).
    """
    if params.objects.use_supplied and pair.reference_objects is not None and pair.target_objects is not None:
        small = tuple(
            image.read_decimated(factor, labels=True).astype(np.int32)
            for image in (pair.reference_objects, pair.target_objects)
        )
        return SceneLabels(pair.shape, pair.reference_objects, pair.target_objects), small, "user", "user"
    from radcons.stages.objects.run import extract_objects

    stage = _scaled_objects(params, factor).objects
    if stage.method != "mbi":
        stage = dataclasses.replace(stage, method="mbi")
    small = tuple(extract_objects(image, stage) for image in decimated)
    return SceneLabels(pair.shape, decimated=small), small, "segmented", stage.method


def object_boxes(small_target: np.ndarray, shape: tuple[int, int], factor: int) -> dict[int, Window]:
    """Full-resolution window around each target object found in the decimated labels."""
    boxes = {}
    margin = factor + 2
    for index, box in enumerate(scipy.ndimage.find_objects(small_target), start=1):
        if box is None:
            continue
        r0 = box[0].start * shape[0] // small_target.shape[0]
        r1 = -(-box[0].stop * shape[0] // small_target.shape[0])
        c0 = box[1].start * shape[1] // small_target.shape[1]
        c1 = -(-box[1].stop * shape[1] // small_target.shape[1])
        boxes[index] = (max(r0 - margin, 0), min(r1 + margin, shape[0]), max(c0 - margin, 0), min(c1 + margin, shape[1]))
    return boxes


@dataclass(frozen=True)
class FitContext:
    """What the association and fit of one object need: the scene, labels, matches, pair-wide values.

    ``reference_boxes`` and ``target_boxes`` are full-resolution windows around each
    object (:func:`object_boxes`); ``search`` is the stage's template search range from
    the scene's matches and ``target_mean`` the target's mean (the template's fill of
    invalid pixels), both for :mod:`radcons.scene.window_association`; ``background`` is
    the scene's histogram mapping of the target and ``light`` its light correction across
    the scene, if applied (as in :class:`radcons.scene.tiles.SceneQuantities`), the refine
    stage's agreement gate compares each line with them.
    """

    pair: ScenePair
    labels: SceneLabels
    matches: Matches
    params: Params
    lambdas: tuple[float, float]
    clip_levels: tuple[tuple[float, ...], tuple[float, ...]]
    reference_boxes: dict[int, Window]
    target_boxes: dict[int, Window]
    search: Any
    target_mean: float = 0.0
    background: tuple[np.ndarray, np.ndarray] | None = None
    light: LightField | None = None
