"""Gabled roofs split at their ridge, joined again.

The height method's snapping (:func:`radcons.stages.objects.regions.segment_elevated`)
places object boundaries on the reference's strongest edges. A gabled roof has one inside
it: the ridge between its sunlit and its shaded plane, which can be as strong as the
roof's outline. At fine resolution a gabled roof often ends as two objects, each about
half the building, and each associated on its own.

Two objects are one roof when all of these hold (:func:`join_roof_halves`):

1. they touch along most of their length: the line between them (pixels next to both)
   is at least :data:`SHARED_LENGTH` of the longer side of the larger one's smallest
   rotated rectangle (a ridge runs the whole roof; a building beside its shadow or a
   neighbour touches along part of it, or along its short side);
2. their D̄m differ by at most :data:`MAX_DISPARITY_STEP` px: one height, where two
   adjacent buildings of different heights differ;
3. the smaller is at least :data:`AREA_RATIO` of the larger (two planes of one roof, not
   a roof and a strip beside it);
4. together they fill at least :data:`UNION_RECTANGULARITY` of their smallest rotated
   rectangle.

Each object joins at most one other (the pair with the longest shared line first); the
joined object takes the D̄m and match score of its larger part, and the line between the
two. It runs on the objects that passed the tree and artefact rules, so a shadow or a
façade strip beside a roof, left out there, cannot join it; and again after the searches,
for the objects they added.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np
import scipy.ndimage

from radcons.stages.objects.regions import keep_objects

__all__ = [
    "join_roof_halves", "join_pairs", "shared_lines", "long_side", "rectangularity", "rotated_rectangle",
    "SHARED_LENGTH", "MAX_DISPARITY_STEP", "AREA_RATIO", "UNION_RECTANGULARITY",
]

#: Shared line over the longer side of the larger part's smallest rotated rectangle.
SHARED_LENGTH = 0.7
#: Largest difference of the two parts' D̄m, px.
MAX_DISPARITY_STEP = 1.5
#: Smallest area of the smaller part over the larger's.
AREA_RATIO = 0.3
#: Smallest area of the joined object over its smallest rotated rectangle's.
UNION_RECTANGULARITY = 0.8

#: The 4-neighbours structuring element.
_NEIGHBOURS = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))


def long_side(points: np.ndarray) -> float:
    """Longer side of the smallest rotated rectangle around the (x, y) points, px."""
    (_, _), (width, height), _ = cv2.minAreaRect(points.astype(np.float32))
    return float(max(width, height)) + 1.0


def rotated_rectangle(mask: np.ndarray) -> tuple[tuple[float, float], tuple[float, float], float]:
    """Smallest rotated rectangle around the mask's pixel centres (``cv2.minAreaRect``'s centre, size, angle).

    Found from the pixels of its outer contours, whose convex hull is all the pixels'.
    """
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    return cv2.minAreaRect(np.concatenate(contours)[:, 0, :].astype(np.float32))


def rectangularity(mask: np.ndarray) -> float:
    """Area of the mask over its smallest rotated rectangle's (pixel centres)."""
    (_, _), (width, height), _ = rotated_rectangle(mask)
    return float(mask.sum()) / max(float(width * height), 1.0)


def shared_lines(labels: np.ndarray) -> dict[tuple[int, int], np.ndarray]:
    """``(a, b) -> (x, y)`` points of the line between objects a < b: pixels 4-adjacent to both."""
    lines: dict[tuple[int, int], np.ndarray] = {}
    for index, box in enumerate(scipy.ndimage.find_objects(labels), start=1):
        if box is None:
            continue
        rows = slice(max(box[0].start - 2, 0), box[0].stop + 2)
        cols = slice(max(box[1].start - 2, 0), box[1].stop + 2)
        window = labels[rows, cols]
        near = cv2.dilate((window == index).astype(np.uint8), _NEIGHBOURS) > 0
        reach = cv2.dilate(near.astype(np.uint8), _NEIGHBOURS) > 0  # objects across a one-pixel line
        for other in np.unique(window[reach]):
            if other <= index:
                continue
            both = near & (cv2.dilate((window == other).astype(np.uint8), _NEIGHBOURS) > 0)
            y, x = np.nonzero(both)
            if y.size >= 2:
                lines[(index, int(other))] = np.column_stack([x + cols.start, y + rows.start])
    return lines


