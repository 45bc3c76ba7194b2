"""Roofs inside the regions the height method's rules removed: verified fine segments, joined.

An elevated region of :func:`radcons.stages.objects.regions.segment_elevated` often spills
from a roof onto the shadow or the crowns beside it (the watershed follows the height
map's coarse grid there). The spilled region is ragged, so the tree rule removes it whole,
roof included: many of the buildings without any object lie in such a region, e.g. an
L-shaped roof in a region that took in its own shadow.

Here the reference is cut into fine segments by graph segmentation
(:func:`radcons.stages.objects.searches.missed.reference_segments`, scale ``removed_scale``), and
every segment lying mostly (:data:`MIN_INSIDE`) inside a removed region and not yet under
an object is matched as one census window
(:class:`radcons.stages.objects.census_check.CensusCheck`: it must stand above the ground,
match better than at the ground's disparity and match uniquely). Neighbouring verified
segments whose disparities differ by at most :data:`JOIN_PX` px are joined, the union is
verified again, and it is given the final objects' outline treatment
(:func:`radcons.stages.objects.outlines.candidate_outlines`: shadow cut, rim snapped,
strips and spurs narrower than 1.5 m opened off by a disc of radius
:data:`radcons.stages.objects.outlines.SPUR_M`), because a union follows the segmentation's
lines onto the façade strip and the kerb beside its roof. It becomes an object when it
is shaped like a roof: by the missed search's rules 4 and 5
(:mod:`radcons.stages.objects.searches.missed`: area and hull at least ``missed_rectangularity``
and ``tree_hull_rectangularity`` of the smallest rotated rectangle and texture at most
``tree_texture``, or a full rectangle with square edges however textured, a roof covered
with furniture; at least :data:`radcons.stages.objects.searches.missed.MIN_WIDTH_M` wide), or
rectilinear and not textured (:func:`rectilinearity` at least :data:`MIN_RECTILINEARITY`,
area at least :data:`MIN_RECTANGULARITY_RECTILINEAR` of that rectangle, texture at most
``tree_texture``: L and U shapes). Shadows stay out because they match nowhere
uniquely; crowns because of their shape. A roof covered with furniture (vents, boxes)
reads as textured as a crown, and only the missed search's furnished-roof rule takes it.
The outline treatment is this search's alone: in the missed search it lost roofs.

References
----------
Felzenszwalb, P. F., Huttenlocher, D. P. (2004). Efficient graph-based image
segmentation. International Journal of Computer Vision 59(2), 167-181.
"""

from __future__ import annotations

import cv2
import numpy as np
import scipy.sparse
import scipy.sparse.csgraph

from radcons.stages.objects.census_check import CensusCheck
from radcons.stages.objects.disparity import object_census_disparity
from radcons.stages.objects.features import ImageScales, object_features
from radcons.stages.objects.ground import HeightMap
from radcons.stages.objects.outlines import candidate_outlines
from radcons.stages.objects.searches.missed import (
    MAX_COVERED,
    MIN_WIDTH_M,
    is_roof_shaped,
    reference_segments,
    segment_cover,
    segment_pixels,
    segment_width,
)

__all__ = ["rectilinearity", "roofs_in_removed", "MIN_INSIDE", "JOIN_PX", "MIN_RECTILINEARITY"]

#: Share of a segment's pixels that must lie in removed regions.
MIN_INSIDE = 0.7
#: Neighbouring segments whose disparities differ by at most this (px) are joined.
JOIN_PX = 1.0
#: Rectilinearity that makes a union roof-shaped without being a rectangle ...
MIN_RECTILINEARITY = 0.9
#: ... when its area is at least this share of its smallest rotated rectangle.
MIN_RECTANGULARITY_RECTILINEAR = 0.6
#: Smallest segment considered, m².
MIN_SEGMENT_M2 = 10.0
#: Douglas-Peucker tolerance of the outline (px) and shortest straight edge (m) of :func:`rectilinearity`.
_OUTLINE_TOLERANCE_PX = 1.5
_LONG_EDGE_M = 3.0
#: Largest angle (degrees) between a straight edge and the outline's two main directions.
_ANGLE_TOLERANCE = 12.0


def rectilinearity(mask: np.ndarray, gsd: float) -> float:
    """Share of a region's outline on long straight edges along two perpendicular directions.

    The outer contour is simplified (Douglas-Peucker, 1.5 px); edges of at least 3 m
    count when they lie within 12 degrees of the outline's main direction or its
    perpendicular (the length-weighted circular mean of the edge angles modulo 90
    degrees). 1 for a rectangle, an L or a U; low for a crown or a blob.

    Parameters
    ----------
    mask : ndarray of bool
        The region.
    gsd : float
        Ground sample distance, m.

    Returns
    -------
    float
        0..1; 0 for an empty mask.
    """
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return 0.0
    outline = cv2.approxPolyDP(max(contours, key=len), _OUTLINE_TOLERANCE_PX, True)[:, 0, :].astype(np.float64)
    edges = np.roll(outline, -1, axis=0) - outline
    length = np.hypot(edges[:, 0], edges[:, 1])
    if not length.sum() > 0:
        return 0.0
    angle = np.degrees(np.arctan2(edges[:, 1], edges[:, 0])) % 90.0
    quadrupled = np.radians(4.0 * angle)
    main = np.degrees(np.arctan2((length * np.sin(quadrupled)).sum(), (length * np.cos(quadrupled)).sum())) / 4.0
    off = np.abs((angle - main + 45.0) % 90.0 - 45.0)
    straight = (length >= _LONG_EDGE_M / gsd) & (off < _ANGLE_TOLERANCE)
    return float(length[straight].sum() / length.sum())


