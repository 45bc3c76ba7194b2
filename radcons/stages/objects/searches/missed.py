"""Buildings the census grid misses: image segments verified by their own census disparity.

The height method's regions (:func:`radcons.stages.objects.regions.segment_elevated`)
come from a census disparity on a grid reduced by the census factor, whose semi-global
smoothing pulls small buildings into the ground around them: the buildings no object
covers are mostly small ones. Here the reference is cut into segments by graph
segmentation (Felzenszwalb and Huttenlocher 2004, ``skimage.segmentation.felzenszwalb``,
on the reference reduced to about 0.75 m a pixel, and to at most 512 px a side), and
every segment of building size that no object covers yet is matched as one large census
window over the whole disparity range searched
(:func:`radcons.stages.objects.disparity.object_census_costs`, at full resolution, on at
most :data:`~radcons.stages.objects.census_check.MAX_PIXELS` of its pixels). It becomes
an object when all of these hold:

1. its least-cost disparity stands at least ``min_object_height`` times the height
   threshold above the ground under it (the height method's median-height rule);
2. its cost there is at least ``min_match_score`` lower than at the ground's disparity
   (the height method's census contrast);
3. the least cost is unique: every disparity more than 2 px from it costs at least
   ``missed_margin`` more (rows of parked cars and road markings repeat along the rows
   and match at several disparities);
4. it is a roof by its shape and texture: area at least ``missed_rectangularity`` of its
   smallest rotated rectangle, hull at least ``tree_hull_rectangularity`` of it, texture
   at most ``tree_texture`` (:func:`radcons.stages.objects.features.object_features`):
   crowns, groves, car rows and the façade strips beside a building are not. A small
   roof covered with furniture (vents, boxes, their shadows) reads as textured as a
   crown; so a segment whose area and hull both fill at least
   ``textured_roof_rectangularity`` of that rectangle and whose edges follow two
   perpendicular directions (``alignment`` at least :data:`TEXTURED_ROOF_ALIGNMENT`) is a
   roof however textured (:func:`is_roof_shaped`);
5. it is at least :data:`MIN_WIDTH_M` wide (the diameter of the largest disc inside it,
   :func:`segment_width`): a thinner segment is a façade strip, a kerb or the edge of a
   wall, and its texture, measured inside a rim it hardly has, says nothing (a long
   façade strip beside a tall building can pass rules 1-4 as a furnished roof). 2 m is
   the width below which no building stands.

Rules 1-3 are those of :class:`radcons.stages.objects.census_check.CensusCheck`. A kept
segment's D̄m is its least-cost disparity refined within ``disparity_radius`` px
(:func:`radcons.stages.objects.disparity.object_census_disparity`).

References
----------
Felzenszwalb, P. F., Huttenlocher, D. P. (2004). Efficient graph-based image
segmentation. International Journal of Computer Vision 59(2), 167-181.
"""

from __future__ import annotations

from collections.abc import Iterator

import cv2
import numpy as np
import scipy.ndimage
from skimage.segmentation import felzenszwalb

from radcons.numerics.coarse_disparity import downsample
from radcons.numerics.stretch import stretch8
from radcons.stages.objects.census_check import CensusCheck
from radcons.stages.objects.disparity import object_census_disparity
from radcons.stages.objects.features import ImageScales, object_features
from radcons.stages.objects.ground import HeightMap

__all__ = [
    "is_rectangle", "is_roof_shaped", "segment_width", "reference_segments", "missed_objects", "segment_cover",
    "segment_pixels", "SEGMENT_GSD_M", "SEGMENT_SIDE", "MAX_COVERED", "TEXTURED_ROOF_ALIGNMENT", "MIN_WIDTH_M",
]

#: Ground sample distance (m) the reference is segmented at (it is reduced to about this) ...
SEGMENT_GSD_M = 0.75
#: ... or further, so that its larger side is at most this many px (the segmentation's
#: time grows with the pixels).
SEGMENT_SIDE = 512
#: A segment already covered by objects on more than this share of its pixels is left out.
MAX_COVERED = 0.2
#: Edge alignment a textured rectangle needs to be a roof (rule 4 of the module notes).
TEXTURED_ROOF_ALIGNMENT = 0.5
#: Narrowest segment that can be a roof, m (rule 5 of the module notes).
MIN_WIDTH_M = 2.0


def is_rectangle(shape: dict[str, float], params: object) -> bool:
    """Area at least ``missed_rectangularity`` and hull at least ``tree_hull_rectangularity`` of the smallest rotated rectangle."""
    return (
        shape["rectangularity"] >= params.missed_rectangularity
        and shape["hull_rectangularity"] >= params.tree_hull_rectangularity
    )


def is_roof_shaped(shape: dict[str, float], params: object) -> bool:
    """Rule 4 of the module notes on the :func:`radcons.stages.objects.features.object_features` of a segment."""
    furnished = (
        params.textured_roof_rectangularity > 0
        and min(shape["rectangularity"], shape["hull_rectangularity"]) >= params.textured_roof_rectangularity
        and shape["alignment"] >= TEXTURED_ROOF_ALIGNMENT
    )
    return is_rectangle(shape, params) and (shape["texture"] <= params.tree_texture or furnished)


def segment_width(rows: np.ndarray, cols: np.ndarray) -> float:
    """Width of a segment, px: the diameter of the largest disc of pixels inside it.

    Twice the largest distance from one of its pixels to a pixel outside it, less one
    (the pixels are counted, not their edges).

    Parameters
    ----------
    rows, cols : ndarray of int
        The segment's pixels.

    Returns
    -------
    float
        1 for a line one pixel wide; n for a strip or a square n px wide (n - 1 for an
        even n).
    """
    mask = np.zeros((np.ptp(rows) + 3, np.ptp(cols) + 3), np.uint8)
    mask[rows - rows.min() + 1, cols - cols.min() + 1] = 1
    return 2.0 * float(cv2.distanceTransform(mask, cv2.DIST_L2, cv2.DIST_MASK_PRECISE).max()) - 1.0


