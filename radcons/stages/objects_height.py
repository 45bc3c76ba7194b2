"""Objects that stand above the ground: regions of the height map, snapped to image edges.

The ``"height"`` method of the objects stage (:class:`radcons.stages.objects_params.ObjectsParams`
``method = "height"``). From the height above ground of :mod:`radcons.stages.height`:

1. **Regions** (:func:`segment_elevated`): on the census grid, the pixels higher than the
   height threshold whose 3 x 3 neighbourhood spans less than ``split_jump`` of height are
   the cores of objects (a height jump between adjacent buildings of different heights
   leaves a gap between their cores, so they become two objects); 4-connected cores are
   the seeds. Cells without a height (the census window's margin at the image's top and
   bottom, nodata) are left out of the neighbourhood, not taken as ground
   (:func:`_valid_spread`): a building cut by the frame keeps its seed.
2. **Snapping**: the seeds, eroded by one census pixel, and the sure ground (lower than
   half the threshold, eroded by two census pixels) mark a watershed of the reference
   (OpenCV's marker-based watershed on the stretched, lightly smoothed reference), which
   places each boundary on the strongest image edge of the band the coarse disparity
   leaves uncertain. A region belongs when at least ``min_elevated_share`` of it is
   elevated; its holes are filled, but for a hole mostly on the ground (not elevated): a
   courtyard is no roof, and filled it made the building's features those of roof and
   ground together (demo pairs at 1024 px, seeds 0-4, labels withheld: mean IoU 0.767
   -> 0.770, recall at IoU 0.5 0.810 -> 0.812); regions outside
   ``[min_area_m2, max_area_m2]`` are dropped.
3. **Trees** (:func:`radcons.stages.object_features.object_features`,
   :func:`radcons.stages.object_rules.is_tree`): trees stand as high as low buildings. An
   object is left out as a tree when it is textured (median gradient of the reference
   inside it more than ``tree_texture`` times the image's median gradient: a crown is a
   pattern of leaves and gaps, a roof a uniform surface) and less rectangular than
   ``roof_rectangularity`` (a small roof with its furniture and the edges at its rim is
   as textured as a crown, but a crown is never a rectangle), or ragged and round (area
   less than ``tree_rectangularity`` of its smallest enclosing rotated rectangle, and its
   convex hull less than ``tree_hull_rectangularity`` of that rectangle: crowns and
   groves are round, a notched or U-shaped roof, or one the snapping cut short, keeps a
   rectangular hull), or when its edges follow no two perpendicular directions
   (``alignment`` below ``tree_alignment``: a roof's outline, its furniture and the
   shadow it casts are straight and square, the edges of crowns and their gaps turn every
   way). A ragged object that is smooth and square
   (:func:`radcons.stages.object_rules.is_spilled_roof`, ``spilled_roof_texture``) is a
   roof that spilled onto its shadow, row houses set back from each other, or a hipped
   roof around a courtyard split at its corners, not a crown. Where heights are in metres,
   a textured object standing ``tall_roof_height_m`` or more above the ground that is
   nearly a rectangle with square edges (:func:`radcons.stages.object_rules.is_tall_roof`)
   is an apartment block's roof with its tanks and heaters, higher than a city's trees.
   The planarity of the height (RMS residual of a plane) and the solidity (area over
   hull) separate less (``benchmarks/bench_objects.py``, section ``trees``).
4. **Artefacts** (:func:`object_disparities`): an object whose median height is lower
   than ``min_object_height`` times the height threshold, or that does not match the
   target better at its D̄m than at the ground's disparity under it (mean census cost
   of its pixels at full resolution, as a share of the descriptor's bits; contrast
   below ``min_match_score``), is ground raised by a mismatch and is left out. A
   census contrast keeps roofs whose grey levels another date or sensor changed.
5. **Transfer** (:func:`transfer_to_target`): each object's D̄m is the mode of its
   census disparities (1 px bins, :func:`radcons.stages.association.modal_disparity`),
   refined within ``radius`` px by the mean census cost of all its pixels at full
   resolution (:func:`radcons.stages.object_disparity.object_census_disparity`; demo
   pairs, 512 px: D̄m within 1 px of the truth for 0.81 of the objects against 0.76 for
   the mode; a masked NCC refinement moved it away, walls and ground pulling its peak).
   The target's object is the reference's moved left by D̄m (objects with a larger
   D̄m, nearer the sensor, drawn last).
6. **Missed buildings** (:mod:`radcons.stages.objects_missed`, ``find_missed``): small
   buildings the census grid smoothed into the ground, found as segments of the reference
   matched over the whole disparity range, before the transfer.
7. **Shadows** (:func:`radcons.stages.object_rules.is_shadow`, ``shadow_texture``), after
   every search: a dark object without texture is the shadow of the building beside it,
   raised by the matcher's smoothing, and is left out (counted with the artefacts); a
   dark object that stands low (:func:`radcons.stages.object_rules.is_dark_and_low`,
   ``dark_brightness``, ``dark_height``) is crowns in the shade or a shadow raised part
   of the way, and is left out (counted with the trees). An object whose outline no image
   edge follows (:func:`radcons.stages.object_rules.is_edgeless`, ``outline_edge``) is a
   patch of a lawn, a field or a pyramid's face that the matcher raised, and is left out
   (counted with the artefacts).
8. **Vegetation by colour** (:func:`radcons.stages.object_rules.green_objects`,
   ``tree_greenness``): on an RGB pair, an object whose median green leaf index exceeds
   ``tree_greenness`` is a tree (crowns that are neither textured nor ragged at the
   image's scale; the US3D tiles).
9. **Left-right check** (:func:`matched_back`, ``cross_check_objects``), before the
   transfer: an object is moved into the target (and so associated) only when its copy
   there, matched back into the reference over the searched range, finds its least census
   cost within 2 px of D̄m; ground that the target hides beside a building, changed roofs
   and repeated patterns do not.
10. **Roof halves** (:mod:`radcons.stages.roof_halves`, ``join_roof_halves``), after the
   artefacts and before the missed buildings: two objects that are the planes of one
   gabled roof, split at its ridge by the snapping, become one.
11. **Gable planes** (:mod:`radcons.stages.roof_mirror`, ``complete_gables``), after
   every search and before the wings: an object that is one plane of a gabled roof (its
   disparity rises towards one side) grows by the other plane, looked for across that
   side, when that plane stands, matches near the object's D̄m and falls away from the
   ridge. The shadow rule (7) spares the grown roofs.
"""


