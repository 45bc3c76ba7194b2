"""Colours and annotation classes of a recording.

Every associated object pair gets one colour, a function of its reference object id only,
so the same building has the same colour in the reference labels, the target labels, the
match lines, the fit plot and between recordings of the same pair. Objects without a
partner are grey.
"""

from __future__ import annotations

import colorsys
from dataclasses import dataclass

import numpy as np

from radcons.results import Association, ObjectLabels

__all__ = ["GREY", "LEFT_OUT_RGB", "object_color", "method_color", "ObjectClasses", "object_classes", "MAX_CLASS_ID"]

#: Colour of objects without a partner and of matches outside every object pair.
GREY = (150, 150, 150)
#: Largest class id rerun's annotation context can address (class ids are 16-bit).
MAX_CLASS_ID = 65535
#: Colour of each rule code of the regions the height method left out
#: (:data:`radcons.stages.objects.rules.LEFT_OUT_RULES`): greens for trees, warm colours
#: for the disparity artefacts, purple and blue for shadows and edgeless patches.
LEFT_OUT_RGB: dict[int, tuple[int, int, int]] = {
    1: (60, 200, 80),
    2: (250, 220, 40),
    3: (250, 140, 30),
    4: (160, 80, 220),
    5: (50, 120, 250),
    6: (150, 90, 50),
    7: (235, 235, 235),
    8: (20, 90, 40),
}
_GOLDEN = 0.6180339887498949
_METHOD_COLORS = {"original": (140, 140, 140), "ours": (30, 160, 70)}
_OTHER_COLORS = ((66, 133, 244), (234, 120, 40), (170, 80, 200), (200, 60, 60), (20, 170, 190), (190, 160, 20))


def object_color(ref_id: int) -> tuple[int, int, int]:
    """Stable, well-separated colour of the object pair whose reference id is ``ref_id``.

    Hues follow the golden-ratio sequence, so neighbouring ids get distant hues.
    """
    hue = (int(ref_id) * _GOLDEN) % 1.0
    red, green, blue = colorsys.hsv_to_rgb(hue, 0.75, 0.95)
    return int(red * 255), int(green * 255), int(blue * 255)


def method_color(name: str, index: int) -> tuple[int, int, int]:
    """Colour of a compared method: grey for ``original``, green for ``ours``, else by order."""
    return _METHOD_COLORS.get(name, _OTHER_COLORS[index % len(_OTHER_COLORS)])


@dataclass(frozen=True)
class ObjectClasses:
    """Class ids of the objects of both images, for ``SegmentationImage`` + ``AnnotationContext``.

    Attributes
    ----------
    reference_lut, target_lut : ndarray of uint16
        Label id -> class id (``lut[labels]`` is the class image); 0 stays 0 (background).
    classes : list of (int, str, (int, int, int))
        ``(class_id, label, colour)`` of every class; the labels name both object ids.
    partner_of_target : dict
        Target object id -> the reference object id it is coloured by.
    """

    reference_lut: np.ndarray
    target_lut: np.ndarray
    classes: list[tuple[int, str, tuple[int, int, int]]]
    partner_of_target: dict[int, int]


def _present(labels: np.ndarray) -> np.ndarray:
    """Ids (> 0) that occur in a non-negative label raster."""
    counts = np.bincount(labels.ravel()) if labels.size else np.zeros(1, np.int64)
    ids = np.flatnonzero(counts)
    return ids[ids > 0]


def object_classes(objects: ObjectLabels, association: Association | None, notes: dict[int, str]) -> ObjectClasses:
    """Class ids, labels and colours of the objects of both images.

    An associated target object takes the class (hence the colour and the label) of its
    reference partner; when several reference objects share one target object, the
    association with the most invariant points (then matches) wins, as in the refined
    stage. Class ids are consecutive: reference objects first (in id order), then the
    target objects without a partner. Beyond :data:`MAX_CLASS_ID` classes the ids wrap
    around, so colours and labels repeat.

    Parameters
    ----------
    objects : ObjectLabels
        Non-negative int label rasters, 0 = background.
    association : Association or None
        Object pairs; None means no object has a partner.
    notes : dict
        Reference object id -> text appended to its label (its metrics).

    Returns
    -------
    ObjectClasses
    """
    ref_ids = _present(objects.reference)
    tgt_ids = _present(objects.target)
    pairs = sorted(association.objects if association is not None else (), key=lambda a: (a.n_invariant, a.n_matches))
    partner = {int(a.tgt_id): int(a.ref_id) for a in pairs if a.tgt_id > 0}  # the best pair is written last
    partner_ids = {int(a.ref_id): int(a.tgt_id) for a in pairs}

    def wrap(rank: np.ndarray) -> np.ndarray:
        return (1 + (rank - 1) % MAX_CLASS_ID).astype(np.uint16)

    ref_class = wrap(np.arange(1, ref_ids.size + 1))
    reference_lut = np.zeros(int(objects.reference.max(initial=0)) + 1, np.uint16)
    reference_lut[ref_ids] = ref_class
    class_of_ref = dict(zip(ref_ids.tolist(), ref_class.tolist()))

    lonely = np.array([t for t in tgt_ids.tolist() if t not in partner], dtype=np.int64)
    lonely_class = wrap(np.arange(ref_ids.size + 1, ref_ids.size + lonely.size + 1))
    target_lut = np.zeros(int(objects.target.max(initial=0)) + 1, np.uint16)
    target_lut[lonely] = lonely_class
    for tgt_id, ref_id in partner.items():
        if tgt_id < target_lut.size and ref_id in class_of_ref:
            target_lut[tgt_id] = class_of_ref[ref_id]

    classes: list[tuple[int, str, tuple[int, int, int]]] = []
    for ref_id, class_id in class_of_ref.items():
        note = notes.get(ref_id, "")
        if ref_id in partner_ids:
            tgt_id = partner_ids[ref_id]
            label = f"object {ref_id} (target {tgt_id})" if tgt_id > 0 else f"object {ref_id} (no target object)"
            color = object_color(ref_id)
        else:
            label, color = f"object {ref_id} (reference only)", GREY
        classes.append((class_id, f"{label} {note}".strip(), color))
    for tgt_id, class_id in zip(lonely.tolist(), lonely_class.tolist()):
        classes.append((class_id, f"target object {tgt_id} (no partner)", GREY))
    return ObjectClasses(reference_lut, target_lut, classes, partner)
