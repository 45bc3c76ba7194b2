"""A gabled roof found by one plane: the other plane looked for across its ridge.

A gabled roof seen from above is two planes, one sunlit and one shaded, split by the
ridge. The height method's snapping often keeps only one of them as an object: the
other merges with the ground beside it where the two are alike in brightness (a sunlit
plane next to bright pavement), or with the shadow beside it, and is lost with that
region to the tree rule. The object is then about half the building.
:mod:`radcons.stages.objects.joins.halves` joins two planes that are both objects; it
cannot find a plane that is none.

A plane of a gabled roof says where its other plane is: its disparity rises towards the
ridge. So, for each object with a D̄m that fills at least :data:`MIN_PLANE_RECTANGULARITY`
of its smallest rotated rectangle (:func:`complete_gables`):

1. **Slope** (:func:`ridge_side`): its pixels are cut into thirds along each axis of its
   smallest rotated rectangle, and the census disparity of each outer third is measured
   as one window (:func:`radcons.stages.objects.disparity.object_census_disparity`). The
   side whose third stands highest above the opposite third, by at least
   :data:`MIN_RISE_PX`, is the ridge; a flat roof has none.
2. **Mirror** (:func:`mirrored`): the object's outline reflected across the side of its
   rectangle at the ridge is where the other plane should lie. Most of it
   (:data:`MIN_MIRROR_SHARE` of the object's area) must fall in the image outside the
   object, and most of that on one owner: free pixels, or one other object.
3. **Match**: the mirror's pixels, as one census window, match best within
   :data:`radcons.stages.objects.joins.halves.MAX_DISPARITY_STEP` px of the object's D̄m, stand
   above the ground by the height method's least object height, and match at least
   ``min_match_score`` better there than at the ground's disparity (rules 1-2 of
   :class:`radcons.stages.objects.census_check.CensusCheck`, the search held near D̄m in
   place of its uniqueness rule). An owning object must have a D̄m within that step,
   an area within :data:`radcons.stages.objects.joins.halves.AREA_RATIO` of the object's either
   way, and fill with it at least
   :data:`radcons.stages.objects.joins.halves.UNION_RECTANGULARITY` of their smallest rotated
   rectangle.
4. **Falling away, as the object rises**: the mirror's disparity falls from the ridge,
   by at least :data:`MIN_RISE_PX` between its third next to the ridge and its far
   third, and each of those thirds matches the object's third at the same distance
   from the ridge within :data:`SYMMETRY_PX` (the two planes of a gable meet at the
   ridge and end at eaves of one height). Flat ground, a flat neighbour at the roof's
   height, a building beside it sloping the other way and a roof of another pitch do
   not: without this test objects grow onto the ground beside them, and whole flat roofs
   onto their surroundings.

The object then takes the mirror's pixels (or the owning object whole), its D̄m is
measured again over both planes, and its match score again. Each object grows once, and
an object taken in grows no more. The shadow rule spares the grown roofs: a shaded plane
darkens the whole roof's median.

:data:`MIN_PLANE_RECTANGULARITY` is below the joined halves' rule
(:data:`radcons.stages.objects.joins.halves.UNION_RECTANGULARITY`): a plane cut from its
twin along a ragged line (the snapping follows the texture of the roof where the two
planes differ little in brightness) fills less of its rectangle, and steps 3 and 4 judge
it anyway. The rectangle test keeps ragged objects that are no roof (a grove, a strip
along a road) from growing onto the ground beside them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np
import scipy.ndimage

from radcons.stages.objects.census_check import CensusCheck
from radcons.stages.objects.disparity import (
    object_census_costs,
    object_census_disparity,
    spread_pixels,
)
from radcons.stages.objects.joins.halves import (
    AREA_RATIO,
    MAX_DISPARITY_STEP,
    UNION_RECTANGULARITY,
    rectangularity,
    rotated_rectangle,
)

__all__ = [
    "Ridge", "ridge_side", "mirrored", "complete_gables",
    "MIN_RISE_PX", "SYMMETRY_PX", "MIN_MIRROR_SHARE", "MIN_PLANE_RECTANGULARITY", "BAND_PIXELS",
]

#: Least rise of the disparity (px) between the outer thirds of a roof plane towards its ridge.
MIN_RISE_PX = 0.5
#: Largest difference (px) between a third of the mirror and the object's third at the same distance from the ridge.
SYMMETRY_PX = 1.0
#: Least area of an object over its smallest rotated rectangle's for it to be looked at as a roof's plane.
MIN_PLANE_RECTANGULARITY = 0.6
#: Least area of the mirror, outside the object and inside the image, over the object's.
MIN_MIRROR_SHARE = 0.5
#: Most pixels of a third compared at each disparity (evenly spread over it).
BAND_PIXELS = 4000
#: Fewest pixels in a third.
_MIN_BAND = 50


@dataclass(frozen=True)
class Ridge:
    """Where an object's disparity rises: towards the side of its rectangle at ``offset`` along ``direction``.

    Attributes
    ----------
    centre : ndarray
        (x, y) centre of the object's smallest rotated rectangle, px.
    direction : ndarray
        Unit (x, y) vector from the centre towards the ridge side.
    offset : float
        Distance from the centre to the ridge side, px: half the extent of the rectangle
        around the pixel centres, so the line through the centres of the object's last
        pixels on that side (see :func:`mirrored`).
    near, far : float
        Disparity of the object's third next to the ridge side, and of the opposite third, px.
    """

    centre: np.ndarray
    direction: np.ndarray
    offset: float
    near: float
    far: float

    @property
    def rise(self) -> float:
        """How far the disparity rises towards the ridge side: :attr:`near` less :attr:`far`, px."""
        return self.near - self.far

    def along(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Signed distance of pixels from the centre towards the ridge side, px."""
        return (cols - self.centre[0]) * self.direction[0] + (rows - self.centre[1]) * self.direction[1]


