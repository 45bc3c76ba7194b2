"""Disparity review: dense matching of the shown stage, compared with the original and baselines.

All measurements come from :func:`radcons.evaluate.compare.evaluate_methods` (eq 20
similarity per object, dense disparity, correct-matching rate overall and per object), one
method at a time so that a review can stop between two when tuning needs the processor.
The dense matcher is a choice (:data:`radcons.evaluate.matching.MATCHERS`: OpenCV SGBM or
census + SGM by CNES Pandora). The original pair and the baselines do not depend on the
stage parameters, so each is measured once per work pair, object association and matcher
and kept in the session cache; each new run measures only the stage on screen.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Callable, MutableMapping, Sequence

import numpy as np

from inspector.objects import number_text
from radcons.errors import RadconsError
from radcons.io import Pair

__all__ = [
    "MATCHER_TITLES",
    "Review",
    "object_pairs",
    "labelled_pair",
    "search_range",
    "resolve_view",
    "view_images",
    "review_run",
    "review_markdown",
    "matchers_markdown",
]

#: How the review names each matcher.
MATCHER_TITLES = {"sgbm": "OpenCV SGBM", "census": "census + SGM, CNES Pandora"}


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
    """

    stage: str
    current: Any
    others: tuple[Any, ...]
    disparity_range: tuple[float, float]
    truth: np.ndarray | None
    matcher: str = "sgbm"

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


def search_range(run: Any) -> tuple[float, float]:
    """Disparity search range: from ground truth, else from the sparse matches, else +-width/8."""
    from radcons.evaluate.matching import disparity_range_from_matches, disparity_range_from_truth

    pair = run.working_pair
    try:
        if pair.disparity is not None:
            return disparity_range_from_truth(pair.disparity)
        if run.association is not None and len(run.association.matches):
            return disparity_range_from_matches(run.association.matches)
    except RadconsError:
        pass
    half = max(16.0, pair.shape[1] / 8.0)
    return -half, half


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
        None when stopped.

    Raises
    ------
    radcons.errors.ParamsError
        An unknown matcher.
    """
    from radcons.evaluate.compare import evaluate_methods
    from radcons.evaluate.matching import matcher_params

    params = matcher_params(matcher)
    view = resolve_view(run, view)
    pair = labelled_pair(run)
    pairs = object_pairs(run)
    search = search_range(run)

    def measure(name: str) -> Any:
        key = method_key(matcher, name, pairs, search)
        if key not in cache:
            images = view_images(run, name, cache) if name != "original" else run.images("original")
            cache[key] = evaluate_methods(pair, {name: images}, pairs, params, disparity_range=search).methods[0]
        return cache[key]

    others = []
    for name in ("original", *(f"baseline:{b}" for b in baselines)):
        if should_stop():
            return None
        others.append(measure(name))
    if should_stop():
        return None
    known = {m.name: m for m in others}
    if view in known:
        current = known[view]
    else:
        images = view_images(run, view, cache)
        current = evaluate_methods(pair, {view: images}, pairs, params, disparity_range=search).methods[0]
        cache[f"shown:{matcher}"] = (run, current)
    return Review(view, current, tuple(others), search, pair.disparity, matcher)


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
        Correct-matching rates (overall and mean per object) when the pair has a
        ground-truth disparity, and the mean eq 20 similarity.
    """
    has_truth = review.truth is not None
    low, high = review.disparity_range
    lines = [
        f"Dense matching ({MATCHER_TITLES.get(review.matcher, review.matcher)}) of **{review.stage}**, "
        f"disparities {low:.0f}..{high:.0f} px.",
        "",
        "| method | correct rate | mean object rate | mean C (eq 20) |" if has_truth else "| method | mean C (eq 20) |",
        "|---|---:|---:|---:|" if has_truth else "|---|---:|",
    ]
    methods = [review.current] + [m for m in review.others if m.name != review.current.name]
    for method in methods:
        name = f"**{method.name}** (shown)" if method is review.current else method.name
        similarity = number_text(method.mean_similarity)
        if has_truth:
            lines.append(f"| {name} | {number_text(method.correct_rate)} | {number_text(method.mean_object_rate)} | {similarity} |")
        else:
            lines.append(f"| {name} | {similarity} |")
    if not has_truth:
        lines.append("\n_No ground-truth disparity: correct-matching rates need one._")
    return "\n".join(lines)


def matchers_markdown(run: Any, review: Review, cache: MutableMapping[str, Any], baselines: Sequence[str] = ()) -> str:
    """Every matcher's correct-matching rates side by side, from what ``cache`` holds.

    One row per method (the shown stage, the original pair, the baselines), one column
    per matcher with the rate over all pixels and the mean over the objects; a matcher not
    reviewed yet on this pair shows "-" (choose it in the dropdown to measure it).

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
        Empty without ground truth (no rates to compare).
    """
    from radcons.evaluate.matching import MATCHERS

    if review.truth is None:
        return ""
    pairs, search = object_pairs(run), review.disparity_range
    names = [review.stage, "original", *(f"baseline:{b}" for b in baselines)]
    names = list(dict.fromkeys(names))
    header = "| method | " + " | ".join(f"{m}: all / objects" for m in MATCHERS) + " |"
    lines = ["Correct-matching rate per matcher (|d - d_gt| < 1 px):", "", header, "|---|" + "---:|" * len(MATCHERS)]
    for name in names:
        cells = []
        for matcher in MATCHERS:
            result = cache.get(method_key(matcher, name, pairs, search))
            shown = cache.get(f"shown:{matcher}")
            if result is None and shown is not None and shown[0] is run and shown[1].name == name:
                result = shown[1]
            cells.append("-" if result is None else f"{number_text(result.correct_rate)} / {number_text(result.mean_object_rate)}")
        label = f"**{name}** (shown)" if name == review.stage else name
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
