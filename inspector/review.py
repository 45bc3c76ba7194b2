"""Disparity review: dense matching of the shown stage, compared with the original and baselines.

All measurements come from :func:`radcons.evaluate.compare.evaluate_methods` (eq 20
similarity per object, dense disparity, correct-matching rate overall and per object), one
method at a time so that a review can stop between two when tuning needs the processor.
The dense matcher is a choice (:data:`radcons.evaluate.matching.MATCHERS`: OpenCV SGBM or
census + SGM by CNES Pandora). The original pair and the baselines do not depend on the
stage parameters, so each is measured once per work pair, object association and matcher
and kept in the session cache; each new run measures only the stage on screen.

Every method is matched over the pair's own disparity range (:func:`search_range`): the
ground truth's, else the range the rectification found, else that of the association's
SIFT matches without their outliers, widened by a margin. Without ground truth the methods
are compared on the share of the reference that the matcher matches and that the target's
own disparity confirms (:class:`Consistency`), overall and per associated object. The
shown stage's reference pixels are also sorted by cause (matched, left-right rejected, at
the range's edge, no match, nodata: :mod:`radcons.evaluate.validity`), with or without
ground truth and whatever the matcher.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Callable, MutableMapping, Sequence

import numpy as np

from inspector.objects import number_text
from radcons.evaluate.search_range import RANGE_MARGIN, inlier_disparities, search_range
from radcons.io import Pair

__all__ = [
    "MATCHER_TITLES",
    "RANGE_MARGIN",
    "Consistency",
    "Review",
    "object_pairs",
    "labelled_pair",
    "search_range",
    "inlier_disparities",
    "resolve_view",
    "view_images",
    "review_run",
    "objects_consistency",
    "causes_markdown",
    "OBJECT_ROWS",
    "review_markdown",
    "matchers_markdown",
]

#: How the review names each matcher.
MATCHER_TITLES = {"sgbm": "OpenCV SGBM", "census": "census + SGM, CNES Pandora"}

@dataclass(frozen=True)
class Consistency:
    """How much of the reference one method's pair lets the matcher match (no ground truth).

    Attributes
    ----------
    matched : float
        Share of the pair's overlap (pixels valid in both images) with a disparity.
    consistent : float
        Share of the overlap whose disparity the target's own disparity confirms within
        1 px (:func:`radcons.evaluate.matching.left_right_shares`).
    """

    matched: float
    consistent: float

    @classmethod
    def of(cls, causes: Any, reference: np.ndarray, target: np.ndarray) -> Consistency:
        """The shares of a :class:`radcons.evaluate.validity.MatchCauses` of the pair
        ``reference``, ``target`` (those of :func:`radcons.evaluate.matching.left_right_shares`,
        without matching again)."""
        from radcons.evaluate.validity import NO_MATCH
        from radcons.numerics.valid_pixels import overlap_share

        return cls(
            overlap_share(causes.codes != NO_MATCH, reference, target),
            overlap_share(causes.consistent, reference, target),
        )


@dataclass(frozen=True)
class Review:
    """Measurements of the shown images next to the original pair and the baselines.

    Attributes
    ----------
    stage : str
        The view that was measured (an image stage or ``"baseline:<name>"``).
    current : radcons.evaluate.compare.MethodResult
        Its measurements (similarity per object, disparity, rates).
    others : tuple of MethodResult
        The original pair's and each baseline's.
    disparity_range : (float, float)
        Disparity range searched by every method.
    truth : ndarray or None
        Ground-truth disparity of the work pair.
    matcher : str
        Name of the dense matcher of every method (a key of ``MATCHERS``).
    range_source : str
        Where :attr:`disparity_range` came from (:func:`search_range`).
    consistency : dict
        Method name -> its :class:`Consistency`; empty with ground truth.
    causes : radcons.evaluate.validity.MatchCauses or None
        The cause of each reference pixel of the shown stage's match.
    object_consistency : dict
        ``(ref_id, tgt_id)`` -> left-right consistent share of the shown stage's valid
        reference pixels of that associated object; empty with ground truth.
    """

    stage: str
    current: Any
    others: tuple[Any, ...]
    disparity_range: tuple[float, float]
    truth: np.ndarray | None
    matcher: str = "sgbm"
    range_source: str = ""
    consistency: dict[str, Consistency] = field(default_factory=dict)
    causes: Any = None
    object_consistency: dict[tuple[int, int], float] = field(default_factory=dict)

    @property
    def original(self) -> Any:
        """The original pair's measurements."""
        return next(m for m in self.others if m.name == "original")