def _band_disparity(
    census: tuple[np.ndarray, np.ndarray], rows: np.ndarray, cols: np.ndarray, start: float, radius: int
) -> float:
    """One census window's D̄m over (at most :data:`BAND_PIXELS` of) the pixels."""
    return object_census_disparity(*census, *spread_pixels(rows, cols, BAND_PIXELS), start, radius)


def ridge_side(
    rows: np.ndarray,
    cols: np.ndarray,
    census: tuple[np.ndarray, np.ndarray],
    modal: float,
    radius: int,
    rectangle: tuple[tuple[float, float], tuple[float, float], float] | None = None,
) -> Ridge | None:
    """Step 1 of the module notes: the side of an object's rectangle its disparity rises to.

    Parameters
    ----------
    rows, cols : ndarray of int
        The object's pixels.
    census : (ndarray, ndarray)
        Census descriptors of both images (:func:`radcons.stages.objects.disparity.census_descriptors`).
    modal : float
        The object's D̄m, px: the thirds are searched within ``radius`` px of it.
    radius : int
        Half-width of that search, px.
    rectangle : cv2 rotated rectangle, optional
        The pixels' smallest rotated rectangle, in their coordinates, when the caller
        has it (:func:`radcons.stages.objects.joins.halves.rotated_rectangle`).

    Returns
    -------
    Ridge or None
        The side whose third stands highest above the opposite one; None when neither
        axis has two thirds of :data:`_MIN_BAND` pixels or more.
    """
    if rectangle is None:
        rectangle = cv2.minAreaRect(np.column_stack([cols, rows]).astype(np.float32))
    (cx, cy), (width, height), angle = rectangle
    theta = np.radians(angle)
    centre = np.array([cx, cy])
    best: Ridge | None = None
    for direction, extent in (
        (np.array([np.cos(theta), np.sin(theta)]), width),
        (np.array([-np.sin(theta), np.cos(theta)]), height),
    ):
        along = (cols - cx) * direction[0] + (rows - cy) * direction[1]
        near, far = along > extent / 6.0, along < -extent / 6.0
        if near.sum() < _MIN_BAND or far.sum() < _MIN_BAND:
            continue
        thirds = (
            _band_disparity(census, rows[near], cols[near], modal, radius),
            _band_disparity(census, rows[far], cols[far], modal, radius),
        )
        for sign, (high, low) in ((1.0, thirds), (-1.0, thirds[::-1])):
            if best is None or high - low > best.rise:
                best = Ridge(centre, sign * direction, extent / 2.0, high, low)
    return best


