"""The height method: the buildings of both images from the pair's height above ground.

:func:`height_objects` runs the steps of the package overview (:mod:`radcons.stages.objects`)
in order: :func:`_height_map` (matching, ground, height), :func:`_first_objects` (regions,
tree, height and contrast rules), :func:`_searched_and_joined` (searches and joins),
:func:`_final_rules` (outlines and the rules judged on them) and
:func:`_final_disparities` (final D̄m and left-right check), then moves each object into
the target. When the census disparity fails, the image-only objects of
:func:`radcons.stages.objects.mbi.extract_objects` stand in (:func:`_fallback`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from radcons.errors import InputError
from radcons.numerics.coarse_disparity import downsample, fill_occlusions
from radcons.stages.objects.census_check import MAX_PIXELS, CensusCheck
from radcons.stages.objects.features import ImageScales, object_features
from radcons.stages.objects.ground import (
    HeightMap,
    ground_under,
    height_above_ground,
)
from radcons.stages.objects.joins.halves import join_roof_halves
from radcons.stages.objects.joins.mirror import complete_gables
from radcons.stages.objects.joins.wings import join_wings
from radcons.stages.objects.matching import (
    TEXTURE_SCALE_M,
    ImageWork,
    PairMatching,
    match_validated_pair,
    resolved_gsd,
    validated_pair,
)
from radcons.stages.objects.mbi import extract_objects
from radcons.stages.objects.memo import LastResults
from radcons.stages.objects.outlines import snap_rims, trim_shadows
from radcons.stages.objects.params import ObjectsParams
from radcons.stages.objects.regions import HeightObjects, keep_objects, segment_elevated
from radcons.stages.objects.rules import (
    green_objects,
    is_dark_and_low,
    is_edgeless,
    is_low_crown,
    is_shadow,
    is_tree,
)
from radcons.stages.objects.searches.clipped import clipped_roofs, mostly_on
from radcons.stages.objects.searches.missed import missed_objects
from radcons.stages.objects.searches.parts import roofs_in_removed
from radcons.stages.objects.transfer import (
    match_scores,
    matched_back,
    object_disparities,
    refined_disparities,
    transfer_to_target,
)

__all__ = ["ObjectsParams", "extract_objects", "height_objects"]

#: Objects of the reference (labels 1..K), their D̄m and their match scores, passed from step to step.
Objects = tuple[np.ndarray, dict[int, float], dict[int, float]]


@dataclass(frozen=True)
class _Scene:
    """What every step after the height map reads: the pair, its height map and the thresholds.

    Attributes
    ----------
    reference, target : ndarray
        The validated pair, NaN where invalid.
    params : ObjectsParams
    heights : HeightMap
        The pair's census disparity, ground and height above it.
    work : ImageWork
        The images' census descriptors, gradient scales and graph segments.
    gsd : float
        Ground sample distance the method works at, m.
    sigma : float
        Smoothing of the texture and match measures, px (0.5 m, at least 1 px).
    threshold, jump : float
        Height that makes a pixel elevated and height spread that separates two
        objects, in the height map's unit.
    metric : bool
        Heights are in metres (else disparity pixels).
    area : (float, float)
        Smallest and largest object, px.
    kept : LastResults
        The steps' results kept with the pair's census matching for a run with other
        thresholds (:mod:`radcons.stages.objects.memo`).
    """

    reference: np.ndarray
    target: np.ndarray
    params: ObjectsParams
    heights: HeightMap
    work: ImageWork
    gsd: float
    sigma: float
    threshold: float
    jump: float
    metric: bool
    area: tuple[float, float]
    kept: LastResults

    @property
    def images(self) -> tuple[np.ndarray, np.ndarray]:
        """``(reference, target)``."""
        return self.reference, self.target

    @property
    def scales(self) -> ImageScales:
        """The reference's gradient scales (waits for the worker)."""
        return self.work.scales()

    @property
    def census(self) -> tuple[np.ndarray, np.ndarray]:
        """Census descriptors of both images (waits for the worker)."""
        return self.work.census()


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
        The pair's census matching from :func:`radcons.stages.objects.matching.match_pair`,
        when the caller kept it: used when it was computed with this pair's ``params``
        (census fields), ground sample distance and range, else matched again.

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
    reference, target = validated_pair(reference, target)
    if greenness is not None and np.shape(greenness) != reference.shape:
        raise InputError(
            f"the greenness map's shape {np.shape(greenness)} differs from the reference's {reference.shape}"
        )
    gsd = resolved_gsd(gsd_m, params)
    sigma = max(1.0, TEXTURE_SCALE_M / gsd)
    if matching is None or matching.key != PairMatching.key_of(reference.shape, params, gsd, disparity_range):
        matching = match_validated_pair(reference, target, params, gsd, disparity_range)
    failure = _matching_failure(matching, params)
    if failure:
        return _fallback(reference, target, params, failure)
    px_per_m = _px_per_m(gsd_m, base_to_height, px_per_m)
    heights, threshold, metric = _height_map(reference, matching, params, gsd, px_per_m)
    if not (np.nan_to_num(heights.height, nan=0.0) > threshold).any():
        empty = np.zeros(reference.shape, np.int32)
        note = f"no pixel stands {threshold:g} {heights.unit} above the ground: a flat scene, no objects"
        return HeightObjects(empty, empty.copy(), "segmented", heights, "height", note)
    jump = params.split_jump_m if metric else params.split_jump_px
    area = (params.min_area_m2 / gsd**2, params.max_area_m2 / gsd**2)
    scene = _Scene(
        reference, target, params, heights, matching.work, gsd, sigma, threshold, jump, metric, area, matching.kept
    )
    objects, removed, left_out, trees, mismatched = _first_objects(scene)
    objects, clipped, gables = _searched_and_joined(scene, objects, removed)
    objects, left_out, shades, crowns = _final_rules(scene, objects, gables, greenness, left_out)
    labels, modal, scores = objects
    modal, unmatched, by_outline = _final_disparities(scene, labels, modal, clipped)
    note = "" if labels.any() else f"no elevated region of {params.min_area_m2:g} m² or more that is not a tree"
    return HeightObjects(
        labels, transfer_to_target(labels, modal), "segmented", heights, "height", note, modal, scores,
        trees + crowns, mismatched + shades, unmatched, left_out, by_outline,
    )


