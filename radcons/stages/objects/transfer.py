"""Each object's D̄m, its checks, and its move into the target.

An object of the height method is moved into the target by its own disparity D̄m
(:func:`transfer_to_target`), so its D̄m must be right to the pixel, and a region the
matcher raised must not pass for an object:

1. **D̄m** (:func:`object_disparities`, on the first regions): the mode of the object's
   census disparities (1 px bins, :func:`radcons.numerics.modal.modal_disparity`),
   refined within ``disparity_radius`` px by the mean census cost of its pixels at full
   resolution (:func:`radcons.stages.objects.disparity.object_census_disparity`): the
   mode of the reduced grid, with its fattened edges, is often more than a pixel off,
   and a masked NCC refinement is pulled off the roof by walls and ground.
2. **Census contrast** (the same function): the object's mean census cost at the ground's
   disparity under it less that at D̄m. A roof matches better at its own disparity than
   at the ground's whatever the dates and sensors do to its grey levels (census sees only
   their local order); a patch of ground raised by a mismatch does not, and is left out
   below ``min_match_score``.
3. **D̄m of the final objects** (:func:`refined_disparities`): refined again on each
   object's core once its outline is final, away from the rim whose census windows reach
   the façade or the ground.
4. **Left-right check** (:func:`matched_back`, ``cross_check_objects``): an object is moved
   into the target only when its copy there, matched back into the reference over the
   searched range, finds its least census cost within 2 px of D̄m
   (:func:`radcons.stages.objects.disparity.matches_back`); ground that the target hides
   beside a building, changed roofs and repeated patterns do not.
5. **Transfer** (:func:`transfer_to_target`): the target's object is the reference's moved
   left by D̄m, the objects nearer the sensor (larger D̄m) drawn last.

:func:`match_scores` gives the NCC of an object against the target near its D̄m, the
score recorded for every object.
"""

from __future__ import annotations

import cv2
import numpy as np

from radcons.numerics.subpixel import parabola_peak
from radcons.stages.objects.disparity import (
    census_descriptors,
    matches_back,
    object_census_costs,
    object_census_disparity,
    spread_pixels,
)
from radcons.stages.objects.features import smoothed
from radcons.stages.objects.ground import HeightMap
from radcons.stages.objects.regions import label_boxes

__all__ = [
    "object_disparities", "refined_disparities", "matched_back", "match_scores", "transfer_to_target", "FINAL_RIM",
]

#: Pixels of a final object within this many px of its outline do not refine its D̄m: the
#: 5 x 5 census window of a pixel there reaches past the outline, onto the façade the
#: oblique view shows or the ground beside it.
FINAL_RIM = 3


def _refine_shift(
    reference: np.ndarray, target: np.ndarray, mask: np.ndarray, box: tuple[slice, slice], disparity: float, radius: int
) -> tuple[float, float]:
    """D̄m refined by masked NCC of the object against the target within ``radius`` px.

    Returns the refined disparity (the given one when the peak lies on the search's edge
    or the object does not fit) and the NCC score at it (NaN when nothing was matched).
    """
    rows, cols = box
    width = target.shape[1]
    start = int(round(disparity))
    x0, x1 = max(cols.start, start + radius), min(cols.stop, width + start - radius)
    if x1 - x0 < 4:
        return disparity, float("nan")
    mask = mask[:, x0 - cols.start : x1 - cols.start]
    template = reference[rows, x0:x1]
    if mask.sum() < 16 or np.ptp(template[mask]) == 0:
        return disparity, float("nan")
    left = x0 - start - radius
    strip = target[rows, left : x1 - start + radius]
    scores = cv2.matchTemplate(strip, template, cv2.TM_CCOEFF_NORMED, mask=mask.astype(np.uint8)).ravel()
    scores[~np.isfinite(scores)] = -np.inf
    peak = int(np.argmax(scores))
    if not 0 < peak < scores.size - 1:
        return disparity, float(scores[radius])
    sub = parabola_peak(scores[peak - 1], scores[peak], scores[peak + 1])
    return float(x0 - (left + peak + sub)), float(scores[peak])