def mirrored(mask: np.ndarray, ridge: Ridge) -> np.ndarray:
    """Step 2 of the module notes: the object's outline reflected across its ridge side, filled.

    The line reflected across runs through the centres of the object's last pixels on
    the ridge side, so the mirror outside the object is a pixel narrower than the object:
    the object's own spill beyond its eave (the snapping's tolerance, of a pixel or so)
    does not carry over into the mirror. Reflected across the pixels' edge instead, the
    mirror would reach a pixel further, onto the ground beyond the other eave.

    Parameters
    ----------
    mask : ndarray of bool
        The object.
    ridge : Ridge
        Its ridge side (:func:`ridge_side`).

    Returns
    -------
    ndarray of bool
        The reflection, clipped to the image (it may overlap the object by the ridge's
        width of rounding).
    """
    filled = np.zeros(mask.shape, np.uint8)
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    for contour in contours:
        points = contour[:, 0, :].astype(np.float64)
        along = ridge.along(points[:, 1], points[:, 0])
        reflected = points + (2.0 * ridge.offset - 2.0 * along)[:, None] * ridge.direction[None, :]
        cv2.fillPoly(filled, [np.round(reflected).astype(np.int32)], 1)
    return filled > 0


def _matches_near(check: CensusCheck, rows: np.ndarray, cols: np.ndarray, modal: float) -> float | None:
    """Step 3 of the module notes: the mirror's disparity near ``modal`` when it stands and matches there."""
    rows, cols = spread_pixels(rows, cols, BAND_PIXELS)
    step = int(np.ceil(MAX_DISPARITY_STEP))
    candidates = np.arange(int(round(modal)) - step, int(round(modal)) + step + 1)
    ground = float(np.median(check.ground[rows, cols]))
    costs = object_census_costs(*check.census, rows, cols, np.append(candidates, int(round(ground))))
    if not np.isfinite(costs).all():
        return None
    best = int(np.argmin(costs[:-1]))
    disparity = float(candidates[best])
    if disparity - ground >= check.lowest and costs[-1] - costs[best] >= check.params.min_match_score:
        return disparity
    return None


def _falls_away(
    rows: np.ndarray, cols: np.ndarray, ridge: Ridge, census: tuple[np.ndarray, np.ndarray], start: float, radius: int
) -> bool:
    """Step 4 of the module notes: the mirror's disparity falls from the ridge as the object's rises to it.

    Its third next to the ridge and its far third match the object's third next to the
    ridge and its far third within :data:`SYMMETRY_PX`, and differ by :data:`MIN_RISE_PX`.
    """
    beyond = ridge.along(rows, cols) - ridge.offset
    span = float(beyond.max()) if beyond.size else 0.0
    near, far = beyond < span / 3.0, beyond > 2.0 * span / 3.0
    if near.sum() < _MIN_BAND or far.sum() < _MIN_BAND:
        return False
    high = _band_disparity(census, rows[near], cols[near], start, radius)
    low = _band_disparity(census, rows[far], cols[far], start, radius)
    return (
        high - low >= MIN_RISE_PX and abs(high - ridge.near) <= SYMMETRY_PX and abs(low - ridge.far) <= SYMMETRY_PX
    )


def _around(shape: tuple[int, int], *boxes: tuple[slice, slice], grow: bool = True) -> tuple[slice, slice]:
    """The window around ``boxes``, grown on every side by the first box's height and width (``grow``).

    A mirror lies within the first object's rectangle's extent beyond its ridge side,
    and that extent is at most the box's height plus its width.
    """
    margin = (boxes[0][0].stop - boxes[0][0].start) + (boxes[0][1].stop - boxes[0][1].start) if grow else 0
    starts = [max(min(box[k].start for box in boxes) - margin, 0) for k in (0, 1)]
    stops = [min(max(box[k].stop for box in boxes) + margin, shape[k]) for k in (0, 1)]
    return slice(starts[0], stops[0]), slice(starts[1], stops[1])


