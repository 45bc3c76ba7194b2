"""Logging a finished pipeline run (and its comparison of methods) to a rerun recording.

Nothing is recomputed: the recorder reads the :class:`radcons.pipeline.Run` (stage images,
objects, association, fits, timings, parameters) and the
:class:`radcons.evaluate.compare.Comparison` (disparity maps and per-object measurements),
the same way for a batch run and for the inspector. Only display quantities are derived
(previews, the error map ``|d - d_gt|``, class images).

Grey images are logged as ``DepthImage`` with a grayscale colormap, not as ``Image``: in
rerun 0.41 an ``Image`` of values above 255 is stretched to its own minimum and maximum,
so the reference and the target of a stage would each be stretched differently, hiding
exactly the brightness differences a review is about. Both images of a stage share one
``depth_range`` (see :func:`.raster.display_range`): it starts at 0 and reaches the
brighter image's maximum, so the stage's radiometric (in)consistency shows as it is. The
values stay exact float32 on the input's range (NaN where invalid); the viewer's colormap
and range can still be changed per view.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import rerun as rr

from radcons.errors import InputError
from radcons.evaluate.compare import Comparison, MethodResult
from radcons.pipeline import IMAGE_STAGES, Run
from radcons.record.colors import (
    GREY,
    LEFT_OUT_RGB,
    method_color,
    object_classes,
    object_color,
)
from radcons.record.layout import (
    ERROR_SPAN,
    GAP,
    IMAGE_SIDES,
    STAGE_TIMELINE,
    TUNING_TIMELINE,
    method_path,
    pixels_path,
)
from radcons.record.raster import block_mean, display_range, preview_factor, subsample
from radcons.record.report import final_method, markdown_summary
from radcons.record.stage_review import StageReview, log_stage_review
from radcons.results import Association, ObjectLabels

__all__ = ["log_run"]

#: Classes of the status overlays of the disparity views.
_UNKNOWN, _FAILED = 1, 2
_STATUS_CLASSES = [
    (0, "", (0, 0, 0, 0)),
    (_UNKNOWN, "no ground truth", (128, 128, 128, 255)),
    (_FAILED, "no match (matching failed)", (230, 0, 230, 255)),
]
_LABEL_COLOR = (255, 190, 60)


def log_run(
    run: Run,
    recording: rr.RecordingStream,
    comparison: Comparison | None = None,
    tuning_step: int | None = None,
    *,
    full_resolution: bool = False,
    stage_review: StageReview | None = None,
) -> None:
    """Log a finished run to ``recording`` (layout: :mod:`radcons.record.layout`).

    Parameters
    ----------
    run : Run
        A finished pipeline run; at least its ``original`` images.
    recording : rerun.RecordingStream
        Where to log. Its time cursor is reset when done.
    comparison : Comparison, optional
        Measurements of compared methods on the same pair: their disparity maps, ground
        truth and error maps, per-object similarity (eq 20) and correct-matching rates.
    tuning_step : int, optional
        Index of this parameter setting when several are logged to one recording:
        everything is also placed on the ``tuning_step`` timeline and the mean metrics
        and stage timings are logged as scalars over it.
    full_resolution : bool
        Log images at full resolution even when the longest side exceeds
        :data:`radcons.record.raster.PREVIEW_MAX_SIDE`.
    stage_review : StageReview, optional
        Every image stage's dense disparity (and error map and rates with ground truth),
        logged on the ``stage`` timeline (:mod:`radcons.record.stage_review`).

    Raises
    ------
    InputError
        The run has no original images, a negative tuning step, negative object labels,
        or comparison disparity maps of another shape than the run's images.
    """
    if "original" not in run.results:
        raise InputError("the run holds no images (no 'original' stage)")
    if tuning_step is not None and (
        isinstance(tuning_step, bool) or int(tuning_step) != tuning_step or tuning_step < 0
    ):
        raise InputError(f"tuning_step must be a non-negative integer, got {tuning_step!r}")
    shape = run.images("original")[0].shape  # the working (rectified) geometry
    if comparison is not None:
        for method in comparison.methods:
            if method.disparity.shape != shape:
                raise InputError(
                    f"method {method.name!r}: disparity {method.disparity.shape} differs from the pair's {shape}"
                )
    objects: ObjectLabels | None = run.objects
    if objects is not None and (objects.reference.min(initial=0) < 0 or objects.target.min(initial=0) < 0):
        raise InputError("object labels must be non-negative (0 = background)")

    factor = preview_factor(shape, full_resolution)
    rec = recording
    rec.reset_time()
    try:
        if tuning_step is not None:
            rec.set_time(TUNING_TIMELINE, sequence=int(tuning_step))
            _log_tuning_scalars(rec, run, comparison)
        rec.set_time(STAGE_TIMELINE, sequence=0)
        _log_placement(rec, shape, factor)
        _log_nodata(rec, run, factor)
        if objects is not None:
            _log_objects(rec, run, comparison, factor)
        if run.association is not None:
            _log_matches(rec, run.association, shape)
        _log_fits(rec, run)
        if comparison is not None or stage_review is not None:
            rec.log("disparity", rr.AnnotationContext(_STATUS_CLASSES), static=True)
        if comparison is not None:
            _log_disparity(rec, comparison, run.working_pair.disparity, factor)
            _log_object_metrics(rec, comparison)
        summary = markdown_summary(run, comparison, factor, stage_review)
        rec.log("summary", rr.TextDocument(summary, media_type=rr.MediaType.MARKDOWN))
        _log_stages(rec, run, factor)
        if stage_review is not None:
            log_stage_review(rec, stage_review, factor)
    finally:
        rec.reset_time()


# ----------------------------------------------------------------------------- placement


def _log_placement(rec: rr.RecordingStream, shape: tuple[int, int], factor: int) -> None:
    """Target beside the reference; previews scaled back to full-resolution pixels."""
    rec.log("pair/target", rr.Transform3D(translation=[shape[1] * (1 + GAP), 0.0, 0.0]), static=True)
    if factor > 1:
        for side in IMAGE_SIDES:
            rec.log(pixels_path(side), rr.Transform3D(scale=[factor, factor, 1.0]), static=True)


# ----------------------------------------------------------------------------- stage images


def _log_stages(rec: rr.RecordingStream, run: Run, factor: int) -> None:
    """Both images of every stage at one entity per image, on the ``stage`` timeline."""
    for stage in run.image_stages:
        rec.set_time(STAGE_TIMELINE, sequence=IMAGE_STAGES.index(stage))
        low, high = display_range(list(run.images(stage)))
        enabled = run.results[stage].info.get("enabled", True)
        title = stage if enabled else f"{stage} (switched off)"
        for side, image in zip(IMAGE_SIDES, run.images(stage)):
            preview = block_mean(image, factor)
            rec.log(
                f"{pixels_path(side)}/image",
                rr.DepthImage(preview, colormap="grayscale", depth_range=(low, high)),
            )
            rec.log(
                f"{pixels_path(side)}/stage",
                rr.Points2D(
                    [[preview.shape[1] / 2, preview.shape[0] * 0.04]],
                    radii=0.0,
                    labels=[f"{side} · {title}"],
                    colors=[_LABEL_COLOR],
                    show_labels=True,
                ),
            )


def _log_nodata(rec: rr.RecordingStream, run: Run, factor: int) -> None:
    """Invalid input pixels as an opaque overlay (the grey images show NaN as white)."""
    for side, image in zip(IMAGE_SIDES, run.images("original")):
        invalid = ~np.isfinite(image)
        if not invalid.any():
            continue
        path = f"{pixels_path(side)}/nodata"
        rec.log(path, rr.AnnotationContext([(0, "", (0, 0, 0, 0)), (1, "nodata", (40, 40, 70, 255))]), static=True)
        rec.log(path, rr.SegmentationImage(subsample(invalid, factor).astype(np.uint8), opacity=1.0))


# ----------------------------------------------------------------------------- objects and matches


def _object_notes(run: Run, comparison: Comparison | None) -> dict[int, str]:
    """Reference object id -> its numbers, for the label of its class."""
    notes: dict[int, list[str]] = {}
    if run.association is not None:
        for link in run.association.objects:
            notes.setdefault(int(link.ref_id), []).append(
                f"{link.method}, {link.n_matches} matches, {link.n_invariant} invariant, "
                f"D̄m {link.modal_disparity:.1f} px"
            )
    for fit in run.fits:
        if fit.applied:
            notes.setdefault(int(fit.ref_id), []).append(f"fit y = {fit.gain:.3f} x + {fit.offset:.1f}")
    if comparison is not None:
        final = comparison.method(final_method(comparison))
        names = [m.name for m in comparison.methods]
        first = comparison.method("original") if "original" in names and final.name != "original" else None
        for ref_id, _ in comparison.object_pairs:
            for key, field in (("C", "similarity"), ("rate", "object_rates")):
                value = getattr(final, field).get(ref_id)
                if value is None:
                    continue
                before = getattr(first, field).get(ref_id) if first is not None else None
                change = f"{value:.2f}" if before is None else f"{before:.2f} → {value:.2f}"
                text = f"{key} {change} ({final.name})"
                notes.setdefault(int(ref_id), []).append(text)
    return {ref_id: "· " + " · ".join(parts) for ref_id, parts in notes.items()}


def _log_objects(rec: rr.RecordingStream, run: Run, comparison: Comparison | None, factor: int) -> None:
    """Object labels of both images, one class (colour, label) per associated pair."""
    objects = run.objects
    classes = object_classes(objects, run.association, _object_notes(run, comparison))
    context = [(0, "background", (0, 0, 0, 0))] + [(cid, label, (*color, 255)) for cid, label, color in classes.classes]
    rec.log("pair", rr.AnnotationContext(context))
    for side, labels, lut in (
        ("reference", objects.reference, classes.reference_lut),
        ("target", objects.target, classes.target_lut),
    ):
        rec.log(f"{pixels_path(side)}/objects", rr.SegmentationImage(lut[subsample(labels, factor)], opacity=0.45))
    left_out = getattr(objects, "left_out", None)
    if left_out is not None:
        _log_left_out(rec, left_out, factor)


def _log_left_out(rec: rr.RecordingStream, codes: np.ndarray, factor: int) -> None:
    """The elevated regions the height method's rules left out, one class per rule (its text the label)."""
    from radcons.stages.objects.rules import LEFT_OUT_RULES

    path = f"{pixels_path('reference')}/left_out"
    context = [(0, "", (0, 0, 0, 0))] + [(code, text, (*LEFT_OUT_RGB[code], 255)) for code, text in LEFT_OUT_RULES.items()]
    rec.log(path, rr.AnnotationContext(context))
    rec.log(path, rr.SegmentationImage(subsample(codes, factor), opacity=0.35))


