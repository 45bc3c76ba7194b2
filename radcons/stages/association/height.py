"""Association of objects found from height: by construction, with SIFT matches as evidence.

Objects of the ``"height"`` method (:func:`radcons.stages.objects.run.height_objects`) are
found in the reference and moved into the target by their own modal disparity D̄m, so
each reference object is associated with the target object of the same id, and D̄m is
that disparity (method ``"height"``). The pair's SIFT matches
(:func:`radcons.stages.association.run.match_features`) stay as evidence: the matches whose
reference point lies in the object and whose target point lies in its target object link
the two, those within ``invariant_threshold`` of D̄m are the invariant points (eq 12).
An object holding more than ``min_matches`` matches (reference point inside it) of which
fewer than half agree with D̄m is flagged: its matches contradict its disparity.

References
----------
Su, Yan, Zhao, Wang (2018), Remote Sensing 10(2), sections 3 and 4.2.2 (eq 12).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from radcons.results import Association, Matches, ObjectAssociation
from radcons.stages.association.params import AssociationParams

__all__ = ["HeightAssociation", "associate_by_height"]


@dataclass(frozen=True)
class HeightAssociation(ObjectAssociation):
    """An association made by construction, with what the SIFT matches say about it.

    Attributes
    ----------
    evidence : str
        ``"agrees"`` (at least half of the object's matches lie within
        ``invariant_threshold`` of D̄m), ``"contradicts"`` (more than ``min_matches``
        matches, fewer than half of them agreeing: flagged), or ``"few matches"``.
    """

    evidence: str = "few matches"

    @property
    def flagged(self) -> bool:
        """True when the object's matches contradict its disparity."""
        return self.evidence == "contradicts"


def _label_at(labels: np.ndarray, xy: np.ndarray) -> np.ndarray:
    cols = np.clip(np.rint(xy[:, 0]).astype(np.int64), 0, labels.shape[1] - 1)
    rows = np.clip(np.rint(xy[:, 1]).astype(np.int64), 0, labels.shape[0] - 1)
    return labels[rows, cols]


def associate_by_height(
    labels_ref: np.ndarray,
    labels_tgt: np.ndarray,
    modal: dict[int, float],
    matches: Matches,
    params: AssociationParams = AssociationParams(),
    scores: dict[int, float] | None = None,
) -> Association:
    """Associate each reference object with its moved copy in the target.

    Parameters
    ----------
    labels_ref, labels_tgt : ndarray of int
        Reference objects and their moved copies (same ids).
    modal : dict
        Object id -> D̄m (px).
    matches : Matches
        The pair's SIFT matches.
    params : AssociationParams
        ``min_matches`` and ``invariant_threshold`` are used.
    scores : dict, optional
        Object id -> NCC of the object against the target at D̄m (kept as ``score``).

    Returns
    -------
    Association
        One :class:`HeightAssociation` per object with a D̄m and a target copy, in
        increasing id; the other reference objects in ``unassociated_ref``.
    """
    scores = scores or {}
    disparity = matches.disparity.astype(np.float64)
    if len(matches):
        lab_r, lab_t = _label_at(labels_ref, matches.ref_xy), _label_at(labels_tgt, matches.tgt_xy)
    else:
        lab_r = lab_t = np.zeros(0, np.int32)
    present_tgt = set(np.unique(labels_tgt).tolist())
    objects: list[ObjectAssociation] = []
    unassociated: list[int] = []
    for ref_id in (int(i) for i in np.unique(labels_ref) if i > 0):
        if ref_id not in modal or ref_id not in present_tgt:
            unassociated.append(ref_id)
            continue
        d_m = float(modal[ref_id])
        inside = np.flatnonzero(lab_r == ref_id)
        agree = np.abs(disparity[inside] - d_m) < params.invariant_threshold
        if inside.size > params.min_matches:
            evidence = "agrees" if 2 * int(agree.sum()) >= inside.size else "contradicts"
        else:
            evidence = "few matches"
        link = inside[lab_t[inside] == ref_id]
        invariant = link[np.abs(disparity[link] - d_m) < params.invariant_threshold]
        objects.append(
            HeightAssociation(
                ref_id, ref_id, "height", d_m, link, invariant, float(scores.get(ref_id, float("nan"))), evidence
            )
        )
    return Association(matches, tuple(objects), tuple(unassociated))