def reference_segments(reference: np.ndarray, gsd: float, scale: float) -> np.ndarray:
    """Graph segmentation of the reference at about :data:`SEGMENT_GSD_M` a pixel, full-size labels.

    The reference is area-averaged by an integer factor that brings it to about
    :data:`SEGMENT_GSD_M` a pixel and its larger side to at most :data:`SEGMENT_SIDE` px.

    Parameters
    ----------
    reference : ndarray
        The reference (NaN where invalid).
    gsd : float
        Its ground sample distance, m.
    scale : float
        Felzenszwalb's scale (larger: larger segments); its ``sigma`` is 0.8 px and its
        smallest segment 50 px, both at the reduced resolution.

    Returns
    -------
    ndarray of int32
        Segment ids (0..K-1) at the reference's full resolution; invalid pixels -1.
    """
    factor = max(1, int(round(SEGMENT_GSD_M / gsd)), -(-max(reference.shape) // SEGMENT_SIDE))
    small = downsample(reference, factor) if factor > 1 else reference
    segments = felzenszwalb(stretch8(small), scale=scale, sigma=0.8, min_size=50).astype(np.int32)
    if factor > 1:
        full = np.zeros(reference.shape, np.int32)
        grown = np.repeat(np.repeat(segments, factor, axis=0), factor, axis=1)
        rows, cols = min(grown.shape[0], full.shape[0]), min(grown.shape[1], full.shape[1])
        full[:rows, :cols] = grown[:rows, :cols]
        # the rows and columns beyond the last whole block take the nearest segment
        full[rows:, :] = full[rows - 1 : rows, :]
        full[:, cols:] = full[:, cols - 1 : cols]
        segments = full
    segments[~np.isfinite(reference)] = -1
    return segments


def missed_objects(
    reference: np.ndarray,
    labels: np.ndarray,
    height: HeightMap,
    census: tuple[np.ndarray, np.ndarray],
    params: object,
    gsd: float,
    threshold: float,
    scales: ImageScales | None = None,
    segments: np.ndarray | None = None,
) -> tuple[np.ndarray, dict[int, float]]:
    """Objects of the reference that the height map missed (see the module notes).

    Parameters
    ----------
    reference : ndarray
        The reference (NaN where invalid).
    labels : ndarray of int
        The objects found so far (0 = background): segments they cover are left out.
    height : HeightMap
        The pair's census disparity, ground and height maps.
    census : (ndarray, ndarray)
        Census descriptors of both images at full resolution
        (:func:`radcons.stages.objects.disparity.census_descriptors`).
    params : ObjectsParams
    gsd : float
        Ground sample distance of the reference, m.
    threshold : float
        The height threshold, in the height map's unit.
    scales : ImageScales, optional
        The reference's gradient and medians at 0.5 m, when the caller has them
        (:class:`radcons.stages.objects.features.ImageScales`).
    segments : ndarray of int, optional
        The reference's :func:`reference_segments` at ``params.missed_scale``, when the
        caller has them.

    Returns
    -------
    labels : ndarray of int32
        The new objects, 1..K (0 elsewhere; none overlaps ``labels``).
    modal : dict
        New object id -> D̄m (px).
    """
    if segments is None:
        segments = reference_segments(reference, gsd, params.missed_scale)
    area, covered = segment_cover(segments, labels > 0)
    smallest, largest = params.min_area_m2 / gsd**2, params.max_area_m2 / gsd**2
    candidates = np.nonzero((area >= smallest) & (area <= largest) & (covered <= MAX_COVERED * area))[0]
    check = CensusCheck.of(height, census, params, threshold, reference.shape)
    verified = np.zeros(reference.shape, np.int32)
    best: dict[int, tuple[float, np.ndarray, np.ndarray]] = {}
    for _, rows, cols in segment_pixels(segments, candidates):
        shift = check.disparity(rows, cols)
        if shift is not None:
            best[len(best) + 1] = (shift, rows, cols)
            verified[rows, cols] = len(best)
    shapes = object_features(reference, verified, height, max(1.0, 0.5 / gsd), scales) if best else {}
    found = np.zeros(reference.shape, np.int32)
    modal: dict[int, float] = {}
    for index, (shift, rows, cols) in best.items():
        if not is_roof_shaped(shapes[index], params) or segment_width(rows, cols) < MIN_WIDTH_M / gsd:
            continue
        found[rows, cols] = len(modal) + 1
        modal[len(modal) + 1] = object_census_disparity(*census, rows, cols, shift, params.disparity_radius)
    return found, modal


def segment_cover(segments: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixels of each segment (ids 0..K-1, -1 invalid), and how many of them ``mask`` holds."""
    shifted = segments.ravel() + 1  # invalid pixels (-1) count in bin 0, left out
    count = int(shifted.max()) + 1
    area = np.bincount(shifted, minlength=count)[1:]
    return area, np.bincount(shifted[mask.ravel()], minlength=count)[1:]


def segment_pixels(segments: np.ndarray, chosen: np.ndarray) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
    """``(segment, rows, cols)`` of each chosen segment, full-image pixel coordinates."""
    boxes = scipy.ndimage.find_objects(segments + 1)
    for segment in chosen:
        box = boxes[segment]
        rows, cols = np.nonzero(segments[box] == segment)
        yield int(segment), rows + box[0].start, cols + box[1].start