def _log_matches(rec: rr.RecordingStream, association: Association, shape: tuple[int, int]) -> None:
    """SIFT matches as points in each image and lines across; invariant points bright."""
    matches = association.matches
    count = len(matches)
    colors = np.tile(np.array(GREY, np.uint8), (count, 1))
    invariant = np.zeros(count, bool)
    for link in association.objects:
        colors[link.match_indices] = object_color(link.ref_id)
        invariant[link.invariant_indices] = True
    rec.log("pair/reference/keypoints", rr.Points2D(matches.ref_xy, colors=colors, radii=-2.0))
    rec.log("pair/target/keypoints", rr.Points2D(matches.tgt_xy, colors=colors, radii=-2.0))
    target = matches.tgt_xy + np.array([shape[1] * (1 + GAP), 0.0], np.float32)
    strips = np.stack([matches.ref_xy, target], axis=1)
    faded = np.concatenate([colors, np.full((count, 1), 80, np.uint8)], axis=1)
    rec.log("pair/matches/other", rr.LineStrips2D(strips[~invariant], colors=faded[~invariant], radii=-0.4))
    rec.log("pair/matches/invariant", rr.LineStrips2D(strips[invariant], colors=colors[invariant], radii=-1.0))


def _log_fits(rec: rr.RecordingStream, run: Run) -> None:
    """Per-object fits of eq 7-11: invariant points and fitted lines, one colour per object.

    All objects go into one points and one lines entity (each point and line labelled
    with its object), so a later tuning step replaces them all at once.
    """
    fits = [fit for fit in run.fits if fit.n_points > 0]
    if not fits:
        return
    rec.log("fits/plot", rr.Transform3D(scale=[1.0, -1.0, 1.0]), static=True)  # grey values grow upwards
    values = np.concatenate([np.concatenate([fit.x, fit.y]) for fit in fits])
    low, high = float(np.nanmin(values)), float(np.nanmax(values))
    rec.log("fits/plot/identity", rr.LineStrips2D([[[low, low], [high, high]]], colors=[(120, 120, 120)], radii=-0.5))
    colors = [object_color(fit.ref_id) if fit.applied else GREY for fit in fits]
    weights = np.concatenate([np.clip(np.nan_to_num(np.asarray(fit.weights, np.float32)), 0.0, 1.0) for fit in fits])
    rec.log(
        "fits/plot/points",
        rr.Points2D(
            np.concatenate([np.column_stack([fit.x, fit.y]) for fit in fits]),
            colors=np.concatenate([np.tile(np.array(c, np.uint8), (fit.n_points, 1)) for c, fit in zip(colors, fits)]),
            radii=-(1.5 + 2.5 * weights),
            labels=[f"object {fit.ref_id}" for fit in fits for _ in range(fit.n_points)],
            show_labels=False,
        ),
    )
    strips, labels = [], []
    for fit in fits:
        x = np.array([np.nanmin(fit.x), np.nanmax(fit.x)], np.float64)
        strips.append(np.column_stack([x, fit.gain * x + fit.offset]))
        note = "" if fit.applied and not fit.note else f" ({fit.state})"
        labels.append(f"object {fit.ref_id}: y = {fit.gain:.3f} x + {fit.offset:.1f}{note}")
    rec.log("fits/plot/lines", rr.LineStrips2D(strips, colors=colors, radii=-1.0, labels=labels, show_labels=False))


