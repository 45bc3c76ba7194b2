"""Flat roofs cut into rectangular parts, joined again.

The height method's snapping (:func:`radcons.stages.objects.regions.segment_elevated`)
can cut a flat roof along an edge inside it (the inner corner of an L, a row of roof
furniture, a change of material): the roof ends as two rectangles, each associated on its
own. :mod:`radcons.stages.objects.joins.halves` joins only parts that touch along most of the
roof's length (a gable's ridge); these touch across the width of the smaller part: a
wing on its block, or one end of a long roof on the other.

Two objects are parts of one roof when all of these hold (:func:`join_wings`):

1. the line between them (pixels next to both) spans at least :data:`SHARED_WIDTH` of the
   shorter side of the smaller one's smallest rotated rectangle: the wing is attached
   across its whole width (a building beside another touches it along part of a side,
   or at a corner);
2. their D̄m differ by at most :data:`MAX_DISPARITY_STEP` px: one flat roof height
   (two adjacent buildings of different heights differ by more);
3. each fills at least :data:`PART_RECTANGULARITY` of its smallest rotated rectangle, and
   those rectangles are parallel within :data:`MAX_TURN` degrees: rectilinear parts of
   one plan (crowns and shadows are neither).

Two buildings of one height built wall to wall, with the wall across the narrower one,
meet these rules too and become one object: the pair cannot tell them from one roof cut
by an edge (the gable rule makes the same choice along a long side).

Each object joins at most one other per pass (the pair with the longest shared line
first); the joined object takes the D̄m and match score of its larger part, and the line
between the two. It runs after every search for objects (after a second pass of the gable
rule), so a part found by the search for missed buildings joins the rest of its roof too.
"""

from __future__ import annotations

import cv2
import numpy as np
import scipy.ndimage

from radcons.stages.objects.joins.halves import join_pairs, long_side

__all__ = ["join_wings", "SHARED_WIDTH", "MAX_DISPARITY_STEP", "PART_RECTANGULARITY", "MAX_TURN"]

#: Shared line over the shorter side of the smaller part's smallest rotated rectangle.
SHARED_WIDTH = 0.8
#: Largest difference of the two parts' D̄m, px.
MAX_DISPARITY_STEP = 0.5
#: Smallest area of each part over its smallest rotated rectangle's.
PART_RECTANGULARITY = 0.8
#: Largest angle between the two parts' rectangles, degrees (modulo 90).
MAX_TURN = 10.0


def _rectangle(mask: np.ndarray) -> tuple[float, float, float]:
    """Shorter side (px, pixel centres + 1), angle (degrees) and rectangularity of the mask's smallest rotated rectangle."""
    y, x = np.nonzero(mask)
    (_, _), (width, height), angle = cv2.minAreaRect(np.column_stack([x, y]).astype(np.float32))
    return float(min(width, height)) + 1.0, float(angle), float(mask.sum()) / max(float(width * height), 1.0)


def join_wings(
    labels: np.ndarray, modal: dict[int, float], scores: dict[int, float]
) -> tuple[np.ndarray, dict[int, float], dict[int, float]]:
    """Join the pairs of objects that are rectangular parts of one flat roof (module notes, rules 1-3).

    Parameters and returns as :func:`radcons.stages.objects.joins.halves.join_roof_halves`.
    """
    shapes = {
        index: _rectangle(labels[box] == index)
        for index, box in enumerate(scipy.ndimage.find_objects(labels.astype(np.int32)), start=1)
        if box is not None
    }

    def parts_of_one_roof(a: int, b: int, line: np.ndarray, current: np.ndarray, area: np.ndarray) -> bool:
        if not abs(modal[a] - modal[b]) <= MAX_DISPARITY_STEP:
            return False
        if min(shapes[a][2], shapes[b][2]) < PART_RECTANGULARITY:
            return False
        turn = abs(shapes[a][1] - shapes[b][1]) % 90.0
        if min(turn, 90.0 - turn) > MAX_TURN:
            return False
        smaller = b if area[a] >= area[b] else a
        return long_side(line) >= SHARED_WIDTH * shapes[smaller][0]

    return join_pairs(labels, modal, scores, parts_of_one_roof)