def object_pairs(run: Any) -> tuple[tuple[int, int], ...]:
    """The associated ``(ref_id, tgt_id)`` object pairs of a run."""
    if run.association is None:
        return ()
    return tuple((int(o.ref_id), int(o.tgt_id)) for o in run.association.objects)


def labelled_pair(run: Any) -> Pair:
    """The pair the run's stages worked on (rectified if needed), with the run's object
    labels (segmented or given)."""
    if run.objects is None:
        return run.working_pair
    return replace(run.working_pair, reference_objects=run.objects.reference, target_objects=run.objects.target)


def resolve_view(run: Any, view: str) -> str:
    """The view that can be shown: ``view``, or the run's last stage when ``view`` is a
    stage the run did not reach."""
    return view if view.startswith("baseline:") or view in run.results else run.final_stage


def view_images(run: Any, view: str, cache: MutableMapping[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """The ``(reference, target)`` float images of a view: an image stage or a baseline.

    Baselines (``"baseline:<name>"``) run on the original images once per work pair and
    are kept in ``cache``. A stage the run did not reach falls back to its last stage.
    """
    view = resolve_view(run, view)
    if not view.startswith("baseline:"):
        return run.images(view)
    name = view.split(":", 1)[1]
    key = f"baseline:{name}"
    if key not in cache:
        from radcons.baselines import BASELINES

        reference, target = run.images("original")
        cache[key] = (reference, BASELINES[name](reference, target))
    return cache[key]


def review_run(
    run: Any,
    view: str,
    cache: MutableMapping[str, Any],
    baselines: Sequence[str] = (),
    should_stop: Callable[[], bool] = lambda: False,
    matcher: str = "sgbm",
) -> Review | None:
    """Measure the view of a run, and (once per pair, cached) the original and baselines.

    Parameters
    ----------
    run : radcons.pipeline.Run
    view : str
        Image stage or ``"baseline:<name>"`` shown.
    cache : mutable mapping
        Per-work-pair cache (:attr:`inspector.state.Session.cache`).
    baselines : sequence of str
        Baselines to compare with.
    should_stop : callable
        Asked before each method is measured; when it returns True the review stops
        (what was measured stays in ``cache``).
    matcher : str
        The dense matcher, a key of :data:`radcons.evaluate.matching.MATCHERS`, with its
        default parameters.

    Returns
    -------
    Review or None
        None when stopped. Every method is matched over :func:`search_range`; without
        ground truth each is also matched on its mirrored pair, for its
        :class:`Consistency` and the causes of its pixels (with ground truth, only the
        shown stage is, for its causes).

    Raises
    ------
    radcons.errors.ParamsError
        An unknown matcher.
    """
    from radcons.evaluate.compare import evaluate_methods
    from radcons.evaluate.matching import matcher_params
    from radcons.evaluate.measure import as_written
    from radcons.evaluate.validity import match_causes

    params = matcher_params(matcher)
    view = resolve_view(run, view)
    pair = labelled_pair(run)
    pairs = object_pairs(run)
    search, source = search_range(run)
    has_truth = pair.disparity is not None

    def written(name: str) -> tuple[Any, Any]:
        images = view_images(run, name, cache)
        return images if name.startswith("baseline:") else as_written(pair, *images)

    def causes_of(name: str, result: Any) -> Any:
        images = written(name)
        return match_causes(images[0], images[1], result.disparity, params, search)

    def measure(name: str) -> tuple[Any, Consistency | None, Any]:
        images = written(name)
        result = evaluate_methods(pair, {name: images}, pairs, params, disparity_range=search).methods[0]
        if has_truth and name != view:
            return result, None, None
        causes = causes_of(name, result)
        return result, None if has_truth else Consistency.of(causes, *images), causes

    measured: dict[str, tuple[Any, Consistency | None, Any]] = {}
    for name in ("original", *(f"baseline:{b}" for b in baselines)):
        if should_stop():
            return None
        key = method_key(matcher, name, pairs, search)
        if key not in cache:
            cache[key] = measure(name)
        elif name == view and cache[key][2] is None:
            cache[key] = (*cache[key][:2], causes_of(name, cache[key][0]))
        measured[name] = cache[key]
    if should_stop():
        return None
    others = tuple(result for result, _, _ in measured.values())
    if view not in measured:
        measured[view] = measure(view)
        cache[f"shown:{matcher}"] = (run, *measured[view])
    consistency = {name: shares for name, (_, shares, _) in measured.items() if shares is not None}
    current, _, causes = measured[view]
    per_object = {} if has_truth else objects_consistency(pair, pairs, causes)
    return Review(view, current, others, search, pair.disparity, matcher, source, consistency, causes, per_object)


def objects_consistency(pair: Pair, pairs: Sequence[tuple[int, int]], causes: Any) -> dict[tuple[int, int], float]:
    """``(ref_id, tgt_id)`` -> the left-right consistent share of the object's valid
    reference pixels (:func:`radcons.evaluate.validity.object_consistency`); empty
    without object labels."""
    from radcons.evaluate.validity import NODATA, object_consistency

    if pair.reference_objects is None or not pairs:
        return {}
    valid = causes.codes != NODATA
    shares = object_consistency(causes.consistent, valid, pair.reference_objects, (ref for ref, _ in pairs))
    return {(ref, tgt): shares[ref] for ref, tgt in pairs}


def method_key(matcher: str, name: str, pairs: Any, search: tuple[float, float]) -> str:
    """The cache key of one method's measurements with one matcher."""
    return f"method:{matcher}:{name}:{pairs}:{search}"


def review_markdown(review: Review) -> str:
    """The review as a markdown table: one row per method, the shown stage first.

    Parameters
    ----------
    review : Review

    Returns
    -------
    str
        The disparity range searched and where it came from; correct-matching rates
        (overall and mean per object) when the pair has a ground-truth disparity, else
        the shares matched and left-right consistent; and the mean eq 20 similarity.
    """
    has_truth = review.truth is not None
    low, high = review.disparity_range
    source = f" ({review.range_source})" if review.range_source else ""
    lines = [
        f"Dense matching ({MATCHER_TITLES.get(review.matcher, review.matcher)}) of **{review.stage}**, "
        f"disparities {low:.0f} .. {high:.0f} px{source}.",
        "",
        "| method | correct rate | mean object rate | mean C (eq 20) |" if has_truth
        else "| method | left-right consistent | matched | mean C (eq 20) |",
        "|---|---:|---:|---:|",
    ]
    methods = [review.current] + [m for m in review.others if m.name != review.current.name]
    for method in methods:
        name = f"**{method.name}** (shown)" if method is review.current else method.name
        if has_truth:
            cells = (method.correct_rate, method.mean_object_rate)
        else:
            shares = review.consistency.get(method.name)
            cells = (shares.consistent, shares.matched) if shares is not None else (None, None)
        row = [name, *(number_text(cell) for cell in cells), number_text(method.mean_similarity)]
        lines.append("| " + " | ".join(row) + " |")
    if not has_truth:
        lines.append(
            "\n_No ground-truth disparity: methods are compared on the share of the overlap (pixels valid "
            "in both images) whose disparity the target's own disparity confirms within 1 px (left-right "
            "consistent); matched: the share with a disparity._"
        )
    return "\n".join(lines)


#: Most objects listed in the table of left-right consistent shares per object.
OBJECT_ROWS = 100


def causes_markdown(review: Review) -> str:
    """The shown stage's reference pixels by cause, and its consistent share per object.

    Parameters
    ----------
    review : Review

    Returns
    -------
    str
        A table of the share of the reference's pixels of each cause (all pixels: the
        shares sum to 1); without ground truth, a table of the left-right consistent share
        of each associated object, least consistent first (at most :data:`OBJECT_ROWS`).
        Empty when the review has no causes.
    """
    if review.causes is None:
        return ""
    lines = [f"| pixels of **{review.stage}** by cause | share |", "|---|---:|"]
    lines += [f"| {name} | {number_text(value)} |" for name, value in review.causes.shares().items()]
    if review.object_consistency:
        ranked = sorted(review.object_consistency.items(), key=lambda item: (-np.inf if np.isnan(item[1]) else item[1], item[0]))
        lines += ["", "| object (ref → tgt) | left-right consistent |", "|---|---:|"]
        lines += [f"| {ref} → {tgt} | {number_text(value)} |" for (ref, tgt), value in ranked[:OBJECT_ROWS]]
        if len(ranked) > OBJECT_ROWS:
            lines.append(f"\n_{len(ranked) - OBJECT_ROWS} more objects, more consistent than these._")
    return "\n".join(lines)


def matchers_markdown(run: Any, review: Review, cache: MutableMapping[str, Any], baselines: Sequence[str] = ()) -> str:
    """Every matcher's figures side by side, from what ``cache`` holds.

    One row per method (the shown stage, the original pair, the baselines), one column
    per matcher: with ground truth the correct-matching rate over all pixels and the mean
    over the objects, without it the left-right consistent share (:class:`Consistency`).
    A matcher not reviewed yet on this pair shows "-" (choose it in the dropdown to
    measure it).

    Parameters
    ----------
    run : radcons.pipeline.Run
        The run ``review`` measured.
    review : Review
        The latest review (its stage is the shown one).
    cache : mutable mapping
        The session cache :func:`review_run` filled.
    baselines : sequence of str

    Returns
    -------
    str
    """
    from radcons.evaluate.matching import MATCHERS

    has_truth = review.truth is not None
    pairs, search = object_pairs(run), review.disparity_range
    names = [review.stage, "original", *(f"baseline:{b}" for b in baselines)]
    names = list(dict.fromkeys(names))
    if has_truth:
        title, heading = "Correct-matching rate per matcher (|d - d_gt| < 1 px):", "{}: all / objects"
    else:
        title, heading = "Left-right consistent share per matcher (no ground truth):", "{}: consistent"
    header = "| method | " + " | ".join(heading.format(m) for m in MATCHERS) + " |"
    lines = [title, "", header, "|---|" + "---:|" * len(MATCHERS)]
    for name in names:
        cells = []
        for matcher in MATCHERS:
            entry = cache.get(method_key(matcher, name, pairs, search))
            shown = cache.get(f"shown:{matcher}")
            if entry is None and shown is not None and shown[0] is run and shown[1].name == name:
                entry = shown[1:]
            cells.append("-" if entry is None else _figures_text(entry[0], entry[1], has_truth))
        label = f"**{name}** (shown)" if name == review.stage else name
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _figures_text(result: Any, shares: Consistency | None, has_truth: bool) -> str:
    """One method's cell of :func:`matchers_markdown`."""
    if has_truth:
        return f"{number_text(result.correct_rate)} / {number_text(result.mean_object_rate)}"
    return number_text(shares.consistent if shares is not None else None)