def _matching_failure(matching: PairMatching, params: ObjectsParams) -> str:
    """Why the census matching cannot carry the height method ("" when it can).

    Census matching failed outright, or its left-right consistent share of the overlap
    is below ``min_valid_share``: the disparity is then noise on most of the image.
    """
    if matching.failure:
        return matching.failure
    if matching.valid_share < params.min_valid_share:
        return (
            f"the census disparity is consistent on {100 * matching.valid_share:.1f} % of the images' overlap "
            f"(min_valid_share {100 * params.min_valid_share:.0f} %)"
        )
    return ""


def _px_per_m(gsd_m: float | None, base_to_height: float | None, px_per_m: float | None) -> float | None:
    """Disparity pixels per metre of height: ``px_per_m`` when given, else ``base_to_height / gsd_m`` when both are."""
    if not (px_per_m and px_per_m > 0) and gsd_m and base_to_height and gsd_m > 0 and base_to_height > 0:
        return base_to_height / gsd_m
    return px_per_m


def _height_map(
    reference: np.ndarray, matching: PairMatching, params: ObjectsParams, gsd: float, px_per_m: float | None
) -> tuple[HeightMap, float, bool]:
    """The height above ground of the census grid, the height threshold and whether heights are in metres.

    The census disparity's occlusions are filled, and its cells whose reference block
    holds no valid pixel made invalid; the ground is the one ``ground`` names
    (:func:`radcons.stages.objects.ground.ground_under`: in windows of ``ground_window_m``
    by default). Heights are in metres where ``px_per_m`` is known (threshold
    ``min_height_m``), else in disparity pixels (``min_height_px``).
    """
    factor = matching.factor
    disparity = fill_occlusions(matching.disparity)
    disparity[~np.isfinite(downsample(reference, factor)[: disparity.shape[0], : disparity.shape[1]])] = np.nan
    metric = bool(px_per_m and px_per_m > 0)
    threshold = params.min_height_m if metric else params.min_height_px
    ground = ground_under(disparity, params, gsd, factor, px_per_m if metric else None)
    height, unit, px_per_unit = height_above_ground(disparity, ground, px_per_m if metric else None)
    heights = HeightMap(disparity, ground, height, unit, px_per_unit, factor, matching.searched, matching.valid_share)
    return heights, threshold, metric


