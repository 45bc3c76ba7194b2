"""Roofs clipped at full scale in one image: found by their outline, matched by its edges.

A roof in glare (a metal roof facing the sun: the paper's Object 1, over-exposed in one
date) is clipped at the sensor's full scale. Inside it no grey-level order is left, so
census matching cannot place it: neither the census disparity the height method's regions
come from (:mod:`radcons.numerics.coarse_disparity`), nor the census window of a segment
(:class:`radcons.stages.objects.census_check.CensusCheck`), whose cost is about 0.5 at
every disparity there: such a roof is no object, at best its furniture is. Its outline
is still sharp. So

1. each plateau of clipped pixels of building size, in either image, is a candidate
   (:func:`clipped_plateaus`) when it is clipped whole: at least :data:`WHOLE_SHARE` of
   the ring around it is dark (:func:`dark_surround`). The clipped core of a bright roof
   is ringed by the rest of that roof, and census sees that roof anyway; lit roof faces
   and white strips are mostly ringed by bright pixels too, and the disparity of their
   outline is often wrong;
2. its disparity is the one at which the other image's edges follow its outline best
   (:func:`outline_scores`: each side of the outline scored on its own, so that only
   edges running the whole side count), refined by a parabola;
3. that disparity must stand at least ``min_object_height`` times the height threshold
   above the ground under it (the height method's median-height rule): white ground, sand
   or a glinting car park clip too, and their outline follows the other image's edges at
   the ground's disparity.

The object is the plateau in the reference's frame (moved by its disparity when the
plateau is the target's). It replaces the objects lying mostly on it (the roof's
furniture, the only parts of it census could match), and its D̄m is kept as the outline
gives it: the census refinement and the object-level left-right check of the other
objects cannot see into it.

There is no uniqueness rule like the census searches' (no other disparity scoring
nearly as well): a straight side of a roof lies on some other straight edge at other
disparities too, and such a rule refuses most glare roofs whose best disparity is right.
"""

from __future__ import annotations

import cv2
import numpy as np
import scipy.ndimage

from radcons.numerics.subpixel import parabola_peak
from radcons.stages.objects.ground import HeightMap
from radcons.stages.objects.searches.missed import segment_cover
from radcons.stages.objects.transfer import transfer_to_target

__all__ = [
    "clipped_plateaus", "dark_surround", "outline_scores", "image_gradient", "clipped_roofs", "mostly_on",
    "MAX_HOLE", "WHOLE_SHARE",
]

#: Least share of a plateau's surroundings that is dark (:func:`dark_surround`) for it to be
#: a roof clipped whole.
WHOLE_SHARE = 0.75
#: Largest hole of a plateau (furniture darker than the glare) filled, as a share of its area.
MAX_HOLE = 0.05