def complete_gables(
    labels: np.ndarray,
    modal: dict[int, float],
    check: CensusCheck,
    radius: int,
) -> tuple[np.ndarray, dict[int, float], list[int]]:
    """Grow each object that is one plane of a gabled roof by the other plane (module notes, steps 1-4).

    Parameters
    ----------
    labels : ndarray of int
        The reference's objects, 1..K (0 = background).
    modal : dict
        Object id -> D̄m (px); objects without one neither grow nor are taken in.
    check : CensusCheck
        The pair's census descriptors, ground and thresholds
        (:meth:`radcons.stages.objects.census_check.CensusCheck.of`).
    radius : int
        Half-width (px) of the searches around D̄m (``disparity_radius``).

    Returns
    -------
    labels : ndarray of int32
        The objects, an object taken in by another numbered as that one (its number left
        unused).
    modal : dict
        D̄m of each object, measured again over both planes of those that grew; the
        objects taken in are gone from it.
    grown : list of int
        The objects that grew, to score again.
    """
    out = labels.astype(np.int32, copy=True)
    modal = dict(modal)
    area = np.bincount(out.ravel())
    boxes = scipy.ndimage.find_objects(out)  # an object keeps its box until it grows or is taken in
    changed: set[int] = set()
    grown: list[int] = []
    for index, box in enumerate(boxes, start=1):
        if box is None or index not in modal or index in changed:
            continue
        window = _around(out.shape, box)  # the object and wherever its mirror can lie
        local = out[window]
        origin = np.array([window[1].start, window[0].start])  # (x, y) of the window's corner
        mask = local == index
        (centre, size, angle) = rotated_rectangle(mask)
        if area[index] < MIN_PLANE_RECTANGULARITY * size[0] * size[1]:
            continue
        rows, cols = np.nonzero(mask)
        rectangle = ((centre[0] + origin[0], centre[1] + origin[1]), size, angle)
        ridge = ridge_side(
            rows + window[0].start, cols + window[1].start, check.census, modal[index], radius, rectangle
        )
        if ridge is None or ridge.rise < MIN_RISE_PX:
            continue
        reflected = mirrored(mask, replace(ridge, centre=ridge.centre - origin)) & ~mask
        if reflected.sum() < MIN_MIRROR_SHARE * rows.size:
            continue
        owners = np.bincount(local[reflected])
        owner = int(owners.argmax())
        if owners[owner] < MIN_MIRROR_SHARE * reflected.sum():
            continue
        if owner:
            if owner not in modal or owner in changed or abs(modal[owner] - modal[index]) > MAX_DISPARITY_STEP:
                continue
            window = _around(out.shape, box, boxes[owner - 1], grow=False)  # both objects whole
            local = out[window]
            if min(area[owner], area[index]) < AREA_RATIO * max(area[owner], area[index]) or rectangularity(
                (local == index) | (local == owner)
            ) < UNION_RECTANGULARITY:
                continue
            plane = local == owner
        else:
            plane = reflected & (local == 0)
        plane_rows, plane_cols = np.nonzero(plane)
        plane_rows, plane_cols = plane_rows + window[0].start, plane_cols + window[1].start
        disparity = _matches_near(check, plane_rows, plane_cols, modal[index])
        if disparity is None or not _falls_away(plane_rows, plane_cols, ridge, check.census, disparity, radius):
            continue
        local[plane] = index  # a view: the objects change
        if owner:
            modal.pop(owner)
            changed.add(owner)
        changed.add(index)
        grown.append(index)
        union_rows, union_cols = np.nonzero(local == index)
        modal[index] = _band_disparity(
            check.census, union_rows + window[0].start, union_cols + window[1].start, modal[index], radius
        )
    return out, modal, grown