def _first_objects(scene: _Scene) -> tuple[Objects, np.ndarray, np.ndarray, int, int]:
    """The elevated regions less the trees, the low ones and the mismatches, with their D̄m and scores.

    Returns
    -------
    objects : Objects
        The regions kept, numbered 1..K.
    removed : ndarray of bool
        The pixels of the regions left out (where :func:`roofs_in_removed` looks).
    left_out : ndarray of uint8
        Those pixels' rule codes (:data:`radcons.stages.objects.rules.LEFT_OUT_RULES`).
    trees, mismatched : int
        Regions left out as trees, and as low or mismatched (trees not counted).
    """
    reference, params, heights, threshold = scene.reference, scene.params, scene.heights, scene.threshold
    labels = scene.kept(
        segment_elevated, reference, heights, threshold, scene.jump, scene.area, params.min_elevated_share,
        params.flat_edges,
    )
    features = object_features(reference, labels, heights, scene.sigma, scene.scales)
    trees, low = np.zeros(int(labels.max()) + 1, bool), np.zeros(int(labels.max()) + 1, bool)
    for index, feature in features.items():
        trees[index] = is_tree(feature, params, scene.metric)
        low[index] = not feature["height"] >= params.min_object_height * threshold
    found = scene.kept(
        object_disparities, reference, scene.target, labels, heights, scene.sigma, params.disparity_radius,
        scene.census,
    )
    keep = np.zeros(trees.size, bool)
    for index, (_, _, contrast) in found.items():
        keep[index] = not trees[index] and not low[index] and not np.nan_to_num(contrast) < params.min_match_score
    mismatched = int(sum(1 for i in found if not trees[i] and not keep[i]))
    removed = (labels > 0) & ~keep[labels]
    rule = np.select([keep, trees, low], [0, 1, 2], 3).astype(np.uint8)  # LEFT_OUT_RULES
    left_out = np.where(removed, rule[labels], 0).astype(np.uint8)
    modal = {i: values[0] for i, values in found.items()}
    scores = {i: values[1] for i, values in found.items()}
    return keep_objects(labels, keep, modal, scores), removed, left_out, int(trees.sum()), mismatched


def _searched_and_joined(
    scene: _Scene, objects: Objects, removed: np.ndarray
) -> tuple[Objects, np.ndarray, np.ndarray]:
    """The objects with the searches' roofs added and the roofs cut in parts joined.

    In order, each where its switch is on: the gabled roofs' halves joined, the roofs
    clipped in one image, the missed buildings, the roofs in the removed regions, the
    halves joined again (for the objects the searches added), the gables completed and
    the wings joined.

    Returns
    -------
    objects : Objects
    clipped : ndarray of bool
        Where the clipped roofs lie (their D̄m comes from their outline).
    gables : ndarray of bool
        Where the completed gables lie (the shadow rule spares them).
    """
    reference, params, heights = scene.reference, scene.params, scene.heights
    if params.join_roof_halves:
        objects = join_roof_halves(*objects)
    clipped = np.zeros(reference.shape, bool)
    if params.find_clipped:
        lowest = params.min_object_height * scene.threshold * heights.px_per_unit
        objects, clipped = _with_clipped_roofs(objects, scene.images, heights, lowest, scene.area, scene.sigma)
    if params.find_missed:
        labels = objects[0]
        missed = missed_objects(
            reference, labels, heights, scene.census, params, scene.gsd, scene.threshold, scene.scales,
            scene.work.segments(params.missed_scale),
        )
        objects = _with_new_objects(objects, missed, scene.images, scene.sigma)
    if params.find_in_removed:
        roofs = roofs_in_removed(
            reference, objects[0], removed, heights, scene.census, params, scene.gsd, scene.threshold, scene.scales,
            scene.work.segments(params.removed_scale),
        )
        objects = _with_new_objects(objects, roofs, scene.images, scene.sigma)
    if params.join_roof_halves and (params.find_missed or params.find_in_removed):
        objects = join_roof_halves(*objects)
    gables = np.zeros(reference.shape, bool)
    if params.complete_gables:
        check = CensusCheck.of(heights, scene.census, params, scene.threshold, reference.shape)
        objects, gables = _with_gables_completed(objects, scene.images, check, params.disparity_radius, scene.sigma)
    if params.join_wings:
        objects = join_wings(*objects)
    return objects, clipped, gables


