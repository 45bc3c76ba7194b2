"""Objects that stand above the ground: regions of the height map, snapped to image edges.

:func:`segment_elevated` turns the height above ground
(:class:`radcons.stages.objects.ground.HeightMap`) into objects of the reference:

1. **Seeds**: on the census grid, the cells higher than the height threshold whose 3 x 3
   neighbourhood spans less than ``split_jump`` of height are the cores of objects (a
   height jump between adjacent buildings of different heights leaves a gap between
   their cores, so they become two objects); 4-connected cores are the seeds. Cells
   without a height (the census window's margin at the image's top and bottom, nodata)
   are left out of the neighbourhood, not taken as ground (:func:`_valid_spread`): a
   building cut by the frame keeps its seed. With ``flat_edges``, the seeds are also cut
   where the reference's gradient is strong (the edges between adjacent roofs), and the
   regions they give are merged again where the line between them is neither an image
   edge nor a height jump (:func:`_merge_weak_boundaries`).
2. **Snapping**: the seeds, eroded by one census cell, and the sure ground (more than two
   census cells from any elevated pixel, or invalid) mark a watershed of the reference
   (OpenCV's marker-based watershed on the stretched, lightly smoothed reference), which
   places each boundary on the strongest image edge of the band the coarse disparity
   leaves uncertain.
3. **Regions kept**: a region is an object when at least ``min_elevated_share`` of it is
   elevated and its area lies in ``[min_area_m2, max_area_m2]``. Its holes are filled,
   but for a hole mostly on the ground (not elevated): a courtyard is no roof, and filled
   it would make the building's features those of roof and ground together
   (:func:`_fill_holes`).

:class:`HeightObjects` is the height method's result, :func:`keep_objects` the one way
objects are dropped and renumbered along the method.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
import scipy.ndimage

from radcons.numerics.labels import new_ids, relabel
from radcons.numerics.stretch import stretch8
from radcons.results import ObjectLabels
from radcons.stages.objects.features import smoothed
from radcons.stages.objects.ground import HeightMap

__all__ = ["HeightObjects", "keep_objects", "label_boxes", "segment_elevated"]


@dataclass(frozen=True)
class HeightObjects(ObjectLabels):
    """Objects of both images found from height, with what was measured on the way.

    Attributes
    ----------
    height : HeightMap or None
        The disparity, ground and height maps (None when matching failed).
    method : str
        ``"height"``, or ``"mbi"`` when the method fell back to the image-only one.
    note : str
        Why there are no objects, or why the method fell back (empty otherwise).
    modal_disparity : dict
        Object id -> D̄m (px) used to move it into the target.
    match_score : dict
        Object id -> NCC of the object against the target at D̄m.
    trees : int
        Elevated regions left out as trees or groves (texture, shape, edges, colour,
        or dark and low).
    mismatched : int
        Elevated regions left out as disparity artefacts (shadows that changed,
        mismatches): lower than ``min_object_height`` times the threshold, or matching
        the target no better at their D̄m than at the ground's disparity, or dark and
        without texture (:func:`radcons.stages.objects.rules.is_shadow`).
    unmatched : tuple of int
        Objects whose copy in the target does not match back at their D̄m
        (``cross_check_objects``): kept, but without a D̄m, a target copy or a fit.
    left_out : ndarray of uint8 or None
        Reference frame: the pixels of the elevated regions a rule left out, each the code
        of that rule in :data:`radcons.stages.objects.rules.LEFT_OUT_RULES` (0 elsewhere, and where an object was found
        after all); what an analyst tuning the rules' thresholds looks at.
    by_outline : tuple of int
        Roofs clipped at full scale in one image, whose D̄m comes from their outline
        (:mod:`radcons.stages.objects.searches.clipped`), not from census.
    """

    height: HeightMap | None = None
    method: str = "height"
    note: str = ""
    modal_disparity: dict[int, float] = field(default_factory=dict)
    match_score: dict[int, float] = field(default_factory=dict)
    trees: int = 0
    mismatched: int = 0
    unmatched: tuple[int, ...] = ()
    left_out: np.ndarray | None = None
    by_outline: tuple[int, ...] = ()


def keep_objects(
    labels: np.ndarray, keep: np.ndarray, modal: dict[int, float], scores: dict[int, float]
) -> tuple[np.ndarray, dict[int, float], dict[int, float]]:
    """The objects with ``keep[id]`` true, numbered 1..K in their order, and their D̄m and scores so numbered."""
    numbers = new_ids(keep)

    def renumbered(values: dict[int, float]) -> dict[int, float]:
        return {int(numbers[i]): value for i, value in values.items() if numbers[i]}

    return numbers[labels], renumbered(modal), renumbered(scores)


def _fill_holes(labels: np.ndarray, ground: np.ndarray) -> np.ndarray:
    """Fill each object's holes (background not connected to the outside of its box), but not those mostly on ``ground``.

    Parameters
    ----------
    labels : ndarray of int32
        0 = background, 1..K the objects.
    ground : ndarray of bool
        Valid pixels that are not elevated: a hole at least half on them is a courtyard
        and stays open.

    Returns
    -------
    ndarray of int32
        The labels with the other holes given to the object around them.
    """
    out = labels.copy()
    for index, box in enumerate(label_boxes(labels), start=1):
        if box is None:
            continue
        mask = np.pad(labels[box] == index, 1).astype(np.uint8)
        outside = mask.copy()
        cv2.floodFill(outside, None, (0, 0), 2)
        holes = (outside[1:-1, 1:-1] == 0) & (labels[box] == 0)
        count, parts = cv2.connectedComponents(holes.astype(np.uint8), connectivity=4)
        if count > 1:
            on_ground = np.bincount(parts.ravel(), weights=ground[box].ravel(), minlength=count)
            size = np.bincount(parts.ravel(), minlength=count)
            open_ground = on_ground >= 0.5 * size
            open_ground[0] = True
            holes &= ~open_ground[parts]
        out[box][holes] = index
    return out


def label_boxes(labels: np.ndarray) -> list:
    """The box (a pair of slices) of each object 1..K of ``labels``, None for an id without pixels."""
    return scipy.ndimage.find_objects(labels)


def segment_elevated(
    reference: np.ndarray,
    height: HeightMap,
    threshold: float,
    jump: float,
    area_px: tuple[float, float],
    min_elevated_share: float,
    flat_edges: float = 0.0,
) -> np.ndarray:
    """Objects of the reference from its height map: seeds, watershed on edges, area range.

    Parameters
    ----------
    reference : ndarray
        The reference image (full resolution, NaN where invalid).
    height : HeightMap
        Its height above ground (census grid).
    threshold : float
        Height above which a pixel is elevated (the map's unit).
    jump : float
        Height spread over a 3 x 3 census neighbourhood that separates two objects.
    area_px : (float, float)
        Smallest and largest object area, full-resolution pixels.
    min_elevated_share : float
        Share of an object's pixels that must be elevated.
    flat_edges : float
        Seeds are cut where the reference's gradient exceeds this many times its median
        (0: the seeds are kept whole).

    Returns
    -------
    ndarray of int32
        0 = background, 1..K the objects.
    """
    shape = reference.shape
    coarse = np.nan_to_num(height.height, nan=0.0)
    elevated = coarse > threshold
    spread = _valid_spread(height.height)
    core = (elevated & (spread < jump)).astype(np.uint8)
    _, seeds = cv2.connectedComponents(core, connectivity=4, ltype=cv2.CV_32S)
    factor = height.factor
    seeds_full = cv2.resize(seeds, (shape[1], shape[0]), interpolation=cv2.INTER_NEAREST)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * factor + 1, 2 * factor + 1))
    inside = cv2.erode((seeds_full > 0).astype(np.uint8), kernel) > 0
    if flat_edges > 0:
        edges = _Edges.of(reference)
        inside &= edges.flat(flat_edges)
        count, seeds_full, stats, _ = cv2.connectedComponentsWithStats(
            inside.astype(np.uint8), connectivity=4, ltype=cv2.CV_32S
        )
        small = stats[:, cv2.CC_STAT_AREA] < 0.25 * area_px[0]
        small[0] = True
        inside &= ~small[seeds_full]
    seeds_full[~inside] = 0
    full = height.full(shape)
    valid = np.isfinite(reference)
    elevated_full = np.nan_to_num(full, nan=-np.inf) > threshold
    band = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (4 * factor + 1, 4 * factor + 1))
    ground = (cv2.dilate(elevated_full.astype(np.uint8), band) == 0) | ~valid
    markers = np.where(seeds_full > 0, seeds_full + 1, 0).astype(np.int32)
    markers[(ground > 0) & (markers == 0)] = 1
    image = cv2.GaussianBlur(stretch8(reference), (0, 0), 1.0)
    cv2.watershed(cv2.merge([image, image, image]), markers)
    if flat_edges > 0:
        markers = _merge_weak_boundaries(markers, edges, full, flat_edges, jump)
    labels = np.where(markers > 1, markers - 1, 0).astype(np.int32)
    labels[~valid] = 0
    labels = _fill_holes(labels, valid & ~elevated_full)
    count = int(labels.max()) + 1
    area = np.bincount(labels.ravel(), minlength=count).astype(np.float64)
    high = np.bincount(labels.ravel(), weights=elevated_full.ravel(), minlength=count)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = high / area
    keep = (area >= area_px[0]) & (area <= area_px[1]) & (share >= min_elevated_share)
    return relabel(labels, keep)


def _valid_spread(height: np.ndarray) -> np.ndarray:
    """Highest minus lowest valid height over each cell's 3 x 3 neighbourhood (NaN: no height).

    A cell without height is left out of its neighbours' spread: the rows the census
    window leaves empty at the image's top and bottom frame, or the nodata around a
    rotated scene, would otherwise count as ground beside every cell next to them, and a
    building cut by the frame would lose its seed. A cell with no valid neighbour gets 0
    (it is not elevated).
    """
    kernel = np.ones((3, 3), np.uint8)
    valid = np.isfinite(height)
    highest = cv2.dilate(np.where(valid, height, -np.inf).astype(np.float32), kernel, borderType=cv2.BORDER_REPLICATE)
    lowest = cv2.erode(np.where(valid, height, np.inf).astype(np.float32), kernel, borderType=cv2.BORDER_REPLICATE)
    return np.where(np.isfinite(highest), highest - lowest, 0.0).astype(np.float32)


@dataclass(frozen=True)
class _Edges:
    """The reference's gradient magnitude at sigma 1.5 px and its median over the valid image."""

    gradient: np.ndarray
    scale: float

    @classmethod
    def of(cls, reference: np.ndarray) -> "_Edges":
        """The edges of ``reference``.

        NaN where invalid: :func:`radcons.stages.objects.features.smoothed` takes those as its mean.
        """
        smooth = smoothed(reference, 1.5)
        gradient = np.hypot(cv2.Sobel(smooth, cv2.CV_32F, 1, 0), cv2.Sobel(smooth, cv2.CV_32F, 0, 1))
        return cls(gradient, float(np.median(gradient[np.isfinite(reference)])))

    def flat(self, edges: float) -> np.ndarray:
        """Pixels whose gradient is below ``edges`` times the median, opened by a 3 x 3 square."""
        flat = (self.gradient < edges * self.scale).astype(np.uint8)
        return cv2.morphologyEx(flat, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)) > 0