from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
import scipy.ndimage

from radcons.results import ObjectLabels
from radcons.stages.height import HeightMap
from radcons.stages.object_disparity import (
    census_descriptors, matches_back, object_census_costs, object_census_disparity, spread_pixels,
)
from radcons.stages.object_features import smoothed
from radcons.stages.subpixel import parabola_peak

__all__ = [
    "HeightObjects", "segment_elevated", "object_disparities", "refined_disparities", "match_scores", "matched_back",
    "transfer_to_target", "keep_objects", "relabel", "stretch8", "check_height_params",
]


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
        without texture (:func:`radcons.stages.object_rules.is_shadow`).
    unmatched : tuple of int
        Objects whose copy in the target does not match back at their D̄m
        (``cross_check_objects``): kept, but without a D̄m, a target copy or a fit.
    left_out : ndarray of uint8 or None
        Reference frame: the pixels of the elevated regions a rule left out, each the code
        of that rule in :data:`radcons.stages.object_rules.LEFT_OUT_RULES` (0 elsewhere, and where an object was found
        after all); what an analyst tuning the rules' thresholds looks at.
    by_outline : tuple of int
        Roofs clipped at full scale in one image, whose D̄m comes from their outline
        (:mod:`radcons.stages.clipped_roofs`), not from census.
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