def _final_rules(
    scene: _Scene, objects: Objects, gables: np.ndarray, greenness: np.ndarray | None, left_out: np.ndarray
) -> tuple[Objects, np.ndarray, int, int]:
    """The final outlines, less the shadows, edgeless patches, dark and low objects, low crowns and green objects.

    Each object first loses the cast shadow it spilled onto and has its rim snapped
    (:func:`trim_shadows`, :func:`snap_rims`). The rules that judge an outline
    (:func:`is_shadow`, :func:`is_edgeless`, :func:`is_dark_and_low`, :func:`is_low_crown`)
    then run on the final objects; a completed gable is no shadow (its shaded plane
    darkens the whole roof's median, but a shadow has no two planes rising to one ridge).
    On an RGB pair the green objects go last (:func:`green_objects`).

    Returns
    -------
    objects : Objects
        The objects kept, numbered 1..K.
    left_out : ndarray of uint8
        The rule codes, with those of these rules added and the kept objects' pixels 0.
    shades : int
        Objects left out as shadows or edgeless patches (counted with the mismatches).
    crowns : int
        Objects left out as dark and low, low crowns or green (counted with the trees).
    """
    reference, params, heights, threshold = scene.reference, scene.params, scene.heights, scene.threshold
    labels, modal, scores = objects
    labels = snap_rims(trim_shadows(labels, scene.scales.smooth, params.shadow_trim), reference, params.outline_band)
    shades = crowns = 0
    if labels.any():
        shadow = np.zeros(int(labels.max()) + 1, bool)
        gabled = mostly_on(labels, gables)  # two planes whose disparities rise to one ridge: no shadow's
        edgeless = np.zeros(int(labels.max()) + 1, bool)
        dark = np.zeros(int(labels.max()) + 1, bool)
        low_crown = np.zeros(int(labels.max()) + 1, bool)
        for index, feature in object_features(reference, labels, heights, scene.sigma, scene.scales).items():
            shadow[index] = is_shadow(feature, params) and not gabled[index]
            edgeless[index] = is_edgeless(feature, params)
            dark[index] = is_dark_and_low(feature, params, threshold)
            low_crown[index] = is_low_crown(feature, params, threshold)
        shade = shadow | edgeless
        dark &= ~shade
        low_crown &= ~(shade | dark)
        shades = int(shade.sum())
        crowns = int(dark.sum() + low_crown.sum())
        rule = np.select([shadow, edgeless, dark, low_crown], [4, 5, 6, 8], 0).astype(np.uint8)
        left_out = np.where(labels > 0, rule[labels], left_out).astype(np.uint8)
        labels, modal, scores = keep_objects(labels, ~(shade | dark | low_crown), modal, scores)
    if greenness is not None and labels.any():
        trees_by_colour = green_objects(labels, greenness, params.tree_greenness)
        crowns += int(trees_by_colour.sum())
        left_out[(labels > 0) & trees_by_colour[labels]] = 7
        labels, modal, scores = keep_objects(labels, ~trees_by_colour, modal, scores)
    left_out[labels > 0] = 0
    return (labels, modal, scores), left_out, shades, crowns


def _final_disparities(
    scene: _Scene, labels: np.ndarray, modal: dict[int, float], clipped: np.ndarray
) -> tuple[dict[int, float], tuple[int, ...], tuple[int, ...]]:
    """Each final object's D̄m, refined on its final core and left-right checked.

    A clipped roof keeps the D̄m its outline gave: census sees nothing inside it. The
    others' D̄m is refined on their pixels away from the final outline
    (:func:`refined_disparities`), and, with ``cross_check_objects``, dropped where the
    object's copy in the target does not match back at it (:func:`matched_back`).

    Returns
    -------
    modal : dict
        Object id -> D̄m (px) of the objects to move into the target.
    unmatched : tuple of int
        The objects whose copy did not match back.
    by_outline : tuple of int
        The clipped roofs, whose D̄m comes from their outline.
    """
    params = scene.params
    by_outline = set(np.nonzero(mostly_on(labels, clipped))[0].tolist())
    by_census = {i: shift for i, shift in modal.items() if i not in by_outline}
    modal = {**modal, **refined_disparities(labels, by_census, scene.census, params.disparity_radius)}
    unmatched: tuple[int, ...] = ()
    if params.cross_check_objects and by_census:
        back = matched_back(labels, by_census, scene.census, scene.heights.searched_disparities(), MAX_PIXELS)
        unmatched = tuple(sorted(i for i, held in back.items() if not held))
        modal = {i: shift for i, shift in modal.items() if i not in unmatched}
    return modal, unmatched, tuple(sorted(by_outline))


def _with_new_objects(
    objects: Objects,
    new: tuple[np.ndarray, dict[int, float]],
    images: tuple[np.ndarray, np.ndarray],
    sigma: float,
) -> Objects:
    """Objects, D̄m and match scores with ``new`` objects (labels 1..K and their D̄m) numbered after the others."""
    labels, modal, scores = objects
    added, shifts = new
    offset = int(labels.max())
    modal = {**modal, **{offset + i: shift for i, shift in shifts.items()}}
    scores = {**scores, **{offset + i: score for i, score in match_scores(*images, added, shifts, sigma).items()}}
    return np.where(added > 0, added + offset, labels).astype(np.int32), modal, scores


def _with_gables_completed(
    objects: Objects,
    images: tuple[np.ndarray, np.ndarray],
    check: CensusCheck,
    radius: int,
    sigma: float,
) -> tuple[Objects, np.ndarray]:
    """Objects, D̄m and match scores with each gabled roof's missing plane (:func:`complete_gables`), numbered 1..K.

    Also returns where the grown objects lie: the shadow rule spares them, since a
    gable's shaded plane darkens the whole roof's median while a shadow has no two
    planes rising to one ridge.
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
    objects: Objects,
    images: tuple[np.ndarray, np.ndarray],
    heights: HeightMap,
    lowest: float,
    area: tuple[float, float],
    sigma: float,
) -> tuple[Objects, np.ndarray]:
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