# ----------------------------------------------------------------------------- disparity review


def _status(classes: Sequence[tuple[np.ndarray, int]], shape: tuple[int, int]) -> np.ndarray:
    status = np.zeros(shape, np.uint8)
    for mask, value in classes:
        status[mask] = value
    return status


def _log_disparity(rec: rr.RecordingStream, comparison: Comparison, truth: np.ndarray | None, factor: int) -> None:
    """Each method's disparity, the ground truth and each method's error map."""
    span = tuple(float(v) for v in comparison.disparity_range)
    gt = subsample(truth, factor) if truth is not None else None
    if gt is not None:
        unknown = ~np.isfinite(gt)
        rec.log("disparity/truth", rr.DepthImage(gt, colormap="turbo", depth_range=span))
        rec.log("disparity/truth/status", rr.SegmentationImage(_status([(unknown, _UNKNOWN)], gt.shape), opacity=1.0))
    for method in comparison.methods:
        _log_method_disparity(rec, method, gt, span, comparison.threshold, factor)


def _log_method_disparity(
    rec: rr.RecordingStream,
    method: MethodResult,
    gt: np.ndarray | None,
    span: tuple[float, float],
    threshold: float,
    factor: int,
) -> None:
    path = f"disparity/{method_path(method.name)}"
    disparity = subsample(method.disparity, factor)
    failed = ~np.isfinite(disparity)
    rec.log(f"{path}/map", rr.DepthImage(disparity, colormap="turbo", depth_range=span))
    rec.log(f"{path}/map/status", rr.SegmentationImage(_status([(failed, _FAILED)], disparity.shape), opacity=1.0))
    if gt is None:
        return
    unknown = ~np.isfinite(gt)
    error = np.abs(disparity - gt)
    rec.log(f"{path}/error", rr.DepthImage(error, colormap="viridis", depth_range=(0.0, ERROR_SPAN * threshold)))
    status = _status([(failed & ~unknown, _FAILED), (unknown, _UNKNOWN)], error.shape)
    rec.log(f"{path}/error/status", rr.SegmentationImage(status, opacity=1.0))