def stretch8(image: np.ndarray) -> np.ndarray:
    """The image's 0.5-99.5 percentile range mapped to 0..255 (uint8), NaN as 0."""
    valid = np.isfinite(image)
    low, high = np.percentile(image[valid], (0.5, 99.5)) if valid.any() else (0.0, 1.0)
    scale = 255.0 / (high - low) if high > low else 1.0
    return np.clip((np.where(valid, image, low) - low) * scale, 0, 255).astype(np.uint8)


def _new_ids(keep: np.ndarray) -> np.ndarray:
    """Old id -> new id: the ids with ``keep[id]`` true numbered 1..K in their order, the others (and 0) 0."""
    keep = keep.copy()
    keep[0] = False
    return (np.cumsum(keep) * keep).astype(np.int32)


def relabel(labels: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """Map the kept ids of ``labels`` to 1..K in increasing order, the rest to 0."""
    return _new_ids(keep)[labels]


def keep_objects(
    labels: np.ndarray, keep: np.ndarray, modal: dict[int, float], scores: dict[int, float]
) -> tuple[np.ndarray, dict[int, float], dict[int, float]]:
    """The objects with ``keep[id]`` true, numbered 1..K in their order, and their D̄m and scores so numbered."""
    new_ids = _new_ids(keep)

    def renumbered(values: dict[int, float]) -> dict[int, float]:
        return {int(new_ids[i]): value for i, value in values.items() if new_ids[i]}

    return new_ids[labels], renumbered(modal), renumbered(scores)


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
    for index, box in enumerate(_boxes(labels), start=1):
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


def _boxes(labels: np.ndarray) -> list:
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

        NaN where invalid: :func:`radcons.stages.object_features.smoothed` takes those as its mean.
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
    strip of ground or wall, which pulls the least cost off the roof (demo pairs, labels
    withheld, D̄m within 1 px at 1024 px: seeds 0-4, where 0.5, 1 and 1.5 m were tried,
    0.836 -> 0.855; seeds 5-9 0.845 -> 0.855; at 512 px 0.830 -> 0.840 and 0.829 ->
    0.828). The score is the NCC near D̄m of both images smoothed by ``sigma`` px (the caller makes it
    0.5 m). The contrast is the mean census cost of the object's pixels (share of the
    descriptor's bits, :func:`object_census_costs`) at the median ground disparity under
    it less that at D̄m: a roof matches better at its own disparity than at the ground's,
    whatever the dates and sensors do to its grey levels (census sees only their local
    order); a patch of ground raised by a mismatch does not. Census replaced the NCC
    difference measured before (demo pairs, 512 px, contrast >= 0.03 against NCC
    difference >= 0.05: mean IoU 0.572 against 0.562, objects that are buildings 0.785
    against 0.769, D̄m within 1 px 0.841 against 0.821).

    ``census`` are both images' census descriptors when the caller has them
    (:func:`census_descriptors`).

    Returns
    -------
    dict
        Object id -> ``(D̄m, score, contrast)`` (NaN when nothing could be matched);
        objects without a valid disparity are left out.
    """
    from radcons.stages.association import modal_disparity

    disparity = height.full(labels.shape, "disparity")
    ref_smooth, tgt_smooth = smoothed(reference, sigma), smoothed(target, sigma)
    ground = height.full(labels.shape, "ground")
    if census is None:
        census = census_descriptors(reference), census_descriptors(target)
    ref_census, tgt_census = census
    found: dict[int, tuple[float, float, float]] = {}
    for index, box in enumerate(_boxes(labels), start=1):
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


#: Pixels of a final object within this many px of its outline do not refine its D̄m: the
#: 5 x 5 census window of a pixel there reaches past the outline, onto the façade the
#: oblique view shows or the ground beside it.
FINAL_RIM = 3


def refined_disparities(
    labels: np.ndarray, modal: dict[int, float], census: tuple[np.ndarray, np.ndarray], radius: int
) -> dict[int, float]:
    """Each final object's D̄m refined again on its own core, once its outline is final.

    The D̄m of :func:`object_disparities` is refined on the first regions, before the
    searches, joins, shadow cut and rim snap change the outlines, and a found object's on
    all its pixels. The census cost of an object's pixels within :data:`FINAL_RIM` px of
    its outline is minimal off the roof's disparity (a whole roof box against its own
    core, by NCC on a demo roof: 1.0 px off against 0.25 px), so each object's D̄m is
    refined again (:func:`object_census_disparity`, within ``radius`` px of the current
    one) on its pixels more than :data:`FINAL_RIM` px inside its outline (all of them when
    less than a quarter would remain). Demo pairs, labels withheld, D̄m within 1 px,
    seeds 0-4 (rims of 1-5 px tried): 512 px 0.915 -> 0.925, 1024 px 0.899 -> 0.909;
    seeds 5-9 (held out): 0.892 -> 0.897 and 0.878 -> 0.874.

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
    for index, box in enumerate(_boxes(labels), start=1):
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
    for index, box in enumerate(_boxes(labels), start=1):
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
    boxes = _boxes(labels)
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
    boxes = _boxes(labels)
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


