"""Pass 1's fit of each associated object (eq 7-12) on a full-resolution window around it.

Each associated object is fitted at full resolution on a window around it (its target box
widened by D̄m), with the scene's lambda of eq 5 and the scene's clipping levels, by
:func:`radcons.stages.refine.run.refine_target` itself; an object still to be associated is
first associated by template matching
(:func:`radcons.scene.window_association.template_association`). When several reference
objects fit one target object, the one with the most points is applied, as in the
in-memory run (:func:`choose_fits`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from radcons.results import Association, Matches, ObjectAssociation, ObjectFit
from radcons.scene.light import mapped_background
from radcons.scene.pairwide import FitContext
from radcons.scene.source import Window
from radcons.scene.window_association import template_association
from radcons.stages.refine.run import refine_target

__all__ = ["fit_objects", "choose_fits"]

def _kept(obj: ObjectAssociation, note: str) -> ObjectFit:
    empty = np.zeros(0, np.float64)
    return ObjectFit(obj.ref_id, obj.tgt_id, 1.0, 0.0, empty, empty, empty, False, 0, note)


def fit_objects(
    chunk: list[ObjectAssociation | int], context: FitContext
) -> list[tuple[int, ObjectAssociation | None, ObjectFit | None]]:
    """Fit each object of ``chunk`` (eq 7-12) on a full-resolution window around it.

    ``chunk`` holds associations, or reference ids to associate first by template matching
    (:func:`radcons.scene.window_association.template_association`). Returns
    ``(ref_id, association, fit)`` per item; association and fit are None for an object
    that stays unassociated.
    """
    fits = []
    for item in chunk:
        obj = template_association(item, context) if isinstance(item, int) else item
        if obj is None:
            fits.append((item, None, None))
            continue
        fits.append((obj.ref_id, obj, _fit_one(obj, context.target_boxes.get(obj.tgt_id), context, context.pair.shape[1])))
    return fits


def _fit_one(obj: ObjectAssociation, box: Window | None, context: FitContext, columns: int) -> ObjectFit:
    """The fit of one object on the window of its target box widened by D̄m (see :func:`fit_objects`)."""
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
        background = mapped_background(raw, context.background, context.light, (window[0], window[2]))
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