# ----------------------------------------------------------------------------- metrics


def _log_object_metrics(rec: rr.RecordingStream, comparison: Comparison) -> None:
    """Per-object similarity and matching rate as bar charts over the reference ids.

    The methods' bars of one object stand side by side around its id.
    """
    ids = sorted(ref_id for ref_id, _ in comparison.object_pairs)
    if not ids:
        return
    count = len(comparison.methods)
    width = 0.8 / count
    fields = [("similarity", "similarity")]
    if comparison.has_ground_truth:
        fields.append(("matching_rate", "object_rates"))
    for index, method in enumerate(comparison.methods):
        offset = -0.4 + width * (index + 0.5)
        for entity, field in fields:
            values = getattr(method, field)
            present = [i for i in ids if values.get(i) is not None and np.isfinite(values[i])]
            if not present:
                continue
            rec.log(
                f"metrics/{entity}/{method_path(method.name)}",
                rr.BarChart(
                    np.array([values[i] for i in present], np.float64),
                    abscissa=np.array(present, np.float64) + offset,
                    widths=np.full(len(present), width, np.float32),
                    color=method_color(method.name, index),
                ),
            )


def _log_tuning_scalars(rec: rr.RecordingStream, run: Run, comparison: Comparison | None) -> None:
    """Mean metrics and stage timings of this setting, on the ``tuning_step`` timeline only."""
    if comparison is not None:
        for index, method in enumerate(comparison.methods):
            color = method_color(method.name, index)
            for key, value in (("similarity", method.mean_similarity), ("matching_rate", method.correct_rate)):
                if value is None or not np.isfinite(value):
                    continue
                path = f"metrics/tuning/quality/{key}/{method_path(method.name)}"
                rec.log(path, rr.SeriesLines(colors=[color], names=[f"{key} {method.name}"]), static=True)
                rec.log(path, rr.Scalars([float(value)]))
    for stage, seconds in run.timings.items():
        rec.log(f"metrics/tuning/seconds/{method_path(stage)}", rr.Scalars([float(seconds)]))
