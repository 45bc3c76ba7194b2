"""Where things live in a recording, and the default blueprint that shows them.

Entity tree (``<m>`` a compared method)::

    pair                              annotation context of the object classes
    pair/reference/pixels             the reference raster (scaled [f, f] for previews)
    pair/reference/pixels/image       grey image of the stage on the ``stage`` timeline
    pair/reference/pixels/stage       the stage's name, over the top of the image
    pair/reference/pixels/objects     SegmentationImage of the objects
    pair/reference/pixels/nodata      invalid input pixels (only when there are some)
    pair/reference/keypoints          reference ends of the SIFT matches
    pair/target                       translated [W + gap, 0]: beside the reference
    pair/target/...                   as the reference; objects take their partner's class
    pair/matches/other                lines joining matches outside the invariant points
    pair/matches/invariant            lines joining the invariant points (eq 12)
    fits/plot/points                  invariant points: target grey (x), reference grey (y)
    fits/plot/lines                   the fitted line of eq 8 of each object
    fits/plot/identity                y = x, for reference
    disparity/truth                   ground-truth disparity (+ ``status``: unknown)
    disparity/<m>/map                 the method's dense disparity (+ ``status``: failed)
    disparity/<m>/error               |d - d_gt| (+ ``status``: failed, unknown truth)
    disparity/stage/map               dense disparity of the stage under the cursor (+ label)
    disparity/stage/error             its |d - d_gt| (see :mod:`radcons.record.stage_review`)
    metrics/stage/rate_*              correct-matching rates over the ``stage`` timeline
    metrics/similarity/<m>            eq 20 similarity per object (bar chart over ids)
    metrics/matching_rate/<m>         correct-matching rate per object (bar chart over ids)
    metrics/tuning/quality/...        mean similarity and matching rate per tuning step
    metrics/tuning/seconds/<stage>    stage timings per tuning step
    summary                           markdown: parameters, timings, per-object table

Timelines: ``stage`` (sequence, the index of the stage in
:data:`radcons.pipeline.IMAGE_STAGES`) steps through the stages: the grey images and their
stage label change, everything else is logged at stage 0 and stays. ``tuning_step``
(sequence) is added when a run is logged as one of several parameter settings; the
``metrics/tuning`` curves live on it alone.

Both the side-by-side views and the stage scrubbing come from logging every stage's image
at the same entity (``pair/reference/pixels/image``): the reference and target views show
the stage under the time cursor, and moving the cursor steps through the stages.
"""

from __future__ import annotations

from collections.abc import Sequence

import rerun as rr
import rerun.blueprint as rrb

__all__ = [
    "method_path",
    "STAGE_TIMELINE",
    "TUNING_TIMELINE",
    "IMAGE_SIDES",
    "GAP",
    "ERROR_SPAN",
    "pixels_path",
    "default_blueprint",
]

STAGE_TIMELINE = "stage"
TUNING_TIMELINE = "tuning_step"
IMAGE_SIDES = ("reference", "target")
#: Gap, as a share of the image width, between the reference and the target placed beside it.
GAP = 0.04
#: The colours of an error map |d - d_gt| span 0 to this many times the correct-match threshold.
ERROR_SPAN = 3.0


def method_path(name: str) -> str:
    """Entity path part of a compared method's name (escaped)."""
    return rr.escape_entity_path_part(name)


def pixels_path(side: str) -> str:
    """Entity of the raster of ``side`` ("reference" or "target")."""
    return f"pair/{side}/pixels"


def _image_view(side: str) -> rrb.Spatial2DView:
    return rrb.Spatial2DView(
        origin=f"pair/{side}",
        contents=[f"+ {pixels_path(side)}/{part}" for part in ("image", "stage", "nodata")],
        name=f"{side} (stage under the cursor)",
    )


