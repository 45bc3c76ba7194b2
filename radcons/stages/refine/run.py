"""Refined object-oriented illumination normalisation of the target (eq 7-12).

Su et al. (2018), section 4.2.2: inside each associated object, the invariant points of
eq 12 (matches whose disparity agrees with the object's modal disparity) give pairs of grey
values, target ``x_k`` and reference ``y_k``, assumed linearly related (eq 7). The line is
fitted by weighted least squares (eq 9) whose weights (eq 11) fall linearly from 1 to 0
with the standardised difference ``T_k = |y'_k - x'_k|`` (eq 10), and the target's object
region is mapped through it (eq 8).

Choices where the paper is silent (exposed in :class:`RefineParams` or documented here):

* eq 10 standardises with the mean and standard deviation of the object's own points
  (the paper's "reference image and transform image" statistics, taken per object, since
  each object's line is fitted independently);
* degenerate fits: if every ``T_k`` is equal the weights are all 1; if the (weighted)
  target values are constant the slope is undefined and the fit is a pure offset,
  ``gain = 1, offset = weighted mean(y - x)``;
* an object with fewer than ``min_points`` invariant points, a gain outside
  ``gain_range``, or no target object (``tgt_id = 0``) keeps the global result
  (``ObjectFit.applied = False`` with the reason in ``ObjectFit.note``, gain 1, offset 0
  recorded when no fit was possible);
* clipped pixels: a point on a pixel that the sensor clipped
  (:func:`radcons.numerics.valid_pixels.clipped_mask`: the image's smallest or largest grey
  value, held by a pile of pixels) only bounds the grey value, so it is left out of the
  fit. An object with more than ``max_clipped`` of its points clipped gets an offset only,
  ``gain = 1, offset = mean(y) - mean(x)`` over all its points: its few unclipped pixels
  cannot tell the line (they are the object's darker part, not a sample of it, and give
  wild gains and offsets), but the offset still brings its grey level to the reference's;
* when several reference objects are associated with the same target object, the
  association with the most points is applied and the others are recorded as not
  applied;
* grey values are sampled at the sub-pixel point positions by bilinear interpolation;
  points on invalid (NaN) pixels are dropped;
* feathering: the corrected value is blended with the global one with the weight
  ``w = min(d / blend_width, 1)``, ``d`` the Euclidean distance (px) of a pixel of the
  object to the nearest pixel outside it (1 on the object's border). The object's border
  thus stays within ``1 / blend_width`` of the global result and there is no seam with the
  background or a neighbouring object; ``blend_width = 0`` applies the line hard.

Only the target is changed: the reference is the radiometric standard.

Option ``points = "dense"`` (not the paper's): the points of an object are its target
pixels (2 px inside the border) paired with the reference pixels D̄m to their right, so
template-associated objects, which have no invariant matches, get a fit too, and a fit
rests on hundreds of points; the weights of eq 11 still damp the pixels where the pairing
is wrong (walls, occlusions).

Option ``fit = "moments"`` (not the paper's): the line through the points' means whose
gain is the ratio of their standard deviations, ``gain = std(y) / std(x)``, ``offset =
mean(y) - gain mean(x)`` (the reduced major axis). The least-squares gain of eq 9 is that
gain times the correlation of the points, which the target's noise and the fraction of a
pixel by which point pairs are misregistered on textured roofs both lower (regression
dilution), so it flattens the target's contrast. The moments line needs no pixel-accurate
pairing: with dense points it gives the target object the grey-level mean and spread of
the reference pixels D̄m to its right.

Option ``background = "histogram"`` (the paper does not say what happens outside the
objects; ``"global"`` keeps the global stage's result there): the target pixels that no
applied object fit covers take the whole-image histogram matching of the target onto the
reference (``skimage.exposure.match_histograms`` over the valid pixels), a monotone
mapping that also undoes a gamma and offset the scalar of eq 5 cannot. ``"local"``: that
mapping, then a gain and offset per tile of a ``local_tiles`` grid, blended between tiles,
for light that varies across the scene, applied when it moves the target by at least
``local_min_light`` (:func:`radcons.stages.refine.light.local_light_correction`).

Option ``background_noise`` (with ``background = "histogram"`` or ``"local"``): the mapping is fitted as
if the target carried the noise that brings it to the reference's level
(:func:`radcons.stages.refine.background.noise_aware_histogram_mapping`). A noisier
reference's histogram is its signal's widened by its noise, and a cleaner target matched
onto it as it is takes that noise as contrast, most where its own histogram peaks. Scene
mode builds the same mapping from the scene's grey-value counts
(:func:`radcons.scene.stats.noise_aware_lut`).

Option ``agreement_gate``: an object's line is applied only where it lowers the mean
absolute difference between the object's target pixels and the reference pixels D̄m to
their right (:func:`object_agreement`) below the background mapping's; a line fitted on a
few misleading points (a change between the dates) would move the whole object away from
the reference.

Option ``clip_to_reference``: the refined target is clipped to the reference's grey-level
range. A line extrapolated over an object's walls or glare can throw a few pixels far out
of it, and dense matching maps both images to 8 bits over their common range
(:func:`radcons.evaluate.matching.to_uint8_pair`), so such outliers lower the contrast the
matcher sees, which by itself changes the correct-matching rate. Clipped, the refined
target is compared at the contrast of every method that stays within the reference's
range.

These options, with ``points = "dense"`` and ``blend_width = 0`` (a feathering ramp adds
false x-gradients that the matcher reads as texture), make the ``radcons`` preset's refine
stage (:meth:`radcons.params.Params.from_preset`; the measurements: ``docs/tuning.md``).
They bring the target to histogram matching's level of agreement, not beyond it: the
target's remaining difference is its blur and noise, see
:mod:`radcons.stages.sharpness.run`.

Reference: Su, Yan, Zhao, Wang (2018), Remote Sensing 10(2):336, section 4.2.2.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import cv2
import numpy as np
import scipy.ndimage

from radcons.errors import InputError
from radcons.numerics.valid_pixels import clipped_mask
from radcons.results import Association, ObjectAssociation, ObjectFit
from radcons.stages.refine.background import added_noise_sigma, histogram_mapping, noise_aware_histogram_mapping
from radcons.stages.refine.light import light_spread, local_light_correction
from radcons.stages.refine.line_fits import fit_moments, fit_object
from radcons.stages.refine.params import RefineParams

__all__ = [
    "RefineParams", "fit_object", "fit_moments", "histogram_mapping", "object_agreement", "sample_bilinear",
    "background_mapping", "refine_target",
]

#: "dense" points stay this many pixels inside the target object's border.
_DENSE_MARGIN = 2


def sample_bilinear(image: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Bilinear grey values of ``image`` at points ``(x, y)``; NaN outside or on NaN pixels."""
    if len(xy) == 0:
        return np.zeros(0, np.float64)
    coords = np.vstack([xy[:, 1], xy[:, 0]]).astype(np.float64)
    return scipy.ndimage.map_coordinates(image, coords, output=np.float64, order=1, mode="constant", cval=np.nan)