def _merge_weak_boundaries(
    markers: np.ndarray, image_edges: _Edges, height: np.ndarray, edges: float, jump: float
) -> np.ndarray:
    """Merge watershed regions (ids > 1) whose shared boundary is no image edge and no height jump.

    Seeds cut at the reference's edges may split one roof at an edge inside it (roof
    furniture, a courtyard's rim, a gable's ridge). Two regions are merged when the
    median gradient along the watershed line between them is below ``edges`` times the
    image's median gradient and their median heights differ by less than ``jump``.
    """
    gradient, scale = image_edges.gradient, image_edges.scale
    count = int(markers.max()) + 1
    first, second, where = [], [], []
    for axis in (0, 1):
        a = np.moveaxis(markers, axis, 0)
        g = np.moveaxis(gradient, axis, 0)
        for left, mid, right, line in ((a[:-2], a[1:-1], a[2:], g[1:-1]), (a[:-1], a[:-1], a[1:], g[:-1])):
            pair = (left > 1) & (right > 1) & (left != right) & ((mid == -1) | (mid == left))
            first.append(left[pair])
            second.append(right[pair])
            where.append(line[pair])
    lo = np.minimum(np.concatenate(first), np.concatenate(second)).astype(np.int64)
    hi = np.maximum(np.concatenate(first), np.concatenate(second)).astype(np.int64)
    values = np.concatenate(where)
    if lo.size == 0:
        return markers
    heights = np.full(count, np.nan)
    flat_ids = markers.ravel()
    finite = np.isfinite(height.ravel()) & (flat_ids > 1)
    order = np.argsort(flat_ids[finite], kind="stable")
    ids, starts = np.unique(flat_ids[finite][order], return_index=True)
    for ident, chunk in zip(ids, np.split(height.ravel()[finite][order], starts[1:])):
        heights[ident] = np.median(chunk)
    keys, inverse = np.unique(lo * count + hi, return_inverse=True)
    parent = np.arange(count)

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for key, index in zip(keys, range(keys.size)):
        a, b = divmod(int(key), count)
        boundary = values[inverse == index]
        if boundary.size < 3 or np.median(boundary) >= edges * scale:
            continue
        if not abs(heights[a] - heights[b]) < jump:
            continue
        parent[root(a)] = root(b)
    roots = np.array([root(i) for i in range(count)])
    merged = np.where(markers > 1, roots[np.maximum(markers, 0)], markers)
    line = markers == -1
    if line.any():  # a line between two merged regions joins them
        neighbours = cv2.dilate(np.where(markers > 1, merged, 0).astype(np.float32), np.ones((3, 3), np.uint8))
        lowest = -cv2.dilate(-np.where(merged > 1, merged, 1 << 20).astype(np.float32), np.ones((3, 3), np.uint8))
        same = line & (neighbours == lowest) & (neighbours > 1)
        merged[same] = neighbours[same].astype(np.int32)
    return merged