def _disparity_row(method: str) -> rrb.Horizontal:
    return rrb.Horizontal(
        rrb.Spatial2DView(origin=f"disparity/{method_path(method)}/map", name=f"{method}: disparity"),
        rrb.Spatial2DView(origin="disparity/truth", name="ground truth"),
        rrb.Spatial2DView(origin=f"disparity/{method_path(method)}/error", name=f"{method}: |d - d_gt|"),
        name=method,
    )


def _stage_disparity_view(part: str, name: str) -> rrb.Spatial2DView:
    return rrb.Spatial2DView(origin=f"disparity/stage/{part}", name=name)


def default_blueprint(
    methods: Sequence[str] = (), tuning: bool = False, stage_disparity: bool = False, stage_error: bool = False
) -> rrb.Blueprint:
    """The layout a recording opens with, without any clicking.

    Left, three fifths of the width: the reference and the target of the stage under the
    time cursor side by side, and below them the pair with its objects and matches. Right:
    the disparity review (one tab per method: its disparity, the ground truth, its error;
    magenta marks failed matches, grey unknown ground truth), the per-object similarity and
    matching-rate bar charts, and tabs with the summary, the per-object fits (eq 7-11) and
    the tuning curves.

    Parameters
    ----------
    methods : sequence of str
        Compared methods, one disparity tab each; the tab of ``ours`` (else the last
        method) is the one open. Empty: no disparity review and no bar charts.
    tuning : bool
        The recording holds several parameter settings: the time panel starts on the
        ``tuning_step`` timeline and the tuning curves tab is the one open.
    stage_disparity : bool
        The recording holds each stage's dense disparity: it stands right of the target,
        so the three views step through the stages together.
    stage_error : bool
        ... and each stage's error map (ground truth): it stands right of the pair view,
        and the rates per stage open as the first tab on the right.

    Returns
    -------
    rerun.blueprint.Blueprint
    """
    methods = list(methods)
    top: list[rrb.View] = [_image_view("reference"), _image_view("target")]
    pair: rrb.View | rrb.Horizontal = rrb.Spatial2DView(origin="pair", name="objects and matches (bright: invariant points)")
    if stage_disparity:
        top.append(_stage_disparity_view("map", "disparity (stage under the cursor)"))
    if stage_error:
        pair = rrb.Horizontal(pair, _stage_disparity_view("error", "|d - d_gt| (stage under the cursor)"), column_shares=[2, 1])
    images = rrb.Vertical(rrb.Horizontal(*top), pair)
    fits = rrb.Spatial2DView(origin="fits", name="fits (eq 7-11): reference ↑ vs target →")
    summary = rrb.TextDocumentView(origin="summary", name="summary")
    curves = rrb.Vertical(
        rrb.TimeSeriesView(origin="metrics/tuning/quality", name="mean similarity and matching rate"),
        rrb.TimeSeriesView(origin="metrics/tuning/seconds", name="seconds per stage"),
        name="tuning",
    )
    review: list[rrb.Container | rrb.View] = []
    if methods:
        active = methods.index("ours") if "ours" in methods else len(methods) - 1
        review.append(rrb.Tabs(*[_disparity_row(m) for m in methods], active_tab=active, name="disparity review"))
        review.append(
            rrb.Horizontal(
                rrb.BarChartView(origin="metrics/similarity", name="similarity C per object (eq 20)"),
                rrb.BarChartView(origin="metrics/matching_rate", name="correct-matching rate per object"),
            )
        )
    tabs: list[rrb.View | rrb.Container] = [summary, fits, curves]
    if stage_error:
        tabs.insert(0, rrb.TimeSeriesView(origin="metrics/stage", name="correct-matching rate per stage"))
    review.append(rrb.Tabs(*tabs, active_tab=tabs.index(curves) if tuning else 0))
    layout = rrb.Horizontal(images, rrb.Vertical(*review), column_shares=[3, 2])
    return rrb.Blueprint(
        layout,
        rrb.TimePanel(timeline=TUNING_TIMELINE if tuning else STAGE_TIMELINE, state="collapsed"),
        collapse_panels=True,
    )
