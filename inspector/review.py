"""Disparity review: dense matching of the shown stage, compared with the original and baselines.

All measurements come from :func:`radcons.evaluate.compare.evaluate_methods` (eq 20
similarity per object, SGBM disparity, correct-matching rate overall and per object), one
method at a time so that a review can stop between two when tuning needs the processor.
The original pair and the baselines do not depend on the stage parameters, so each is
measured once per work pair (and object association) and kept in the session cache; each
new run measures only the stage on screen.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Callable, MutableMapping, Sequence

import numpy as np

from radcons.errors import RadconsError
from radcons.io import Pair

__all__ = ["Review", "object_pairs", "labelled_pair", "search_range", "resolve_view", "view_images", "review_run"]


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
    """

    stage: str
    current: Any
    others: tuple[Any, ...]
    disparity_range: tuple[float, float]
    truth: np.ndarray | None

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

    Returns
    -------
    Review or None
        None when stopped.
    """
    from radcons.evaluate.compare import evaluate_methods

    view = resolve_view(run, view)
    pair = labelled_pair(run)
    pairs = object_pairs(run)
    search = search_range(run)
    def measure(name: str) -> Any:
        key = f"method:{name}:{pairs}:{search}"
        if key not in cache:
            images = view_images(run, name, cache) if name != "original" else run.images("original")
            cache[key] = evaluate_methods(pair, {name: images}, pairs, disparity_range=search).methods[0]
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
        current = evaluate_methods(pair, {view: images}, pairs, disparity_range=search).methods[0]
    return Review(view, current, tuple(others), search, pair.disparity)