def _core_pixels(mask: np.ndarray, box: tuple[slice, slice], rim: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns (full image) of the object eroded by ``rim`` px, or of all of it when less than a quarter would remain."""
    padded = np.pad(mask, rim).astype(np.uint8)  # the box is the object's own: its outline touches the box
    core = (cv2.erode(padded, np.ones((2 * rim + 1, 2 * rim + 1), np.uint8)) > 0)[rim : rim + mask.shape[0], rim : rim + mask.shape[1]]
    rows, cols = np.nonzero(core if core.sum() >= 0.25 * mask.sum() else mask)
    return rows + box[0].start, cols + box[1].start


def object_disparities(
    reference: np.ndarray,
    target: np.ndarray,
    labels: np.ndarray,
    height: HeightMap,
    sigma: float = 1.0,
    radius: int = 3,
    census: tuple[np.ndarray, np.ndarray] | None = None,
) -> dict[int, tuple[float, float, float]]:
    """Each object's D̄m, its NCC against the target there, and its census contrast to the ground.

    D̄m is the mode of the object's census disparities (1 px bins refined by the median of
    the modal bin), refined within ``radius`` px by the census cost of the object's
    pixels at full resolution (:func:`object_census_disparity`; 0 keeps the mode), those
    more than ``sigma`` px (0.5 m) inside its outline: the snapped outline takes in a
    strip of ground or wall, which pulls the least cost off the roof. The score is the
    NCC near D̄m of both images smoothed by ``sigma`` px (the caller makes it 0.5 m). The
    contrast is the mean census cost of the object's pixels (share of the descriptor's
    bits, :func:`object_census_costs`) at the median ground disparity under it less that
    at D̄m: a roof matches better at its own disparity than at the ground's, whatever the
    dates and sensors do to its grey levels (census sees only their local order); a
    patch of ground raised by a mismatch does not.

    ``census`` are both images' census descriptors when the caller has them
    (:func:`census_descriptors`).

    Returns
    -------
    dict
        Object id -> ``(D̄m, score, contrast)`` (NaN when nothing could be matched);
        objects without a valid disparity are left out.
    """
    from radcons.numerics.modal import modal_disparity

    disparity = height.full(labels.shape, "disparity")
    ref_smooth, tgt_smooth = smoothed(reference, sigma), smoothed(target, sigma)
    ground = height.full(labels.shape, "ground")
    if census is None:
        census = census_descriptors(reference), census_descriptors(target)
    ref_census, tgt_census = census
    found: dict[int, tuple[float, float, float]] = {}
    for index, box in enumerate(label_boxes(labels), start=1):
        if box is None:
            continue
        mask = labels[box] == index
        values = disparity[box][mask]
        values = values[np.isfinite(values)]
        if not values.size:
            continue
        rows, cols = np.nonzero(mask)
        rows, cols = rows + box[0].start, cols + box[1].start
        shift = modal_disparity(values)
        if radius > 0:
            core_rows, core_cols = _core_pixels(mask, box, int(round(sigma)))
            shift = object_census_disparity(ref_census, tgt_census, core_rows, core_cols, shift, radius)
        score = _refine_shift(ref_smooth, tgt_smooth, mask, box, float(round(shift)), 1)[1]
        under = ground[box][mask]
        under = under[np.isfinite(under)]
        contrast = float("nan")
        if under.size:
            candidates = np.array([round(float(np.median(under))), round(shift)])
            at_ground, at_shift = object_census_costs(ref_census, tgt_census, rows, cols, candidates)
            if np.isfinite(at_shift):  # inf: fewer than 10 of its pixels land in the target
                contrast = float(at_ground - at_shift)
        found[index] = (shift, score, contrast)
    return found


def refined_disparities(
    labels: np.ndarray, modal: dict[int, float], census: tuple[np.ndarray, np.ndarray], radius: int
) -> dict[int, float]:
    """Each final object's D̄m refined again on its own core, once its outline is final.

    The D̄m of :func:`object_disparities` is refined on the first regions, before the
    searches, joins, shadow cut and rim snap change the outlines, and a found object's on
    all its pixels. The census cost of an object's pixels within :data:`FINAL_RIM` px of
    its outline is minimal off the roof's disparity (their census windows reach the façade
    or the ground), so each object's D̄m is refined again (:func:`object_census_disparity`,
    within ``radius`` px of the current one) on its pixels more than :data:`FINAL_RIM` px
    inside its outline (all of them when less than a quarter would remain).

    Parameters
    ----------
    labels : ndarray of int
        The objects (0 = background).
    modal : dict
        Object id -> its D̄m (px); objects without one are left out.
    census : (ndarray, ndarray)
        :func:`census_descriptors` of both images.
    radius : int
        Integer disparities within this many px of the rounded D̄m are tried (0: none,
        ``modal`` is returned as it is).

    Returns
    -------
    dict
        Object id -> refined D̄m.
    """
    refined = dict(modal)
    if radius <= 0:
        return refined
    for index, box in enumerate(label_boxes(labels), start=1):
        if box is None or index not in modal:
            continue
        rows, cols = _core_pixels(labels[box] == index, box, FINAL_RIM)
        refined[index] = object_census_disparity(*census, rows, cols, modal[index], radius)
    return refined


def matched_back(
    labels: np.ndarray,
    modal: dict[int, float],
    census: tuple[np.ndarray, np.ndarray],
    disparities: np.ndarray,
    pixels: int,
) -> dict[int, bool]:
    """The object-level left-right check (:func:`matches_back`) of every object with a D̄m.

    Parameters
    ----------
    labels : ndarray of int
        Objects of the reference (0 = background).
    modal : dict
        Object id -> D̄m (px).
    census : (ndarray, ndarray)
        Census descriptors of both images.
    disparities : ndarray of int
        The disparities searched.
    pixels : int
        Pixels of an object compared, at most (evenly spread over it).

    Returns
    -------
    dict
        Object id -> whether its copy in the target matches back at its D̄m.
    """
    checked: dict[int, bool] = {}
    for index, box in enumerate(label_boxes(labels), start=1):
        if box is None or index not in modal:
            continue
        rows, cols = np.nonzero(labels[box] == index)
        rows, cols = spread_pixels(rows + box[0].start, cols + box[1].start, pixels)
        checked[index] = matches_back(*census, rows, cols, modal[index], disparities)
    return checked


def match_scores(
    reference: np.ndarray, target: np.ndarray, labels: np.ndarray, modal: dict[int, float], sigma: float = 1.0
) -> dict[int, float]:
    """NCC of each object against the target near its D̄m, both images smoothed by ``sigma`` px.

    The score :func:`object_disparities` gives each object (NaN when nothing could be
    matched), for objects found otherwise.

    Parameters
    ----------
    reference, target : ndarray
        The pair (NaN where invalid).
    labels : ndarray of int
        The objects (0 = background).
    modal : dict
        Object id -> D̄m (px) of the objects to score.
    sigma : float
        Smoothing of both images, px.

    Returns
    -------
    dict
        Object id -> score.
    """
    ref_smooth, tgt_smooth = smoothed(reference, sigma), smoothed(target, sigma)
    boxes = label_boxes(labels)
    scores = {}
    for index, shift in modal.items():
        box = boxes[index - 1] if index <= len(boxes) else None
        scores[index] = (
            float("nan") if box is None
            else _refine_shift(ref_smooth, tgt_smooth, labels[box] == index, box, float(round(shift)), 1)[1]
        )
    return scores


def transfer_to_target(labels: np.ndarray, modal: dict[int, float]) -> np.ndarray:
    """Move each reference object into the target by its own D̄m (``x_t = x - round(D̄m)``).

    Parameters
    ----------
    labels : ndarray of int
        Reference objects, 0 = background.
    modal : dict
        Object id -> D̄m (px); objects not in it are not moved.

    Returns
    -------
    ndarray of int32
        Target objects with the reference's ids; where moved objects overlap, the one
        with the larger D̄m (nearer the sensor) wins. Parts moved off the image are lost.
    """
    target_labels = np.zeros(labels.shape, np.int32)
    width = labels.shape[1]
    boxes = label_boxes(labels)
    for index in sorted(modal, key=modal.get):
        if index > len(boxes) or boxes[index - 1] is None:
            continue
        rows, cols = boxes[index - 1]
        shift = int(round(modal[index]))
        mask = labels[rows, cols] == index
        x0, x1 = cols.start - shift, cols.stop - shift
        lo, hi = max(x0, 0), min(x1, width)
        if hi <= lo:
            continue
        part = mask[:, lo - x0 : hi - x0]
        target_labels[rows, lo:hi][part] = index
    return target_labels
