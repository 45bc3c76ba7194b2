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
* association: SIFT matches and object pairs of the decimated images (lengths divided by
  ``k``); positions and modal disparities D̄m are then multiplied by ``k``;
* fits (eq 7-12): each associated object is fitted at full resolution on a window around
  it (its target box widened by D̄m), with the scene's lambda of eq 5 and the scene's
  clipping levels, by :func:`radcons.stages.refine.refine_target` itself; when several
  reference objects fit one target object the one with the most points is applied, as
  in the in-memory run.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import scipy.ndimage

from radcons.params import Params
from radcons.results import Association, Matches, ObjectAssociation, ObjectFit
from radcons.scene.source import ScenePair, SceneImage, Window

__all__ = [
    "DECIMATED_SIDE", "SceneLabels", "decimation_factor", "decimated_images", "scene_labels",
    "scene_association", "FitContext", "fit_objects", "object_boxes", "choose_fits", "full_resolution_disparity", "template_limits", "search_objects", "match_range",
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


def scene_labels(
    pair: ScenePair, decimated: tuple[np.ndarray, np.ndarray], factor: int, params: Params
) -> tuple[SceneLabels, tuple[np.ndarray, np.ndarray], str]:
    """Labels of the scene: the pair's own rasters or the segmentation of the decimated copy.

    Returns
    -------
    labels : SceneLabels
        Full-resolution access for the tiles.
    small : (ndarray, ndarray)
        The labels at the decimated copy's resolution (for the association).
    source : str
        ``"user"`` or ``"segmented"``.
    """
    if params.objects.use_supplied and pair.reference_objects is not None and pair.target_objects is not None:
        small = tuple(
            image.read_decimated(factor, labels=True).astype(np.int32)
            for image in (pair.reference_objects, pair.target_objects)
        )
        return SceneLabels(pair.shape, pair.reference_objects, pair.target_objects), small, "user"
    from radcons.stages.objects import extract_objects

    stage = _scaled_objects(params, factor).objects
    if getattr(stage, "method", "mbi") != "mbi":  # the height method needs a whole-pair disparity
        stage = dataclasses.replace(stage, method="mbi")
    small = tuple(extract_objects(image, stage) for image in decimated)
    return SceneLabels(pair.shape, decimated=small), small, "segmented"


def scene_association(
    decimated: tuple[np.ndarray, np.ndarray], small_labels: tuple[np.ndarray, np.ndarray], factor: int,
    params: Params,
) -> Association:
    """Association of the decimated pair, in full-resolution pixels (positions and D̄m times ``factor``)."""
    from radcons.stages.association import associate_objects, match_features

    stage = params.association
    if factor > 1:
        stage = dataclasses.replace(
            stage,
            max_disparity=stage.max_disparity / factor,
            search_margin=stage.search_margin / factor,
            ratio_rows=stage.ratio_rows / factor,
        )
    reference, target = decimated
    matches = match_features(reference, target, stage, rectified=True)
    association = associate_objects(reference, target, small_labels[0], small_labels[1], matches, stage)
    if factor == 1:
        return association
    scale = np.float32(factor)
    full = Matches(association.matches.ref_xy * scale, association.matches.tgt_xy * scale)
    objects = tuple(
        dataclasses.replace(obj, modal_disparity=float(obj.modal_disparity) * factor) for obj in association.objects
    )
    return Association(full, objects, association.unassociated_ref)


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
    """What the fit of one object needs: the scene, its labels, matches and pair-wide values.

    ``reference_boxes`` (full-resolution windows around the reference objects), ``factor``
    (the decimation), ``disparity_limits`` (the association's template search range,
    :func:`template_limits`) and ``match_range`` (the disparities of the scene's matches,
    :func:`match_range`) serve :func:`full_resolution_disparity` and :func:`search_objects`;
    ``background`` is the scene's histogram mapping of the target (as in
    :class:`radcons.scene.tiles.SceneQuantities`), the refine stage's agreement gate
    compares each line with it.
    """

    pair: ScenePair
    labels: SceneLabels
    matches: Matches
    params: Params
    lambdas: tuple[float, float]
    clip_levels: tuple[tuple[float, ...], tuple[float, ...]]
    reference_boxes: dict[int, Window]
    factor: int
    disparity_limits: tuple[float, float] = (-math.inf, math.inf)
    match_range: tuple[float, float] = (0.0, 0.0)
    background: tuple[np.ndarray, np.ndarray] | None = None


def _parabola(left: float, centre: float, right: float) -> float:
    """Offset of the vertex of the parabola through three equally spaced scores."""
    curvature = left - 2.0 * centre + right
    return 0.0 if not curvature < 0 else float(np.clip(0.5 * (left - right) / curvature, -0.5, 0.5))


def full_resolution_disparity(obj: ObjectAssociation, context: FitContext) -> float:
    """D̄m of an object measured again at full resolution, near the decimated copy's ``k D̄m``.

    A decimated D̄m is known to ``k`` px only, and a fit that pairs pixels at D̄m (dense
    points) needs it to the pixel. It is measured as the association measured it:

    * ``"sift"`` associations: SIFT matches (:func:`radcons.stages.association.match_features`)
      between a full-resolution window around the reference object and the target
      window ``k D̄m`` to its left (widened by ``2 k + 8`` px); D̄m is the modal disparity
      (:func:`~radcons.stages.association.modal_disparity`) of the matches that link the
      two objects, when more than ``min_matches`` do;
    * ``"template"`` associations: the reference object (its pixels, as a mask) matched
      along the same rows of the target by normalised cross-correlation
      (``cv2.matchTemplate``, ``TM_CCOEFF_NORMED``) within ``k + 1`` px of ``k D̄m``, the
      peak refined by a parabola.

    Returns None for a SIFT association that no more than ``min_matches`` full-resolution
    matches confirm (a mismatch of the decimated copy), else the decimated estimate where
    nothing better is found (a flat or invalid object, a search strip leaving the scene).
    """
    estimate = float(obj.modal_disparity)
    box = context.reference_boxes.get(obj.ref_id)
    if context.factor == 1 or box is None:
        return estimate
    if obj.method == "sift":
        return _sift_disparity(obj, box, context)
    return _template_disparity(obj, box, context)


def match_range(matches: Matches, margin: float = 16.0) -> tuple[float, float]:
    """Disparities of the scene's matches (0.5th to 99.5th percentile), widened by ``margin`` px."""
    if len(matches) == 0:
        return -margin, margin
    low, high = np.percentile(matches.disparity, [0.5, 99.5])
    return float(low) - margin, float(high) + margin


def _window_matches(box: Window, left: int, right: int, context: FitContext) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Full-resolution SIFT matches of a reference window and the target's columns ``left:right``.

    Returns their disparities and the reference and target labels under their points, or
    None without matches.
    """
    from radcons.stages.association import match_features

    r0, r1, c0, _ = box
    if right - left < 16:
        return None
    window = (r0, r1, left, right)
    matches = match_features(
        context.pair.reference.read_float(box), context.pair.target.read_float(window),
        context.params.association, rectified=True,
    )
    if len(matches) == 0:
        return None

    def label_at(labels: np.ndarray, xy: np.ndarray) -> np.ndarray:
        rows = np.clip(np.rint(xy[:, 1]).astype(np.int64), 0, labels.shape[0] - 1)
        cols = np.clip(np.rint(xy[:, 0]).astype(np.int64), 0, labels.shape[1] - 1)
        return labels[rows, cols]

    disparity = (matches.ref_xy[:, 0] + c0) - (matches.tgt_xy[:, 0] + left)
    return (
        disparity.astype(np.float64),
        label_at(context.labels.window("reference", box), matches.ref_xy),
        label_at(context.labels.window("target", window), matches.tgt_xy),
    )


def search_objects(ref_ids: list[int], context: FitContext) -> list[ObjectAssociation]:
    """SIFT associations (the stage's rule) of reference objects the decimated copy left unassociated.

    Each object's full-resolution window is matched against the target's band of the same
    rows over the disparities of the scene's matches; the target object holding most of
    the object's matches is its partner if more than ``min_matches`` matches link them and
    more than ``min_matches`` of them agree with their modal disparity (eq 12). Their
    matches are not among the scene's, so the association lists none.
    """
    from radcons.stages.association import modal_disparity

    params = context.params.association
    found = []
    for ref_id in ref_ids:
        box = context.reference_boxes.get(ref_id)
        if box is None:
            continue
        low, high = context.match_range
        left = max(int(math.floor(box[2] - high)), 0)
        right = min(int(math.ceil(box[3] - low)), context.pair.shape[1])
        result = _window_matches(box, left, right, context)
        if result is None:
            continue
        disparity, labels_ref, labels_tgt = result
        on_object = (labels_ref == ref_id) & (labels_tgt > 0)
        if not on_object.any():
            continue
        ids, counts = np.unique(labels_tgt[on_object], return_counts=True)
        tgt_id = int(ids[np.argmax(counts)])
        linked = disparity[on_object & (labels_tgt == tgt_id)]
        if linked.size <= params.min_matches:
            continue
        modal = modal_disparity(linked)
        if (np.abs(linked - modal) < params.invariant_threshold).sum() <= params.min_matches:
            continue
        none = np.zeros(0, np.int64)
        found.append(ObjectAssociation(ref_id, tgt_id, "sift", modal, none, none))
    return found


def template_limits(matches: Matches, params: Params) -> tuple[float, float]:
    """The disparity range the association's template search covers, from the scene's matches.

    The stage's own rule (:mod:`radcons.stages.association`: the supported disparities
    of the matches widened by ``search_margin``, ``max_disparity`` without matches), here
    on the decimated copy's matches in full-resolution pixels; a template association at
    full resolution stays inside it as the stage's does.
    """
    from radcons.stages.association import _search_window  # the stage's rule, not a copy of it

    if len(matches) == 0:
        return -params.association.max_disparity, params.association.max_disparity
    search = _search_window(matches, params.association)
    return float(search.d_low), float(search.d_high)


def _sift_disparity(obj: ObjectAssociation, box: Window, context: FitContext) -> float | None:
    """Modal disparity of the full-resolution SIFT matches linking the two objects, or None."""
    from radcons.stages.association import modal_disparity

    margin = 2 * context.factor + 8
    left = max(int(math.floor(box[2] - obj.modal_disparity)) - margin, 0)
    right = min(int(math.ceil(box[3] - obj.modal_disparity)) + margin, context.pair.shape[1])
    result = _window_matches(box, left, right, context)
    if result is None:
        return None
    disparity, labels_ref, labels_tgt = result
    linked = (labels_ref == obj.ref_id) & (labels_tgt == obj.tgt_id)
    if linked.sum() <= context.params.association.min_matches:
        return None
    return modal_disparity(disparity[linked])


def _template_disparity(obj: ObjectAssociation, box: Window, context: FitContext) -> float:
    """Disparity of the best normalised cross-correlation of the reference object near ``k D̄m``."""
    import cv2

    estimate = float(obj.modal_disparity)
    r0, r1, c0, c1 = box
    template = context.pair.reference.read_float(box)
    mask = (context.labels.window("reference", box) == obj.ref_id) & np.isfinite(template)
    if mask.sum() < 2 or np.ptp(template[mask]) == 0:
        return estimate
    low = max(estimate - context.factor - 1, context.disparity_limits[0])
    high = min(estimate + context.factor + 1, context.disparity_limits[1])
    left, right = int(math.floor(c0 - high)), int(math.ceil(c1 - low))
    if high < low or left < 0 or right > context.pair.shape[1]:
        return estimate
    strip = context.pair.target.read_float((r0, r1, left, right))
    valid = np.isfinite(strip)
    if not valid.any():
        return estimate
    strip = np.where(valid, strip, np.float32(strip[valid].mean()))
    template = np.where(mask, template, np.float32(0.0))
    scores = cv2.matchTemplate(strip, template, cv2.TM_CCOEFF_NORMED, mask=mask.astype(np.uint8))[0]
    scores[~np.isfinite(scores)] = -np.inf
    col = int(np.argmax(scores))
    if not np.isfinite(scores[col]):
        return estimate
    sub = _parabola(scores[col - 1], scores[col], scores[col + 1]) if 0 < col < scores.size - 1 else 0.0
    return float(c0 - (left + col + sub))


def _kept(obj: ObjectAssociation, note: str) -> ObjectFit:
    empty = np.zeros(0, np.float64)
    return ObjectFit(obj.ref_id, obj.tgt_id, 1.0, 0.0, empty, empty, empty, False, 0, note)


def fit_objects(
    chunk: list[tuple[ObjectAssociation, Window | None]], context: FitContext
) -> list[tuple[ObjectAssociation, ObjectFit]]:
    """Fit each object of ``chunk`` (eq 7-12) on a full-resolution window around it.

    Returns each object (its D̄m measured again at full resolution,
    :func:`full_resolution_disparity`) with its fit.
    """
    fits = []
    for obj, box in chunk:
        if obj.tgt_id > 0:
            measured = full_resolution_disparity(obj, context)
            if measured is None:
                fits.append((obj, _kept(obj, "SIFT association not confirmed at full resolution")))
                continue
            obj = dataclasses.replace(obj, modal_disparity=measured)
        fits.append((obj, _fit_one(obj, box, context, context.pair.shape[1])))
    return fits


def _fit_one(obj: ObjectAssociation, box: Window | None, context: FitContext, columns: int) -> ObjectFit:
    """The fit of one object on the window of its target box widened by D̄m (see :func:`fit_objects`)."""
    from radcons.stages.refine import refine_target

    if obj.tgt_id == 0:
        return _kept(obj, "no target object")
    if box is None:
        return _kept(obj, "target object absent from the scene's decimated copy")
    shift = float(obj.modal_disparity)
    c0 = max(int(math.floor(box[2] + min(shift, 0.0))) - 2, 0)
    c1 = min(int(math.ceil(box[3] + max(shift, 0.0))) + 2, columns)
    window = (box[0], box[1], c0, c1)
    labels = context.labels.window("target", window)
    if not (labels == obj.tgt_id).any():
        return _kept(obj, "target object absent from its window")
    images, clipped = [], []
    for image, lam, levels in zip((context.pair.reference, context.pair.target), context.lambdas, context.clip_levels):
        values = image.read_float(window)
        clipped.append(np.isin(values, levels) if levels else np.zeros(values.shape, bool))
        images.append(values * np.float32(lam))
    background = None
    if context.background is not None:
        raw = images[1] / np.float32(context.lambdas[1])
        background = np.full(raw.shape, np.nan, np.float32)
        valid = np.isfinite(raw)
        background[valid] = np.interp(raw[valid], *context.background)
    origin = np.array([c0, box[0]], np.float32)
    matches = Matches(context.matches.ref_xy - origin, context.matches.tgt_xy - origin)
    _, (fit,) = refine_target(
        images[0], images[1], labels, Association(matches, (obj,)), context.params.refine, tuple(clipped), background
    )
    return fit


def choose_fits(fits: list[ObjectFit]) -> tuple[list[ObjectFit], dict[int, tuple[float, float]]]:
    """Apply one fit per target object: the one with the most points (as the in-memory stage).

    Returns the fits (the others marked not applied, with the reason) and the applied
    ``(gain, offset)`` of each target object id.
    """
    chosen: dict[int, int] = {}
    for i, fit in enumerate(fits):
        if fit.applied and (fit.tgt_id not in chosen or fit.n_points > fits[chosen[fit.tgt_id]].n_points):
            chosen[fit.tgt_id] = i
    out = list(fits)
    for i, fit in enumerate(fits):
        if fit.applied and chosen[fit.tgt_id] != i:
            note = f"reference object {fits[chosen[fit.tgt_id]].ref_id} fits the same target object on more points"
            out[i] = dataclasses.replace(fit, applied=False, note=note)
    return out, {tgt_id: (fits[i].gain, fits[i].offset) for tgt_id, i in chosen.items()}