def clipped_plateaus(image: np.ndarray, smallest: float, largest: float) -> np.ndarray:
    """Plateaus of clipped pixels of an image, of building size.

    A pixel is clipped when it and its eight neighbours all hold the image's largest
    value (a single bright pixel is not clipping: a plateau is). Each plateau is grown by
    one pixel (its own rim, still at full scale) and its small holes (furniture darker
    than the glare, less than :data:`MAX_HOLE` of it) are filled. A plateau that touches
    the image's edge or an invalid pixel is left out: its outline there is the frame's
    or the nodata's (a fill value at full scale), not a roof's.

    Parameters
    ----------
    image : ndarray
        2-D image, NaN where invalid.
    smallest, largest : float
        Area range of a plateau kept, px.

    Returns
    -------
    ndarray of int32
        Plateau ids 1..K (0 elsewhere).
    """
    valid = np.isfinite(image)
    if not valid.any():
        return np.zeros(image.shape, np.int32)
    top = np.nanmax(image)
    at_top = (np.where(valid, image, -np.inf) >= top).astype(np.uint8)
    core = cv2.erode(at_top, np.ones((3, 3), np.uint8), borderType=cv2.BORDER_CONSTANT, borderValue=0)
    if not core.any():
        return np.zeros(image.shape, np.int32)
    grown = (cv2.dilate(core, np.ones((3, 3), np.uint8)) & at_top).astype(bool)
    box = scipy.ndimage.find_objects(grown.astype(np.uint8))[0]  # a hole lies inside it
    grown[box] = _small_holes_filled(grown[box])
    labels, count = scipy.ndimage.label(grown)
    area = np.bincount(labels.ravel(), minlength=count + 1)
    edge = np.ones(image.shape, bool)
    edge[1:-1, 1:-1] = False
    edge |= cv2.dilate((~valid).astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    cut = np.bincount(labels[edge], minlength=count + 1) > 0
    keep = (area >= smallest) & (area <= largest) & ~cut
    keep[0] = False
    ids = np.cumsum(keep) * keep
    return ids[labels].astype(np.int32)


def outline_scores(
    mask: np.ndarray, gradient: tuple[np.ndarray, np.ndarray], disparities: np.ndarray, direction: int
) -> np.ndarray:
    """How well the other image's edges follow a plateau's outline, at each disparity.

    At each pixel of the outline (where the mask, smoothed by a 3 x 3 Sobel, has a
    gradient), the other image's gradient at the pixel moved by ``direction * d`` is
    projected on the outline's normal. The outline's pixels are grouped into four sides
    by the direction of their normal (to the nearest quarter turn); the score is the sum
    over the sides of the absolute mean projection along each. A roof's side lies on
    one edge of the other image at the roof's disparity, brighter on one side of it all
    along, whichever that is there; edges that cross a side at other disparities point
    every way and cancel in its mean.

    Parameters
    ----------
    mask : ndarray of bool
        The plateau, in its own image's frame (not empty).
    gradient : (ndarray, ndarray)
        The other image's :func:`image_gradient`.
    disparities : ndarray of int
        Candidate disparities (``reference(x, y) <-> target(x - d, y)``).
    direction : int
        +1 when the plateau is the target's (it lies at ``x + d`` in the reference),
        -1 when it is the reference's.

    Returns
    -------
    ndarray of float
        One score per disparity; 0 where less than half of the outline lands inside
        the other image.
    """
    box = scipy.ndimage.find_objects(mask.astype(np.int8))[0]
    top, left = max(box[0].start - 1, 0), max(box[1].start - 1, 0)
    window = mask[top : box[0].stop + 1, left : box[1].stop + 1].astype(np.float32)
    normal_x = cv2.Sobel(window, cv2.CV_32F, 1, 0, ksize=3)
    normal_y = cv2.Sobel(window, cv2.CV_32F, 0, 1, ksize=3)
    length = np.hypot(normal_x, normal_y)
    rows, cols = np.nonzero(length > 0)
    normal_x = normal_x[rows, cols] / length[rows, cols]
    normal_y = normal_y[rows, cols] / length[rows, cols]
    side = np.rint(np.arctan2(normal_y, normal_x) / (np.pi / 2)).astype(np.int64) % 4
    rows, cols = rows + top, cols + left
    grad_x, grad_y = gradient
    width = grad_x.shape[1]
    moved = cols[None, :] + direction * np.asarray(disparities, np.int64)[:, None]
    inside = (moved >= 0) & (moved < width)
    at = np.clip(moved, 0, width - 1)
    across = (grad_x[rows[None, :], at] * normal_x + grad_y[rows[None, :], at] * normal_y) * inside
    score = np.zeros(len(disparities))
    for which in range(4):
        on = side == which
        if on.any():
            score += np.abs(across[:, on].sum(axis=1)) / on.sum()
    return np.where(inside.sum(axis=1) >= 0.5 * rows.size, score, 0.0)


def image_gradient(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """3 x 3 Sobel gradient (x, y) of an image, 0 at and beside invalid pixels."""
    valid = np.isfinite(image)
    filled = np.where(valid, image, float(np.median(image[valid])) if valid.any() else 0.0).astype(np.float32)
    near_invalid = cv2.dilate((~valid).astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    grad_x = cv2.Sobel(filled, cv2.CV_32F, 1, 0, ksize=3)
    grad_y = cv2.Sobel(filled, cv2.CV_32F, 0, 1, ksize=3)
    grad_x[near_invalid] = 0.0
    grad_y[near_invalid] = 0.0
    return grad_x, grad_y


def clipped_roofs(
    reference: np.ndarray,
    target: np.ndarray,
    height: HeightMap,
    lowest: float,
    area: tuple[float, float],
) -> tuple[np.ndarray, dict[int, float]]:
    """The roofs clipped in either image (see the module notes), in the reference's frame.

    Parameters
    ----------
    reference, target : ndarray
        The rectified pair, NaN where invalid.
    height : HeightMap
        The pair's census disparity and ground.
    lowest : float
        Least disparity above the ground (px) of an object (rule 3 of the module notes).
    area : (float, float)
        Area range of an object, px.

    Returns
    -------
    labels : ndarray of int32
        The clipped roofs, 1..K (0 elsewhere; where two overlap, the first keeps the pixels).
    modal : dict
        Roof id -> D̄m (px).
    """
    found = np.zeros(reference.shape, np.int32)
    modal: dict[int, float] = {}
    sides = [(image, other, direction, clipped_plateaus(image, *area))
             for image, other, direction in ((target, reference, 1), (reference, target, -1))]
    if not any(plateaus.any() for *_, plateaus in sides):
        return found, modal
    disparities = height.searched_disparities()
    ground = height.full(reference.shape, "ground")
    for image, other, direction, plateaus in sides:
        if not plateaus.any():
            continue
        gradient = image_gradient(other)
        median, top = float(np.nanmedian(image)), float(np.nanmax(image))
        for index in range(1, int(plateaus.max()) + 1):
            mask = plateaus == index
            if dark_surround(image, mask, median + 0.5 * (top - median)) < WHOLE_SHARE:
                continue
            scores = outline_scores(mask, gradient, disparities, direction)
            best = int(np.argmax(scores))
            if scores[best] <= 0:
                continue
            inner = 0 < best < scores.size - 1
            shift = best + (parabola_peak(*scores[best - 1 : best + 2]) if inner else 0.0) + float(disparities[0])
            # the target's plateau lies at x + d in the reference: transfer_to_target moves by -D̄m
            placed = transfer_to_target(mask.astype(np.int32), {1: -shift}) > 0 if direction > 0 else mask
            footprint = placed & (found == 0)
            if footprint.sum() < area[0] or shift - float(np.median(ground[footprint])) < lowest:
                continue
            modal[len(modal) + 1] = shift
            found[footprint] = len(modal)
    return found, modal


def dark_surround(image: np.ndarray, mask: np.ndarray, level: float) -> float:
    """Share of the ring 2-3 px around a plateau that is dark: below ``level``.

    A roof clipped whole stands against the ground, its walls and its shadow; the clipped
    core of a bright roof is ringed by the rest of that roof, nearly as bright.
    :func:`clipped_roofs` takes halfway from the image's median to its top as ``level``.

    Parameters
    ----------
    image : ndarray
        The image the plateau is clipped in, NaN where invalid.
    mask : ndarray of bool
        The plateau (not empty).
    level : float
        Grey level below which a pixel is dark.

    Returns
    -------
    float
        0..1; 0 when no valid pixel rings the plateau.
    """
    box = scipy.ndimage.find_objects(mask.astype(np.int8))[0]
    rows = slice(max(box[0].start - 3, 0), box[0].stop + 3)
    cols = slice(max(box[1].start - 3, 0), box[1].stop + 3)
    window = mask[rows, cols].astype(np.uint8)
    grown = cv2.dilate(window, np.ones((7, 7), np.uint8)) > 0
    near = cv2.dilate(window, np.ones((3, 3), np.uint8)) > 0
    ring = image[rows, cols][grown & ~near]
    ring = ring[np.isfinite(ring)]
    return float(np.mean(ring < level)) if ring.size else 0.0


def mostly_on(labels: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Per object id (index 0 the background, False), whether more than half its pixels lie in ``mask``."""
    area, inside = segment_cover(labels - 1, mask)  # object k is segment k - 1; the background drops out
    return np.concatenate([[False], inside > 0.5 * area])


def _small_holes_filled(mask: np.ndarray) -> np.ndarray:
    """``mask`` with its holes of less than :data:`MAX_HOLE` of their plateau's area filled."""
    filled = scipy.ndimage.binary_fill_holes(mask)
    holes, count = scipy.ndimage.label(filled & ~mask)
    if count == 0:
        return mask
    outlines, _ = scipy.ndimage.label(filled)
    plateau_area = np.bincount(outlines[mask], minlength=int(outlines.max()) + 1)
    hole_area = np.bincount(holes.ravel())
    owner = np.zeros(count + 1, np.int64)
    owner[holes[holes > 0]] = outlines[holes > 0]
    small = hole_area < MAX_HOLE * plateau_area[owner]
    small[0] = False
    return mask | small[holes]