_METHODS = ("mbi", "height")
_CROSS_CHECKS = ("accurate", "fast", "none")


def check_height_params(params: object) -> None:
    """Refuse out-of-range height-method fields of :class:`radcons.stages.objects_params.ObjectsParams`."""
    from radcons.errors import ParamsError
    from radcons.validate import check_int_range

    if params.method not in _METHODS:
        raise ParamsError(f"[objects] method must be one of {_METHODS}, got {params.method!r}")
    if params.census_cross_check not in _CROSS_CHECKS:
        raise ParamsError(f"[objects] census_cross_check must be one of {_CROSS_CHECKS}, got {params.census_cross_check!r}")
    check_int_range(params.census_side, 32, 4096, "[objects] census_side")
    check_int_range(params.disparity_radius, 0, 16, "[objects] disparity_radius")
    for name, low, high in (
        ("search_share", 0.01, 1.0),
        ("min_valid_share", 0.0, 1.0),
        ("ground_percentile", 0.0, 50.0),
        ("min_elevated_share", 0.0, 1.0),
        ("tree_rectangularity", 0.0, 1.0),
        ("roof_rectangularity", 0.0, 2.0),
        ("tree_hull_rectangularity", 0.0, 1.0),
        ("min_match_score", -2.0, 2.0),
        ("missed_rectangularity", 0.0, 1.0),
        ("missed_margin", 0.0, 1.0),
        ("tree_greenness", -1.0, 1.0),
        ("shadow_texture", 0.0, 2.0),
        ("tree_alignment", 0.0, 1.0),
        ("spilled_roof_texture", 0.0, 2.0),
        ("tall_roof_height_m", 0.0, 1000.0),
        ("dark_brightness", 0.0, 2.0),
        ("dark_height", 0.0, 100.0),
        ("crown_alignment", 0.0, 1.0),
        ("crown_rectangularity", 0.0, 2.0),
        ("crown_height", 0.0, 100.0),
        ("outline_edge", 0.0, 100.0),
        ("shadow_trim", 0.0, 1.0),
        ("outline_band", 0.0, 20.0),
        ("census_cell_m", 0.05, 50.0),
        ("textured_roof_rectangularity", 0.0, 2.0),
        ("flat_edges", 0.0, 100.0),
    ):
        value = getattr(params, name)
        if not low <= value <= high:
            raise ParamsError(f"[objects] {name} must be in {low}..{high}, got {value}")
    for name in (
        "ground_window_m", "min_height_m", "min_height_px", "split_jump_m", "split_jump_px",
        "min_area_m2", "assumed_gsd_m", "tree_texture", "min_object_height", "missed_scale", "removed_scale",
    ):
        if not getattr(params, name) > 0:
            raise ParamsError(f"[objects] {name} must be positive, got {getattr(params, name)}")
    if not params.max_area_m2 > params.min_area_m2:
        raise ParamsError(
            f"[objects] max_area_m2 ({params.max_area_m2}) must exceed min_area_m2 ({params.min_area_m2})"
        )
