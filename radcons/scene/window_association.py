"""Section 3's association of the scene's objects at full resolution, by the stage's rule.

The decimated copy links objects on keypoints ``k`` times coarser than the in-memory run's,
and the objects linked by 3 to 5 matches in memory fall on either side of the
``> min_matches`` rule there. Scene mode therefore associates at full resolution, as the
stage (:func:`radcons.stages.association.run.associate_objects`) does:

* SIFT (:func:`sift_associations`): the scene's full-resolution matches
  (:func:`radcons.scene.features.scene_matches`) with the labels under their points; the
  target object holding most of a reference object's matches is its partner when more
  than ``min_matches`` matches link them and more than ``min_matches`` of those agree
  with their D̄m (eq 12);
* otherwise the stage's template matching (:func:`radcons.stages.association.run._template`,
  :func:`template_association`) on a crop holding the object and its search strip, over
  the stage's search range from the scene's matches: the crop reproduces the stage's
  result on the whole image (its edge rules see the image's edges where the crop meets
  them).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.ndimage

from radcons.results import Matches, ObjectAssociation

if TYPE_CHECKING:
    from radcons.scene.pairwide import FitContext

__all__ = ["sift_associations", "template_association", "with_matches"]

_NONE = np.zeros(0, np.int64)


def sift_associations(
    matches: Matches, labels_ref: np.ndarray, labels_tgt: np.ndarray, ref_ids: list[int], params: Any
) -> tuple[list[ObjectAssociation], list[int]]:
    """The stage's SIFT rule for each of ``ref_ids``; returns the associations and the ids left.

    ``labels_ref`` and ``labels_tgt`` are the labels under each match's two points.
    """
    from radcons.numerics.modal import modal_disparity

    disparity = matches.disparity.astype(np.float64)
    found, left = [], []
    for ref_id in ref_ids:
        inside = np.flatnonzero(labels_ref == ref_id)
        linked = inside[labels_tgt[inside] > 0]
        if linked.size:
            ids, counts = np.unique(labels_tgt[linked], return_counts=True)
            if counts.max() > params.min_matches:
                tgt_id = int(ids[np.argmax(counts)])
                link = np.sort(linked[labels_tgt[linked] == tgt_id])
                modal = modal_disparity(disparity[link])
                invariant = link[np.abs(disparity[link] - modal) < params.invariant_threshold]
                if invariant.size > params.min_matches:
                    found.append(ObjectAssociation(ref_id, tgt_id, "sift", modal, link, invariant))
                    continue
        left.append(ref_id)
    return found, left


def with_matches(obj: ObjectAssociation, matches: Matches, labels_ref: np.ndarray, labels_tgt: np.ndarray,
                 params: Any) -> ObjectAssociation:
    """A template association with its matches and invariant points (eq 12), as the stage lists them."""
    if obj.tgt_id == 0:
        return obj
    link = np.flatnonzero((labels_ref == obj.ref_id) & (labels_tgt == obj.tgt_id))
    invariant = link[np.abs(matches.disparity[link].astype(np.float64) - obj.modal_disparity) < params.invariant_threshold]
    return dataclasses.replace(obj, match_indices=link, invariant_indices=invariant)


def template_association(ref_id: int, context: FitContext) -> ObjectAssociation | None:
    """The stage's template matching of one reference object on a crop of the scene, or None.

    The crop holds the object's window (``context.reference_boxes``) and its search strip;
    None when the object has no window or the stage's rule does not associate it.
    """
    from radcons.stages.association.run import _template

    box = context.reference_boxes.get(ref_id)
    if box is None:
        return None
    search = context.search
    rows, columns = context.pair.shape
    crop = (
        max(min(box[0], box[0] + search.dy - search.dy_range), 0),
        min(max(box[1], box[1] + search.dy + search.dy_range), rows),
        max(min(box[2], box[2] - search.d_high), 0),
        min(max(box[3], box[3] - search.d_low), columns),
    )
    labels_ref = context.labels.window("reference", crop)
    found = scipy.ndimage.find_objects((labels_ref == ref_id).astype(np.int32))
    if not found or found[0] is None:
        return None
    reference = context.pair.reference.read_float(crop)
    target = context.pair.target.read_float(crop)
    ref_valid = np.isfinite(reference)
    tgt_valid = np.isfinite(target)
    fill = np.float32(context.target_mean)
    result = _template(
        np.where(ref_valid, reference, np.float32(0.0)), ref_valid, np.where(tgt_valid, target, fill),
        labels_ref, context.labels.window("target", crop), ref_id, found[0], search, context.params.association,
    )
    if result is None:
        return None
    tgt_id, modal, score = result
    return ObjectAssociation(ref_id, tgt_id, "template", modal, _NONE, _NONE, score)