def _neighbours(segments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of segment ids that touch (4-connected), each pair once or more."""
    first = np.concatenate([segments[:, :-1].ravel(), segments[:-1, :].ravel()])
    second = np.concatenate([segments[:, 1:].ravel(), segments[1:, :].ravel()])
    keep = (first != second) & (first >= 0) & (second >= 0)
    return first[keep], second[keep]


def _roof_shaped(feature: dict[str, float], mask: np.ndarray, gsd: float, params: object) -> bool:
    """The shape and texture rule of the module notes."""
    if is_roof_shaped(feature, params):
        return segment_width(*np.nonzero(mask)) >= MIN_WIDTH_M / gsd
    return (
        feature["texture"] <= params.tree_texture
        and feature["rectangularity"] >= MIN_RECTANGULARITY_RECTILINEAR
        and rectilinearity(mask, gsd) >= MIN_RECTILINEARITY
    )


def _outlined(
    shifts: dict[int, tuple[float, np.ndarray, np.ndarray]], outlined: np.ndarray, smallest: float
) -> dict[int, tuple[float, np.ndarray, np.ndarray]]:
    """The candidates' pixels after :func:`candidate_outlines`, those still ``smallest`` px or more."""
    sizes = np.bincount(outlined.ravel(), minlength=max(shifts) + 1)
    chosen = [index - 1 for index in shifts if sizes[index] >= smallest]  # segment_pixels counts from 0
    return {
        segment + 1: (shifts[segment + 1][0], rows, cols)
        for segment, rows, cols in segment_pixels(outlined - 1, chosen)
    }


def roofs_in_removed(
    reference: np.ndarray,
    labels: np.ndarray,
    removed: np.ndarray,
    height: HeightMap,
    census: tuple[np.ndarray, np.ndarray],
    params: object,
    gsd: float,
    threshold: float,
    scales: ImageScales | None = None,
    segments: np.ndarray | None = None,
) -> tuple[np.ndarray, dict[int, float]]:
    """Roofs inside the removed regions (see the module notes).

    Parameters
    ----------
    reference : ndarray
        The reference (NaN where invalid).
    labels : ndarray of int
        The objects found so far (0 = background): segments they cover are left out.
    removed : ndarray of bool
        The pixels of the elevated regions the rules removed.
    height : HeightMap
        The pair's census disparity, ground and height maps.
    census : (ndarray, ndarray)
        Census descriptors of both images at full resolution.
    params : ObjectsParams
    gsd : float
        Ground sample distance of the reference, m.
    threshold : float
        The height threshold, in the height map's unit.
    scales : ImageScales, optional
        The reference's gradient and medians at 0.5 m, when the caller has them
        (:class:`radcons.stages.objects.features.ImageScales`).
    segments : ndarray of int, optional
        The reference's :func:`radcons.stages.objects.searches.missed.reference_segments` at
        ``params.removed_scale``, when the caller has them.

    Returns
    -------
    labels : ndarray of int32
        The new objects, 1..K (0 elsewhere; none overlaps ``labels``).
    modal : dict
        New object id -> D̄m (px).
    """
    found = np.zeros(reference.shape, np.int32)
    if not removed.any():
        return found, {}
    if segments is None:
        segments = reference_segments(reference, gsd, params.removed_scale)
    area, covered = segment_cover(segments, labels > 0)
    in_removed = segment_cover(segments, removed)[1]
    candidates = np.nonzero(
        (area >= MIN_SEGMENT_M2 / gsd**2) & (covered <= MAX_COVERED * area) & (in_removed >= MIN_INSIDE * area)
    )[0]
    check = CensusCheck.of(height, census, params, threshold, reference.shape)
    count = area.size
    shift = np.full(count, np.nan)
    for segment, rows, cols in segment_pixels(segments, candidates):
        value = check.disparity(rows, cols)
        if value is not None:
            shift[segment] = value
    first, second = _neighbours(segments)
    join = np.isfinite(shift[first]) & np.isfinite(shift[second]) & (np.abs(shift[first] - shift[second]) <= JOIN_PX)
    graph = scipy.sparse.coo_matrix((np.ones(int(join.sum())), (first[join], second[join])), shape=(count, count))
    _, component = scipy.sparse.csgraph.connected_components(graph, directed=False)
    verified = np.isfinite(shift)
    unions = np.where(segments >= 0, np.where(verified, component, -1)[np.maximum(segments, 0)], -1)
    smallest, largest = params.min_area_m2 / gsd**2, params.max_area_m2 / gsd**2
    joined = np.zeros(reference.shape, np.int32)
    shifts: dict[int, tuple[float, np.ndarray, np.ndarray]] = {}
    for _, rows, cols in segment_pixels(unions, np.unique(component[verified])):
        if not smallest <= rows.size <= largest:
            continue
        value = check.disparity(rows, cols)
        if value is not None:
            shifts[len(shifts) + 1] = (value, rows, cols)
            joined[rows, cols] = len(shifts)
    sigma = max(1.0, 0.5 / gsd)
    if shifts:
        scales = scales if scales is not None and scales.sigma == sigma else ImageScales.of(reference, sigma)
        joined = candidate_outlines(joined, labels > 0, reference, scales.smooth, params, gsd)
        shifts = _outlined(shifts, joined, smallest)
    features = object_features(reference, joined, height, sigma, scales) if shifts else {}
    modal: dict[int, float] = {}
    for index, (value, rows, cols) in shifts.items():
        if _roof_shaped(features[index], joined == index, gsd, params):
            found[rows, cols] = len(modal) + 1
            modal[len(modal) + 1] = object_census_disparity(*census, rows, cols, value, params.disparity_radius)
    return found, modal
