"""Disparity review of every image stage of a run: each stage's pair matched densely.

A recording of ``radcons process`` shows, on the ``stage`` timeline, how the images change
from stage to stage; this module adds what that change does to dense matching. Every image
stage's reference and target are matched by one matcher (:data:`MATCHERS`) over one
disparity range for all stages, so that only the images differ between stages: the ground
truth's range (2 px margin) when the pair has one, else the range of the association's SIFT
matches (those of the original images, matched again when the run stopped before the
association). Where the pair has ground truth, each stage's error map ``|d - d_gt|`` and
correct-matching rates (all pixels with truth, and the mean over the objects) come with it.

Logged entities (``stage`` timeline, the stage's index in :data:`IMAGE_STAGES`)::

    disparity/stage/map            the stage's dense disparity (+ ``status``: failed)
    disparity/stage/map/label      the stage, the matcher and its rates over the map's top
    disparity/stage/error          |d - d_gt| (+ ``status``: failed, unknown truth)
    metrics/stage/rate_all         correct-matching rate over all pixels with truth
    metrics/stage/rate_objects     its mean over the objects
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import rerun as rr

from radcons.errors import InputError, RadconsError, StageError
from radcons.evaluate.matching import (
    MatcherParams,
    dense_disparity,
    matcher_name,
)
from radcons.evaluate.measure import as_written
from radcons.evaluate.rates import correct_matching_rate, object_matching_rates
from radcons.evaluate.search_range import inlier_disparities, search_range
from radcons.numerics.census import CensusParams
from radcons.pipeline import IMAGE_STAGES, Run
from radcons.record.layout import ERROR_SPAN, STAGE_TIMELINE
from radcons.record.raster import subsample

__all__ = ["StageDisparity", "StageReview", "review_stages", "log_stage_review"]

#: Classes of the status overlays (the values of :mod:`radcons.record.log`'s context).
_UNKNOWN, _FAILED = 1, 2
_LABEL_COLOR = (255, 190, 60)


@dataclass(frozen=True)
class StageDisparity:
    """One image stage's dense disparity and, with ground truth, its rates.

    Attributes
    ----------
    stage : str
    disparity : ndarray
        float32, NaN where matching failed.
    rate_all : float or None
        Correct-matching rate over every pixel with ground truth; None without truth.
    rate_objects : float or None
        Mean of the per-object rates; None without truth or objects.
    """

    stage: str
    disparity: np.ndarray = field(repr=False)
    rate_all: float | None
    rate_objects: float | None


@dataclass(frozen=True)
class StageReview:
    """Every image stage of a run matched with one matcher over one range.

    Attributes
    ----------
    matcher : str
        The matcher's name.
    disparity_range : (float, float) or None
        The range searched; None when none could be found (``note`` says why).
    stages : tuple of StageDisparity
    truth : ndarray or None
        The pair's ground-truth disparity (reference frame).
    threshold : float
        Error below which a match is correct, in pixels.
    seconds : float
        Time spent matching and measuring.
    note : str
        Why there is no stage disparity, when there is none.
    """

    matcher: str
    disparity_range: tuple[float, float] | None
    stages: tuple[StageDisparity, ...]
    truth: np.ndarray | None = field(repr=False)
    threshold: float
    seconds: float
    note: str = ""


def _search_range(run: Run) -> tuple[float, float]:
    """The pair's own disparity range (:func:`radcons.evaluate.search_range.search_range`),
    from SIFT matches made here when the run stopped before the association.

    Raises
    ------
    InputError
        No ground truth, no rectification range and no SIFT match to take a range from.
    """
    if run.working_pair.disparity is not None or getattr(run.rectification, "disparity_range", None) is not None:
        return search_range(run)[0]
    if run.association is not None:
        disparities = run.association.matches.disparity
    else:
        from radcons.stages.association.run import match_features

        disparities = match_features(*run.images("original"), run.params.association).disparity
    if inlier_disparities(disparities).size == 0:
        raise InputError("no disparity range to search: no ground truth, no rectification range, no SIFT match")
    return search_range(run, disparities)[0]


def _object_labels(run: Run) -> np.ndarray | None:
    """Reference object labels: the pair's own (ground truth), else the run's segmentation."""
    labels = run.working_pair.reference_objects
    if labels is None and run.objects is not None:
        labels = run.objects.reference
    return labels


def review_stages(run: Run, matcher: MatcherParams | CensusParams, threshold: float = 1.0) -> StageReview:
    """Match every image stage's pair of ``run`` and measure it against the ground truth.

    Parameters
    ----------
    run : Run
        A finished pipeline run.
    matcher : MatcherParams or CensusParams
        The dense matcher of every stage.
    threshold : float
        Correct-match threshold in pixels.

    Returns
    -------
    StageReview
        Without stages (and with a ``note``) when no disparity range can be found: no
        ground truth and too few SIFT matches.

    Raises
    ------
    RadconsError
        The matcher fails on a stage (e.g. a range too wide for census' memory); a
        StageError of Pandora names the pair and the stage.
    """
    name = matcher_name(matcher)
    truth = run.working_pair.disparity
    start = time.perf_counter()
    try:
        search = _search_range(run)
    except RadconsError as error:
        return StageReview(name, None, (), truth, threshold, 0.0, f"no stage disparity: {error}")
    labels = _object_labels(run) if truth is not None else None
    stages = []
    for stage in run.image_stages:
        try:
            disparity = dense_disparity(*as_written(run.working_pair, *run.images(stage)), matcher, search)
        except StageError as error:  # Pandora's failure: name the pair and the stage
            raise StageError(f"pair {run.pair.name}, stage {stage}: {error}") from error
        rate_all = rate_objects = None
        if truth is not None:
            rate_all = correct_matching_rate(disparity, truth, threshold=threshold)
            if labels is not None and labels.max(initial=0) > 0:
                rates = [v for v in object_matching_rates(disparity, truth, labels, threshold).values() if math.isfinite(v)]
                rate_objects = float(np.mean(rates)) if rates else None
        stages.append(StageDisparity(stage, disparity, rate_all, rate_objects))
    return StageReview(name, search, tuple(stages), truth, threshold, time.perf_counter() - start)


def _rate_text(value: float | None) -> str:
    return "-" if value is None else f"{value:.3f}"


def log_stage_review(rec: rr.RecordingStream, review: StageReview, factor: int) -> None:
    """Log each stage's disparity (and error map, rates) at its place on the ``stage`` timeline.

    Parameters
    ----------
    rec : rerun.RecordingStream
    review : StageReview
    factor : int
        Preview reduction (every ``factor``-th pixel), as for the grey images.
    """
    if review.disparity_range is None:
        rec.log("disparity/stage/note", rr.TextLog(review.note, level=rr.TextLogLevel.WARN), static=True)
        return
    span = review.disparity_range
    if review.truth is not None:
        for key, name in (("rate_all", "all pixels"), ("rate_objects", "mean over objects")):
            rec.log(f"metrics/stage/{key}", rr.SeriesLines(names=[f"{review.matcher}: {name}"]), static=True)
    gt = subsample(review.truth, factor) if review.truth is not None else None
    for item in review.stages:
        rec.set_time(STAGE_TIMELINE, sequence=IMAGE_STAGES.index(item.stage))
        disparity = subsample(item.disparity, factor)
        failed = ~np.isfinite(disparity)
        rec.log("disparity/stage/map", rr.DepthImage(disparity, colormap="turbo", depth_range=span))
        rec.log("disparity/stage/map/status", rr.SegmentationImage(_status(failed, None), opacity=1.0))
        text = f"{item.stage} · {review.matcher}"
        if gt is not None:
            text += f" · rate {_rate_text(item.rate_all)} all, {_rate_text(item.rate_objects)} objects"
        rec.log(
            "disparity/stage/map/label",
            rr.Points2D(
                [[disparity.shape[1] / 2, disparity.shape[0] * 0.04]],
                radii=0.0,
                labels=[text],
                colors=[_LABEL_COLOR],
                show_labels=True,
            ),
        )
        if gt is None:
            continue
        unknown = ~np.isfinite(gt)
        error = np.abs(disparity - gt)
        rec.log("disparity/stage/error", rr.DepthImage(error, colormap="viridis", depth_range=(0.0, ERROR_SPAN * review.threshold)))
        rec.log("disparity/stage/error/status", rr.SegmentationImage(_status(failed & ~unknown, unknown), opacity=1.0))
        for key, value in (("rate_all", item.rate_all), ("rate_objects", item.rate_objects)):
            if value is not None and math.isfinite(value):
                rec.log(f"metrics/stage/{key}", rr.Scalars([float(value)]))


def _status(failed: np.ndarray, unknown: np.ndarray | None) -> np.ndarray:
    status = np.zeros(failed.shape, np.uint8)
    status[failed] = _FAILED
    if unknown is not None:
        status[unknown] = _UNKNOWN
    return status
