"""The objects stage: the buildings of both images, by the method its parameters name.

``ObjectsParams.method`` (:mod:`radcons.stages.objects_params`) chooses:

- ``"height"`` (:func:`height_objects`, the ``radcons`` preset's): objects stand above the
  ground; census matching of the pair as given, the ground under it, elevated regions
  snapped to the reference's edges, the rules that leave trees, shadows and mismatches
  out, the searches for the buildings the coarse grid missed, and each object moved into
  the target by its own D̄m (the module notes of :mod:`radcons.stages.objects_height`);
- ``"mbi"`` (:func:`radcons.stages.objects_mbi.extract_objects`, the ``paper`` preset's,
  and the height method's fallback when the disparity fails): the morphological
  building index of each image alone.

Label rasters supplied with a pair win over both (:mod:`radcons.pipeline`).
"""

from __future__ import annotations

from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from radcons.census import CensusParams
from radcons.errors import InputError, ParamsError, StageError
from radcons.stages.clipped_roofs import clipped_roofs, mostly_on
from radcons.stages.height import (
    HeightMap,
    census_factor,
    coarse_disparity,
    downsample,
    fill_occlusions,
    ground_disparity,
    height_above_ground,
)
from radcons.stages.object_disparity import census_descriptors
from radcons.stages.object_features import ImageScales, object_features
from radcons.stages.object_outlines import snap_rims, trim_shadows
from radcons.stages.object_rules import (
    green_objects, is_dark_and_low, is_edgeless, is_low_crown, is_shadow, is_tree,
)
from radcons.stages.objects_height import (
    HeightObjects,
    keep_objects,
    match_scores,
    matched_back,
    object_disparities,
    refined_disparities,
    segment_elevated,
    transfer_to_target,
)
from radcons.stages.objects_mbi import building_index, extract_objects
from radcons.stages.objects_missed import MAX_PIXELS, CensusCheck, missed_objects, reference_segments
from radcons.stages.objects_params import ObjectsParams
from radcons.stages.roof_halves import join_roof_halves
from radcons.stages.roof_mirror import complete_gables
from radcons.stages.roof_parts import roofs_in_removed
from radcons.stages.roof_wings import join_wings
from radcons.validate import single_band_image

__all__ = ["ObjectsParams", "PairMatching", "building_index", "extract_objects", "height_objects", "match_pair"]


#: Smallest side of a pair the height method matches (the range-finding run halves it
#: twice more than the census grid, and census needs its 5 x 5 window).
_MIN_SIDE = 32
#: Scale (m) of the gradient the tree rule's texture is measured with, and of the smoothing
#: of both images before an object is matched into the target.
_TEXTURE_SCALE_M = 0.5


@dataclass(frozen=True)
class PairMatching:
    """What the height method computes of a pair before any of its rules.

    The census disparity (:func:`radcons.stages.height.coarse_disparity`) and the images'
    own measures (:class:`_ImageWork`) depend on the images, the census fields of
    :class:`ObjectsParams` (``census_cell_m``, ``census_side``, ``search_share``,
    ``census_cross_check``), the ground sample distance and a known disparity range,
    not on the thresholds of the rules and searches. A caller that runs the method again
    on one pair with other thresholds (the pipeline, when an analyst tunes the objects
    stage) keeps this and hands it to :func:`height_objects`, which then skips the
    matching: about 0.9 of 1.8 s at 1024 x 1024 px (``benchmarks/bench_objects.py
    --only timing``).

    Attributes
    ----------
    key : tuple
        The images' shape and the values above it was computed with.
    disparity : ndarray or None
        The census disparity at the grid's resolution, full-image pixels, NaN where
        invalid (None when matching failed).
    searched : tuple of float
        The disparity range of the final run, px.
    valid_share : float
        Share of the overlap the cross-checked disparity holds.
    factor : int
        The census grid's reduction.
    failure : str
        Why the pair could not be matched ("" when it was).
    work : _ImageWork or None
        The census descriptors, gradient scales and graph segments of the images.
    """

    key: tuple
    disparity: np.ndarray | None
    searched: tuple[float, float]
    valid_share: float
    factor: int
    failure: str = ""
    work: "_ImageWork | None" = None

    @staticmethod
    def key_of(
        shape: tuple[int, ...],
        params: ObjectsParams,
        gsd_m: float | None = None,
        disparity_range: tuple[float, float] | None = None,
    ) -> tuple:
        """The :attr:`key` of the matching of a pair of ``shape`` with these arguments of :func:`match_pair`."""
        gsd = _resolved_gsd(gsd_m, params)
        census = (params.census_cell_m, params.census_side, params.search_share, params.census_cross_check)
        return (tuple(shape), census, gsd, None if disparity_range is None else tuple(map(float, disparity_range)))