def _feather(mask: np.ndarray, width: float, at_border: tuple[bool, bool, bool, bool]) -> np.ndarray:
    """Blend weight inside ``mask``: ``min(distance to the outside / width, 1)``.

    ``mask`` is the object within its bounding box; ``at_border`` says which sides of the
    box (top, bottom, left, right) lie on the image border, where the object continues
    out of the image rather than ending, so no feathering happens there.
    """
    if width == 0:
        return mask.astype(np.float32)
    padded = np.pad(mask, 1).astype(np.uint8)
    top, bottom, left, right = at_border
    if top:
        padded[0] = padded[1]
    if bottom:
        padded[-1] = padded[-2]
    if left:
        padded[:, 0] = padded[:, 1]
    if right:
        padded[:, -1] = padded[:, -2]
    distance = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)[1:-1, 1:-1]
    return np.minimum(distance / np.float32(width), np.float32(1.0))


def _dense_points(obj: ObjectAssociation, labels_tgt: np.ndarray, box: tuple[slice, slice],
                  params: RefineParams) -> tuple[np.ndarray, np.ndarray]:
    """Target object pixels (eroded) and the reference points D̄m to their right."""
    mask = (labels_tgt[box] == obj.tgt_id).astype(np.uint8)
    size = 2 * _DENSE_MARGIN + 1
    mask = cv2.erode(mask, np.ones((size, size), np.uint8), borderType=cv2.BORDER_CONSTANT, borderValue=0)
    rows, cols = np.nonzero(mask)
    step = max(1, -(-rows.size // params.dense_max_points))
    tgt_xy = np.c_[cols[::step] + box[1].start, rows[::step] + box[0].start].astype(np.float32)
    ref_xy = tgt_xy + np.array([obj.modal_disparity, 0.0], np.float32)
    return tgt_xy, ref_xy


def _fit(obj: ObjectAssociation, images: tuple[np.ndarray, np.ndarray], clipped: tuple[np.ndarray, np.ndarray],
         tgt_xy: np.ndarray, ref_xy: np.ndarray, params: RefineParams) -> ObjectFit:
    """Fit one object's line on its points that are valid and unclipped in both images."""
    reference, target = images
    x = sample_bilinear(target, tgt_xy)
    y = sample_bilinear(reference, ref_xy)
    keep = np.isfinite(x) & np.isfinite(y)
    x, y, tgt_xy, ref_xy = x[keep], y[keep], tgt_xy[keep], ref_xy[keep]
    # a point whose bilinear support touches a clipped pixel is clipped
    on_clip = (sample_bilinear(clipped[1], tgt_xy) > 0) | (sample_bilinear(clipped[0], ref_xy) > 0)
    n_clipped = int(on_clip.sum())

    def kept(note: str) -> ObjectFit:
        return ObjectFit(obj.ref_id, obj.tgt_id, 1.0, 0.0, x, y, np.ones_like(x), False, n_clipped, note)

    if obj.tgt_id == 0:
        return kept("no target object")
    if x.size < params.min_points:
        return kept(f"too few points ({x.size}, min_points {params.min_points})")
    if n_clipped > params.max_clipped * x.size:
        note = f"offset only: {n_clipped} of {x.size} points on clipped pixels"
        return ObjectFit(obj.ref_id, obj.tgt_id, 1.0, float(y.mean() - x.mean()), x, y, np.ones_like(x), True, n_clipped, note)
    x, y = x[~on_clip], y[~on_clip]
    if x.size < params.min_points:
        return kept(f"too few unclipped points ({x.size}, min_points {params.min_points})")
    gain, offset, weights = (fit_moments if params.fit == "moments" else fit_object)(x, y)
    low, high = params.gain_range
    note = "" if low <= gain <= high else f"gain outside gain_range {low:g}-{high:g}"
    return ObjectFit(obj.ref_id, obj.tgt_id, gain, offset, x, y, weights, not note, n_clipped, note)


def object_agreement(reference: np.ndarray, target: np.ndarray, mask: np.ndarray, box: tuple[slice, slice],
                     disparity: float) -> float:
    """Mean ``|reference(x + d, y) - target(x, y)|`` over an object's target pixels.

    ``mask`` is the object inside its bounding ``box``; ``d`` its modal disparity D̄m,
    rounded to a pixel. Pixels whose partner falls outside the image or on NaN are left
    out; NaN when none is left.
    """
    rows, cols = np.nonzero(mask)
    rows, cols = rows + box[0].start, cols + box[1].start
    partner = cols + int(round(disparity))
    inside = (partner >= 0) & (partner < reference.shape[1])
    difference = np.abs(reference[rows[inside], partner[inside]] - target[rows[inside], cols[inside]])
    difference = difference[np.isfinite(difference)]
    return float(difference.mean()) if difference.size else float("nan")


def _checked(
    reference: np.ndarray,
    target: np.ndarray,
    labels_tgt: np.ndarray,
    association: Association,
    clipped: tuple[np.ndarray, np.ndarray] | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray], list]:
    """The inputs of :func:`refine_target` as float32, the clipped masks and the label boxes.

    Raises
    ------
    InputError
        Shapes that do not agree, or label ids the association names but the labels lack.
    """
    reference = np.asarray(reference, np.float32)
    target = np.asarray(target, np.float32)
    labels_tgt = np.asarray(labels_tgt)
    if reference.ndim != 2 or target.ndim != 2:
        raise InputError("reference and target must be single-band 2-D images")
    if labels_tgt.shape != target.shape:
        raise InputError(f"target labels {labels_tgt.shape} differ in shape from the target {target.shape}")
    if clipped is None:
        clipped = (clipped_mask(reference), clipped_mask(target))
    if clipped[0].shape != reference.shape or clipped[1].shape != target.shape:
        raise InputError(
            f"clipped masks {clipped[0].shape} and {clipped[1].shape} differ in shape from the images "
            f"{reference.shape} and {target.shape}"
        )
    clipped = (clipped[0].astype(np.float32), clipped[1].astype(np.float32))
    boxes = scipy.ndimage.find_objects(labels_tgt.astype(np.int32, copy=False))
    for obj in association.objects:
        if obj.tgt_id > len(boxes) or (obj.tgt_id > 0 and boxes[obj.tgt_id - 1] is None):
            raise InputError(f"the association names target object {obj.tgt_id}, absent from the labels")
    return reference, target, labels_tgt, clipped, boxes


def _one_fit_per_object(fits: list[ObjectFit]) -> dict[int, int]:
    """Target object id -> index of the applied fit with the most points; the others are marked not applied."""
    chosen: dict[int, int] = {}
    for i, fit in enumerate(fits):
        if fit.applied and (fit.tgt_id not in chosen or fit.n_points > fits[chosen[fit.tgt_id]].n_points):
            chosen[fit.tgt_id] = i
    for i, fit in enumerate(fits):
        if fit.applied and chosen[fit.tgt_id] != i:
            note = f"reference object {fits[chosen[fit.tgt_id]].ref_id} fits the same target object on more points"
            fits[i] = dataclasses.replace(fit, applied=False, note=note)
    return chosen


def background_mapping(reference: np.ndarray, target: np.ndarray, params: RefineParams) -> tuple[np.ndarray, dict[str, Any]]:
    """The target outside the applied objects as ``params.background`` names it, and what was done.

    With ``"local"``, the tile-wise light correction is applied to the whole-image mapping
    only when it moves the target by at least ``params.local_min_light``
    (:func:`radcons.stages.refine.light.light_spread`): a smaller one follows content
    that differs between tiles, not light.

    Returns
    -------
    mapped : ndarray, float32
    done : dict
        ``background`` (the name), and with ``"local"`` the ``light_spread`` measured and
        whether the correction was ``light_applied``.
    """
    done: dict[str, Any] = {"background": params.background}
    if params.background == "global":
        return target.copy(), done
    if params.background_noise:
        mapped = noise_aware_histogram_mapping(reference, target, added_noise_sigma(reference, target))
    else:
        mapped = histogram_mapping(reference, target, params.background_smoothing)
    if params.background == "local" and reference.shape == target.shape:  # tiles need one frame
        corrected = local_light_correction(reference, mapped, params.local_tiles)
        spread = light_spread(reference, mapped, corrected)
        done.update(light_spread=spread, light_applied=spread >= params.local_min_light)
        if done["light_applied"]:
            return corrected, done
    return mapped, done


def _apply_fits(
    refined: np.ndarray,
    images: tuple[np.ndarray, np.ndarray],
    labels_tgt: np.ndarray,
    boxes: list,
    association: Association,
    fits: list[ObjectFit],
    chosen: dict[int, int],
    params: RefineParams,
) -> None:
    """Blend each chosen object's line into ``refined`` (feathered), unless the agreement gate refuses it."""
    reference, target = images
    for tgt_id, i in list(chosen.items()):
        box = boxes[tgt_id - 1]
        mask = labels_tgt[box] == tgt_id
        if params.agreement_gate:
            disparity = association.objects[i].modal_disparity
            with_fit = object_agreement(reference, np.float32(fits[i].gain) * target + np.float32(fits[i].offset), mask, box, disparity)
            without = object_agreement(reference, refined, mask, box, disparity)
            if not with_fit < without:
                note = f"kept the background mapping: the line does not raise the agreement ({with_fit:.3g} vs {without:.3g})"
                fits[i] = dataclasses.replace(fits[i], applied=False, note=note)
                del chosen[tgt_id]
                continue
        at_border = (box[0].start == 0, box[0].stop == target.shape[0], box[1].start == 0, box[1].stop == target.shape[1])
        weight = _feather(mask, params.blend_width, at_border)
        region = refined[box]
        corrected = np.float32(fits[i].gain) * target[box] + np.float32(fits[i].offset)
        region += weight * (corrected - region)


def refine_target(
    reference: np.ndarray,
    target: np.ndarray,
    labels_tgt: np.ndarray,
    association: Association,
    params: RefineParams = RefineParams(),
    clipped: tuple[np.ndarray, np.ndarray] | None = None,
    background: np.ndarray | None = None,
) -> tuple[np.ndarray, tuple[ObjectFit, ...]]:
    """Map each associated target object through its fitted line (eq 7-12), feathered.

    Parameters
    ----------
    reference, target : ndarray
        The globally normalised images (NaN where invalid); grey values are sampled from
        them at the invariant points.
    labels_tgt : ndarray of int
        Target object labels (the ones the association refers to).
    association : Association
        From :func:`radcons.stages.association.run.associate_objects`.
    params : RefineParams
    clipped : (ndarray, ndarray) of bool, optional
        The reference's and the target's clipped pixels (:func:`clipped_mask` of the
        images as read: a stage before may have spread a clipping level over several
        grey values). Default: found in ``reference`` and ``target``.
    background : ndarray, optional
        The target's background mapping (``params.background``) computed by the caller,
        for a window of a larger scene mapped with the scene's own grey-level counts.
        Default: computed here from ``reference`` and ``target``.

    Returns
    -------
    refined : ndarray, float32
        The target with every applied object corrected, the rest as ``params.background``
        says; NaN kept.
    fits : tuple of ObjectFit
        One per association, in the association's order.

    Raises
    ------
    InputError
        Shapes that do not agree, or label ids the association names but the labels lack.
    """
    reference, target, labels_tgt, clipped, boxes = _checked(reference, target, labels_tgt, association, clipped)
    fits = []
    for obj in association.objects:
        if params.points == "dense" and obj.tgt_id > 0:
            tgt_xy, ref_xy = _dense_points(obj, labels_tgt, boxes[obj.tgt_id - 1], params)
        else:
            tgt_xy = association.matches.tgt_xy[obj.invariant_indices]
            ref_xy = association.matches.ref_xy[obj.invariant_indices]
        fits.append(_fit(obj, (reference, target), clipped, tgt_xy, ref_xy, params))
    chosen = _one_fit_per_object(fits)
    if background is None:
        refined, _ = background_mapping(reference, target, params)
    elif np.shape(background) != target.shape:
        raise InputError(f"background {np.shape(background)} differs in shape from the target {target.shape}")
    else:
        refined = np.array(background, np.float32)
    _apply_fits(refined, (reference, target), labels_tgt, boxes, association, fits, chosen, params)
    if params.clip_to_reference and np.isfinite(reference).any():
        np.clip(refined, np.nanmin(reference), np.nanmax(reference), out=refined)
    return refined, tuple(fits)
