"""Section 3's association of one reference object, made at full resolution in its window.

The decimated copy links objects on keypoints ``k`` times coarser than the in-memory run's,
and a few objects (those linked by 3 to 5 matches in memory) fall on the other side of the
``> min_matches`` rule there. Each reference object is therefore associated again at full
resolution by the stage's own rule (:mod:`radcons.stages.association`), on a window:

* SIFT: keypoints of the object's window (its box widened by :data:`DETECT_MARGIN`) matched with those of the target's
  band of the same rows (widened by ``ratio_rows``, so that Lowe's ratio test sees the
  candidates it sees in memory) over the disparities of the scene's matches
  (:func:`radcons.scene.pairwide.match_range`). Each window keeps the keypoint density of
  an in-memory run: ``max_features`` times its share of the scene's pixels (the in-memory
  stage keeps ``max_features`` keypoints over the whole image). The target object holding
  most of the object's matches is its partner when more than ``min_matches`` matches link
  them and more than ``min_matches`` of those agree with their D̄m (eq 12);
* otherwise the stage's template matching (:func:`radcons.stages.association._template`)
  on a crop holding the object and its search strip, over the stage's search range
  computed from the scene's matches: the crop reproduces the stage's result on the whole
  image (its edge rules see the image's edges where the crop meets them).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np
import scipy.ndimage

from radcons.results import ObjectAssociation
from radcons.scene.source import Window

if TYPE_CHECKING:
    from radcons.scene.pairwide import FitContext

__all__ = ["associate_object", "keypoint_budget"]

_NONE = np.zeros(0, np.int64)
#: Pixels added around each window before SIFT: keypoints within 5 px per octave of an
#: image's edge are dropped and descriptors reach some 14 px per octave, so an object's
#: corners at its box's edge keep the keypoints and descriptors they have in memory.
DETECT_MARGIN = 64


def keypoint_budget(window: Window, shape: tuple[int, int], max_features: int) -> int:
    """Keypoints a window keeps: ``max_features`` times its share of the scene (0: all, as the stage)."""
    if max_features == 0:
        return 0
    share = (window[1] - window[0]) * (window[3] - window[2]) / (float(shape[0]) * float(shape[1]))
    return max(1, math.ceil(max_features * share))


def _features(image: np.ndarray, window: Window, context: FitContext) -> tuple[np.ndarray, np.ndarray]:
    """SIFT keypoints (scene coordinates) and descriptors of one window, at the in-memory density."""
    from radcons.stages.association import _detect  # the stage's detector, not a copy of it

    params = context.params.association
    budget = keypoint_budget(window, context.pair.shape, params.max_features)
    xy, descriptors = _detect(image, dataclasses.replace(params, max_features=budget))
    return xy + np.array([window[2], window[0]], np.float32), descriptors


def _label_at(labels: np.ndarray, window: Window, xy: np.ndarray) -> np.ndarray:
    rows = np.clip(np.rint(xy[:, 1]).astype(np.int64) - window[0], 0, labels.shape[0] - 1)
    cols = np.clip(np.rint(xy[:, 0]).astype(np.int64) - window[2], 0, labels.shape[1] - 1)
    return labels[rows, cols]


def _sift_association(ref_id: int, box: Window, context: FitContext) -> ObjectAssociation | None:
    """The stage's SIFT rule on the object's window and its target band, or None."""
    from radcons.stages.association import _match_rows, modal_disparity

    params = context.params.association
    rows, columns = context.pair.shape
    low, high = context.match_range
    pad = DETECT_MARGIN + math.ceil(max(params.ratio_rows, params.row_tolerance))
    band = (max(box[0] - pad, 0), min(box[1] + pad, rows),
            max(int(math.floor(box[2] - high)) - DETECT_MARGIN, 0),
            min(int(math.ceil(box[3] - low)) + DETECT_MARGIN, columns))
    box = (max(box[0] - DETECT_MARGIN, 0), min(box[1] + DETECT_MARGIN, rows),
           max(box[2] - DETECT_MARGIN, 0), min(box[3] + DETECT_MARGIN, columns))
    ref_xy, ref_desc = _features(context.pair.reference.read_float(box), box, context)
    tgt_xy, tgt_desc = _features(context.pair.target.read_float(band), band, context)
    if len(ref_xy) == 0 or len(tgt_xy) == 0:
        return None
    ref_idx, tgt_idx = _match_rows(ref_xy, ref_desc, tgt_xy, tgt_desc, params)
    labels_ref = _label_at(context.labels.window("reference", box), box, ref_xy[ref_idx])
    labels_tgt = _label_at(context.labels.window("target", band), band, tgt_xy[tgt_idx])
    disparity = (ref_xy[ref_idx, 0] - tgt_xy[tgt_idx, 0]).astype(np.float64)
    on_object = (labels_ref == ref_id) & (labels_tgt > 0)
    if not on_object.any():
        return None
    ids, counts = np.unique(labels_tgt[on_object], return_counts=True)
    if counts.max() <= params.min_matches:
        return None
    tgt_id = int(ids[np.argmax(counts)])
    linked = disparity[on_object & (labels_tgt == tgt_id)]
    modal = modal_disparity(linked)
    if (np.abs(linked - modal) < params.invariant_threshold).sum() <= params.min_matches:
        return None
    return ObjectAssociation(ref_id, tgt_id, "sift", modal, _NONE, _NONE)


def _template_association(ref_id: int, box: Window, context: FitContext) -> ObjectAssociation | None:
    """The stage's template matching of the object on a crop of the scene, or None."""
    from radcons.stages.association import _template

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


def associate_object(ref_id: int, context: FitContext) -> ObjectAssociation | None:
    """Associate one reference object at full resolution (the stage's rule), or None.

    Parameters
    ----------
    ref_id : int
        Reference object id; its window is ``context.reference_boxes[ref_id]``.
    context : FitContext

    Returns
    -------
    ObjectAssociation or None
        ``"sift"`` or ``"template"``, without match indices (its matches are not among the
        scene's); None when neither rule associates it.
    """
    box = context.reference_boxes.get(ref_id)
    if box is None:
        return None
    return _sift_association(ref_id, box, context) or _template_association(ref_id, box, context)