def join_roof_halves(
    labels: np.ndarray, modal: dict[int, float], scores: dict[int, float]
) -> tuple[np.ndarray, dict[int, float], dict[int, float]]:
    """Join the pairs of objects that are the two planes of one roof (module notes, rules 1-4).

    Parameters
    ----------
    labels : ndarray of int
        The reference's objects, 1..K (0 = background).
    modal : dict
        Object id -> D̄m (px); objects without one are never joined.
    scores : dict
        Object id -> match score.

    Returns
    -------
    labels : ndarray of int32
        The objects, numbered 1..K' in the order of their first part.
    modal, scores : dict
        D̄m and score of each, those of its larger part where two were joined.
    """
    boxes = scipy.ndimage.find_objects(labels.astype(np.int32))

    def planes_of_one_roof(a: int, b: int, line: np.ndarray, current: np.ndarray, area: np.ndarray) -> bool:
        if not abs(modal[a] - modal[b]) <= MAX_DISPARITY_STEP:
            return False
        larger, smaller = (a, b) if area[a] >= area[b] else (b, a)
        if area[smaller] < AREA_RATIO * area[larger]:
            return False
        rows, cols = (
            slice(max(min(boxes[a - 1][k].start, boxes[b - 1][k].start) - 1, 0),
                  max(boxes[a - 1][k].stop, boxes[b - 1][k].stop) + 1)
            for k in (0, 1)
        )
        window = current[rows, cols]  # one pixel beyond both boxes: the line between them
        y, x = np.nonzero(window == larger)
        if long_side(line) < SHARED_LENGTH * long_side(np.column_stack([x, y])):
            return False
        union = (window == a) | (window == b)
        union[line[:, 1] - rows.start, line[:, 0] - cols.start] = True
        return rectangularity(union) >= UNION_RECTANGULARITY

    return join_pairs(labels, modal, scores, planes_of_one_roof)


def join_pairs(
    labels: np.ndarray,
    modal: dict[int, float],
    scores: dict[int, float],
    rule: Callable[[int, int, np.ndarray, np.ndarray, np.ndarray], bool],
) -> tuple[np.ndarray, dict[int, float], dict[int, float]]:
    """Join the touching pairs of objects that ``rule`` takes for parts of one roof.

    Pairs are tried from the longest line between them (:func:`shared_lines`) down; each
    object joins at most one other, and only objects with a D̄m are joined. The joined
    object takes the line between its parts, and the D̄m and score of its larger part.

    Parameters
    ----------
    labels : ndarray of int
        The reference's objects, 1..K (0 = background).
    modal : dict
        Object id -> D̄m (px).
    scores : dict
        Object id -> match score.
    rule : callable
        ``rule(a, b, line, labels, area)``: whether objects ``a`` and ``b``, touching
        along ``line`` ((x, y) points), are one roof; ``labels`` are the objects as
        joined so far (``a`` and ``b`` unchanged), ``area`` their areas by id.

    Returns
    -------
    labels : ndarray of int32
        The objects, numbered 1..K' in the order of their first part.
    modal, scores : dict
        D̄m and score of each.
    """
    count = int(labels.max())
    if count < 2:
        return labels.astype(np.int32), dict(modal), dict(scores)
    labels = labels.astype(np.int32, copy=True)
    area = np.bincount(labels.ravel(), minlength=count + 1)
    joined = np.zeros(count + 1, bool)
    for (a, b), line in sorted(shared_lines(labels).items(), key=lambda item: -len(item[1])):
        if joined[a] or joined[b] or a not in modal or b not in modal or not rule(a, b, line, labels, area):
            continue
        larger, smaller = (a, b) if area[a] >= area[b] else (b, a)
        joined[[a, b]] = True
        labels[labels == smaller] = larger
        gap = labels[line[:, 1], line[:, 0]] == 0
        labels[line[gap, 1], line[gap, 0]] = larger
    if not joined.any():
        return labels, dict(modal), dict(scores)
    return keep_objects(labels, np.bincount(labels.ravel(), minlength=count + 1) > 0, modal, scores)