def match_pair(
    reference: np.ndarray,
    target: np.ndarray,
    params: ObjectsParams = ObjectsParams(method="height"),
    *,
    gsd_m: float | None = None,
    disparity_range: tuple[float, float] | None = None,
) -> PairMatching:
    """The census matching of a pair for :func:`height_objects`, to keep while its rules are tuned.

    Parameters
    ----------
    reference, target : ndarray
        The working (rectified) pair, NaN where invalid.
    params : ObjectsParams
        Its census fields are used (:class:`PairMatching`).
    gsd_m : float, optional
        Ground sample distance, m (``params.assumed_gsd_m`` without it).
    disparity_range : tuple of float, optional
        Known disparity range (px); else it is searched.

    Returns
    -------
    PairMatching
        With ``failure`` set when the pair is too small or census matching fails.

    Raises
    ------
    InputError
        Images not 2-D, of different shapes or without a valid pixel.
    """
    reference, target = _validated_pair(reference, target)
    return _match_pair(reference, target, params, _resolved_gsd(gsd_m, params), disparity_range)


def _resolved_gsd(gsd_m: float | None, params: ObjectsParams) -> float:
    """The ground sample distance (m) the method works at: ``gsd_m`` when positive, else ``params.assumed_gsd_m``."""
    return gsd_m if gsd_m and gsd_m > 0 else params.assumed_gsd_m


def _validated_pair(reference: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both images as 2-D float arrays of one shape, each with a valid pixel; else InputError."""
    reference = single_band_image(reference, "reference", 1, "is empty")
    target = single_band_image(target, "target", 1, "is empty")
    if reference.shape != target.shape:
        raise InputError(f"height objects need a rectified pair of one shape, got {reference.shape} and {target.shape}")
    return reference, target


def _match_pair(
    reference: np.ndarray,
    target: np.ndarray,
    params: ObjectsParams,
    gsd: float,
    disparity_range: tuple[float, float] | None,
) -> PairMatching:
    """:func:`match_pair` on validated images, at the ground sample distance ``gsd`` (m)."""
    key = PairMatching.key_of(reference.shape, params, gsd, disparity_range)
    if min(reference.shape) < _MIN_SIDE:
        reason = f"the pair is too small for a census disparity ({_MIN_SIDE} px a side)"
        return PairMatching(key, None, (0.0, 0.0), 0.0, 0, reason)
    work = _ImageWork.start(reference, target, gsd, max(1.0, _TEXTURE_SCALE_M / gsd), params)
    factor = census_factor(reference.shape, params.census_cell_m / gsd, params.census_side)
    census = CensusParams(cross_check=params.census_cross_check)
    try:
        disparity, searched, valid_share, factor = coarse_disparity(
            reference, target, factor, params.search_share, census, disparity_range
        )
    except (StageError, ParamsError) as error:
        return PairMatching(key, None, (0.0, 0.0), 0.0, factor, f"census matching failed ({error})")
    return PairMatching(key, disparity, searched, valid_share, factor, "", work)


def height_objects(
    reference: np.ndarray,
    target: np.ndarray,
    params: ObjectsParams = ObjectsParams(method="height"),
    *,
    gsd_m: float | None = None,
    base_to_height: float | None = None,
    disparity_range: tuple[float, float] | None = None,
    px_per_m: float | None = None,
    greenness: np.ndarray | None = None,
    matching: PairMatching | None = None,
) -> HeightObjects:
    """Objects of both images from the pair's height above ground (the ``"height"`` method).

    See :mod:`radcons.stages.height` (disparity, ground, height) and
    :mod:`radcons.stages.objects_height` (regions, snapping, trees, transfer).

    Parameters
    ----------
    reference, target : ndarray
        The working (rectified) pair, NaN where invalid.
    params : ObjectsParams
    gsd_m, base_to_height : float, optional
        Ground sample distance (m) and base-to-height ratio; with both, heights are in
        metres.
    disparity_range : tuple of float, optional
        Known disparity range (px); else it is searched.
    px_per_m : float, optional
        Disparity pixels per metre of height when known otherwise (e.g. from the RPC
        models of an RPC rectification); wins over ``base_to_height / gsd_m``.
    greenness : ndarray, optional
        Green leaf index of the reference's pixels (an RGB reference,
        :attr:`radcons.io.Raster.greenness`): green objects are trees.
    matching : PairMatching, optional
        The pair's census matching from :func:`match_pair`, when the caller kept it: used
        when it was computed with this pair's ``params`` (census fields), ground sample
        distance and range, else matched again.

    Returns
    -------
    HeightObjects
        Empty labels and a note for a flat scene; the image-only objects (``method =
        "mbi"``) and the reason in ``note`` when the disparity fails on most of the image.

    Raises
    ------
    InputError
        Images not 2-D, of different shapes or without a valid pixel.
    """
    reference, target = _validated_pair(reference, target)
    if greenness is not None and np.shape(greenness) != reference.shape:
        raise InputError(f"the greenness map's shape {np.shape(greenness)} differs from the reference's {reference.shape}")
    gsd = _resolved_gsd(gsd_m, params)
    sigma = max(1.0, _TEXTURE_SCALE_M / gsd)
    if matching is None or matching.key != PairMatching.key_of(reference.shape, params, gsd, disparity_range):
        matching = _match_pair(reference, target, params, gsd, disparity_range)
    if matching.failure:
        return _fallback(reference, target, params, matching.failure)
    work, searched, valid_share, factor = matching.work, matching.searched, matching.valid_share, matching.factor
    if valid_share < params.min_valid_share:
        return _fallback(
            reference, target, params,
            f"the census disparity is consistent on {100 * valid_share:.1f} % of the images' overlap "
            f"(min_valid_share {100 * params.min_valid_share:.0f} %)",
        )
    disparity = fill_occlusions(matching.disparity)
    disparity[~np.isfinite(downsample(reference, factor)[: disparity.shape[0], : disparity.shape[1]])] = np.nan
    window = int(round(params.ground_window_m / gsd / factor))
    if not (px_per_m and px_per_m > 0) and gsd_m and base_to_height and gsd_m > 0 and base_to_height > 0:
        px_per_m = base_to_height / gsd_m
    metric = bool(px_per_m and px_per_m > 0)
    threshold = params.min_height_m if metric else params.min_height_px
    jump = params.split_jump_m if metric else params.split_jump_px
    ground = ground_disparity(disparity, window, params.ground_percentile, threshold * (px_per_m if metric else 1.0))
    height, unit, px_per_unit = height_above_ground(disparity, ground, px_per_m if metric else None)
    heights = HeightMap(disparity, ground, height, unit, px_per_unit, factor, searched, valid_share)
    empty = np.zeros(reference.shape, np.int32)
    if not (np.nan_to_num(height, nan=0.0) > threshold).any():
        note = f"no pixel stands {threshold:g} {unit} above the ground: a flat scene, no objects"
        return HeightObjects(empty, empty.copy(), "segmented", heights, "height", note)
    area = (params.min_area_m2 / gsd**2, params.max_area_m2 / gsd**2)
    labels = segment_elevated(reference, heights, threshold, jump, area, params.min_elevated_share, params.flat_edges)
    scales = work.scales()
    features = object_features(reference, labels, heights, sigma, scales)
    trees, low = np.zeros(int(labels.max()) + 1, bool), np.zeros(int(labels.max()) + 1, bool)
    for index, feature in features.items():
        trees[index] = is_tree(feature, params, metric)
        low[index] = not feature["height"] >= params.min_object_height * threshold
    census = work.census()
    found = object_disparities(reference, target, labels, heights, sigma, params.disparity_radius, census)
    keep = np.zeros(trees.size, bool)
    for index, (_, _, contrast) in found.items():
        keep[index] = not trees[index] and not low[index] and not np.nan_to_num(contrast) < params.min_match_score
    mismatched = int(sum(1 for i in found if not trees[i] and not keep[i]))
    removed = (labels > 0) & ~keep[labels]
    rule = np.select([keep, trees, low], [0, 1, 2], 3).astype(np.uint8)  # LEFT_OUT_RULES
    left_out = np.where(removed, rule[labels], 0).astype(np.uint8)
    modal = {i: values[0] for i, values in found.items()}
    scores = {i: values[1] for i, values in found.items()}
    labels, modal, scores = keep_objects(labels, keep, modal, scores)
    if params.join_roof_halves:
        labels, modal, scores = join_roof_halves(labels, modal, scores)
    clipped = np.zeros(reference.shape, bool)
    if params.find_clipped:
        lowest = params.min_object_height * threshold * heights.px_per_unit
        (labels, modal, scores), clipped = _with_clipped_roofs(
            (labels, modal, scores), (reference, target), heights, lowest, area, sigma
        )
    if params.find_missed:
        missed = missed_objects(
            reference, labels, heights, census, params, gsd, threshold, scales, work.segments(params.missed_scale)
        )
        labels, modal, scores = _with_new_objects((labels, modal, scores), missed, (reference, target), sigma)
    if params.find_in_removed:
        roofs = roofs_in_removed(
            reference, labels, removed, heights, census, params, gsd, threshold, scales,
            work.segments(params.removed_scale),
        )
        labels, modal, scores = _with_new_objects((labels, modal, scores), roofs, (reference, target), sigma)
    if params.join_roof_halves and (params.find_missed or params.find_in_removed):
        labels, modal, scores = join_roof_halves(labels, modal, scores)
    gables = np.zeros(reference.shape, bool)
    if params.complete_gables:
        check = CensusCheck.of(heights, census, params, threshold, reference.shape)
        (labels, modal, scores), gables = _with_gables_completed(
            (labels, modal, scores), (reference, target), check, params.disparity_radius, sigma
        )
    if params.join_wings:
        labels, modal, scores = join_wings(labels, modal, scores)
    labels = snap_rims(trim_shadows(labels, scales.smooth, params.shadow_trim), reference, params.outline_band)
    crowns = 0
    if labels.any():
        shadow = np.zeros(int(labels.max()) + 1, bool)
        gabled = mostly_on(labels, gables)  # two planes whose disparities rise to one ridge: no shadow's
        edgeless = np.zeros(int(labels.max()) + 1, bool)
        dark = np.zeros(int(labels.max()) + 1, bool)
        low_crown = np.zeros(int(labels.max()) + 1, bool)
        for index, feature in object_features(reference, labels, heights, sigma, scales).items():
            shadow[index] = is_shadow(feature, params) and not gabled[index]
            edgeless[index] = is_edgeless(feature, params)
            dark[index] = is_dark_and_low(feature, params, threshold)
            low_crown[index] = is_low_crown(feature, params, threshold)
        shade = shadow | edgeless
        dark &= ~shade
        low_crown &= ~(shade | dark)
        mismatched += int(shade.sum())
        crowns = int(dark.sum() + low_crown.sum())
        rule = np.select([shadow, edgeless, dark, low_crown], [4, 5, 6, 8], 0).astype(np.uint8)
        left_out = np.where(labels > 0, rule[labels], left_out).astype(np.uint8)
        labels, modal, scores = keep_objects(labels, ~(shade | dark | low_crown), modal, scores)
    green = 0
    if greenness is not None and labels.any():
        trees_by_colour = green_objects(labels, greenness, params.tree_greenness)
        green = int(trees_by_colour.sum())
        left_out[(labels > 0) & trees_by_colour[labels]] = 7
        labels, modal, scores = keep_objects(labels, ~trees_by_colour, modal, scores)
    left_out[labels > 0] = 0
    # a clipped roof's D̄m comes from its outline: census sees nothing inside it
    by_outline = set(np.nonzero(mostly_on(labels, clipped))[0].tolist())
    by_census = {i: shift for i, shift in modal.items() if i not in by_outline}
    modal = {**modal, **refined_disparities(labels, by_census, census, params.disparity_radius)}
    unmatched: tuple[int, ...] = ()
    if params.cross_check_objects and by_census:
        back = matched_back(labels, by_census, census, heights.searched_disparities(), MAX_PIXELS)
        unmatched = tuple(sorted(i for i, held in back.items() if not held))
        modal = {i: shift for i, shift in modal.items() if i not in unmatched}
    note = "" if labels.any() else f"no elevated region of {params.min_area_m2:g} m² or more that is not a tree"
    return HeightObjects(
        labels, transfer_to_target(labels, modal), "segmented", heights, "height", note, modal, scores,
        int(trees.sum()) + crowns + green, mismatched, unmatched, left_out, tuple(sorted(by_outline)),
    )


@dataclass(frozen=True)
class _ImageWork:
    """What the height method needs of the images alone, computed beside the census matching.

    The census descriptors of both images, the reference's gradient scales at 0.5 m
    (:class:`radcons.stages.object_features.ImageScales`) and its graph segments
    (:func:`radcons.stages.objects_missed.reference_segments`, at the scales of the
    searches switched on) do not depend on the disparity. They are computed in a worker
    thread while Pandora matches: both release the GIL for most of their work, and so
    does Pandora's C++ (0.23 s of 1.5 s at 1024 x 1024 px, `benchmarks/bench_objects.py
    --only timing`). A pair that falls back or is flat leaves its jobs to finish unused.
    The reference and its ground sample distance (m) are kept for the segments at a
    scale not started with the others (a :class:`PairMatching` kept while the searches'
    scales are tuned).
    """

    scales_job: Future
    descriptor_jobs: tuple[Future, Future]
    segment_jobs: dict[float, Future]
    reference: np.ndarray
    gsd: float

    @classmethod
    def start(
        cls, reference: np.ndarray, target: np.ndarray, gsd: float, sigma: float, params: ObjectsParams
    ) -> "_ImageWork":
        """Submit one pair's jobs to the worker thread, in the order they are needed.

        ``sigma`` is the smoothing of the gradient scales, px.
        """
        searches = ((params.missed_scale, params.find_missed), (params.removed_scale, params.find_in_removed))
        scales = {scale for scale, used in searches if used}
        return cls(
            _WORKER.submit(ImageScales.of, reference, sigma),
            (_WORKER.submit(census_descriptors, reference), _WORKER.submit(census_descriptors, target)),
            {scale: _WORKER.submit(reference_segments, reference, gsd, scale) for scale in sorted(scales)},
            reference,
            gsd,
        )

    def census(self) -> tuple[np.ndarray, np.ndarray]:
        """Census descriptors of the reference and the target (waits for them)."""
        return self.descriptor_jobs[0].result(), self.descriptor_jobs[1].result()

    def scales(self) -> ImageScales:
        """The reference's gradient scales at 0.5 m (waits for them)."""
        return self.scales_job.result()

    def segments(self, scale: float) -> np.ndarray:
        """The reference's graph segments at ``scale`` (waits for them; a scale not started yet is started now)."""
        if scale not in self.segment_jobs:
            self.segment_jobs[scale] = _WORKER.submit(reference_segments, self.reference, self.gsd, scale)
        return self.segment_jobs[scale].result()


#: The worker thread of :class:`_ImageWork`, shared by every call (jobs queue in order;
#: the thread starts with the first job).
_WORKER = ThreadPoolExecutor(max_workers=1, thread_name_prefix="radcons-objects")


def _with_new_objects(
    objects: tuple[np.ndarray, dict[int, float], dict[int, float]],
    new: tuple[np.ndarray, dict[int, float]],
    images: tuple[np.ndarray, np.ndarray],
    sigma: float,
) -> tuple[np.ndarray, dict[int, float], dict[int, float]]:
    """Objects, D̄m and match scores with ``new`` objects (labels 1..K and their D̄m) numbered after the others."""
    labels, modal, scores = objects
    added, shifts = new
    offset = int(labels.max())
    modal = {**modal, **{offset + i: shift for i, shift in shifts.items()}}
    scores = {**scores, **{offset + i: score for i, score in match_scores(*images, added, shifts, sigma).items()}}
    return np.where(added > 0, added + offset, labels).astype(np.int32), modal, scores


def _with_gables_completed(
    objects: tuple[np.ndarray, dict[int, float], dict[int, float]],
    images: tuple[np.ndarray, np.ndarray],
    check: CensusCheck,
    radius: int,
    sigma: float,
) -> tuple[tuple[np.ndarray, dict[int, float], dict[int, float]], np.ndarray]:
    """Objects, D̄m and match scores with each gabled roof's missing plane (:func:`complete_gables`), numbered 1..K.

    Also returns where the grown objects lie: the shadow rule spares them. A gable's
    shaded plane darkens the whole roof's median (a roof of JAX_072 was left out as a
    shadow once joined to it), while a shadow has no two planes rising to one ridge.
    """
    labels, modal, scores = objects
    count = int(labels.max())
    labels, modal, grown = complete_gables(labels, modal, check, radius)
    if not grown:
        return (labels, modal, scores), np.zeros(labels.shape, bool)
    scores = {**scores, **match_scores(*images, labels, {i: modal[i] for i in grown}, sigma)}
    kept = np.bincount(labels.ravel(), minlength=count + 1) > 0  # the objects taken in go, the last one too
    return keep_objects(labels, kept, modal, scores), np.isin(labels, grown)


def _with_clipped_roofs(
    objects: tuple[np.ndarray, dict[int, float], dict[int, float]],
    images: tuple[np.ndarray, np.ndarray],
    heights: HeightMap,
    lowest: float,
    area: tuple[float, float],
    sigma: float,
) -> tuple[tuple[np.ndarray, dict[int, float], dict[int, float]], np.ndarray]:
    """The objects with the roofs clipped in either image (:func:`clipped_roofs`), and where those roofs lie.

    The objects lying mostly on a clipped roof (its furniture) give way to it; the others
    keep their pixels.
    """
    roofs, shifts = clipped_roofs(*images, heights, lowest, area)
    if not shifts:
        return objects, np.zeros(roofs.shape, bool)
    labels, modal, scores = objects
    labels, modal, scores = keep_objects(labels, ~mostly_on(labels, roofs > 0), modal, scores)
    roofs[labels > 0] = 0
    return _with_new_objects((labels, modal, scores), (roofs, shifts), images, sigma), roofs > 0


def _fallback(reference: np.ndarray, target: np.ndarray, params: ObjectsParams, reason: str) -> HeightObjects:
    """The image-only objects of both images, with the reason the height method was left."""
    return HeightObjects(
        extract_objects(reference, params),
        extract_objects(target, params),
        "segmented",
        None,
        "mbi",
        f"{reason}: image-only objects (mbi) instead",
    )
