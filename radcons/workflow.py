"""Evaluating the method against the baselines on one pair (``radcons evaluate``).

Method names: ``original`` (the pair as it is), ``ours`` (the last stage of the pipeline
with the given parameters), ``paper`` (the pipeline with the ``paper`` preset, the text as
printed), any image stage of the "ours" pipeline (``uniformity``, ``global``, ``refine``,
``sharpness``, ``smoothness``) to see what each stage adds, and the baselines of
:data:`radcons.baselines.BASELINES`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable, Sequence

from radcons.baselines import BASELINES
from radcons.errors import ParamsError
from radcons.evaluate.compare import Comparison, baseline_images, evaluate_methods
from radcons.evaluate.matching import MatcherParams, disparity_range_from_matches
from radcons.io import Pair
from radcons.params import Params
from radcons.pipeline import IMAGE_STAGES, Pipeline, Run

__all__ = ["METHODS", "evaluate_pair", "evaluate_run"]

#: Every method name ``evaluate_pair`` knows.
METHODS: tuple[str, ...] = ("original", "ours", "paper", *IMAGE_STAGES[1:], *BASELINES)


def evaluate_pair(
    pair: Pair,
    methods: Sequence[str],
    params: Params | None = None,
    matcher: MatcherParams = MatcherParams(),
    *,
    pipeline: Pipeline | None = None,
    progress: Callable[[str, int, int], None] | None = None,
) -> tuple[Run, Comparison]:
    """Run the pipeline, then compare ``methods`` by eq 20 similarity and dense matching.

    Parameters
    ----------
    pair : Pair
        The pair; its ground-truth disparity and labels are used when present.
    methods : sequence of str
        Names among :data:`METHODS`, in the order the table shows them.
    params : Params, optional
        Parameters of the pipeline ("ours").
    matcher : MatcherParams
        One dense matcher for every method.
    pipeline : Pipeline, optional
        A pipeline whose cache may be reused.
    progress : callable, optional
        Pipeline progress callback.

    Returns
    -------
    run : Run
        The pipeline run (objects, association, every stage's images).
    comparison : Comparison
    """
    unknown = [name for name in methods if name not in METHODS]
    if unknown:
        raise ParamsError(f"unknown method(s) {', '.join(unknown)}; known: {', '.join(METHODS)}")
    if not methods:
        raise ParamsError("no method to evaluate")
    pipeline = pipeline or Pipeline(params)
    run = pipeline.run(pair, params, progress=progress)
    return run, evaluate_run(run, methods, matcher)


def evaluate_run(run: Run, methods: Sequence[str], matcher: MatcherParams = MatcherParams()) -> Comparison:
    """Compare ``methods`` on a finished run (see :func:`evaluate_pair`).

    Objects: the pair's own label rasters (ground truth) when it has them, else the run's
    segmented objects paired by the association stage. Disparity range: the ground truth's
    when present, else the range of the sparse matches.
    """
    pair = run.working_pair
    seconds: dict[str, float] = {}
    baselines = baseline_images(pair, [name for name in methods if name in BASELINES], seconds)
    images = {}
    for name in methods:
        if name in baselines:
            images[name] = baselines[name]
        elif name == "ours":
            images[name] = run.images()
            seconds[name] = run.total_time
        elif name == "paper":
            faithful = Params.from_preset("paper")
            paper = run if run.params == faithful else Pipeline(faithful).run(run.pair)
            images[name] = paper.images()
            seconds[name] = paper.total_time
        else:
            images[name] = run.images(name)
    object_pairs = None
    if pair.reference_objects is None or pair.target_objects is None:
        pair = replace(pair, reference_objects=run.objects.reference, target_objects=run.objects.target)
        object_pairs = [(obj.ref_id, obj.tgt_id) for obj in run.association.objects if obj.tgt_id > 0]
    disparity_range = None
    if pair.disparity is None:
        disparity_range = disparity_range_from_matches(run.association.matches)
    return evaluate_methods(
        pair, images, object_pairs, matcher, disparity_range=disparity_range, normalise_seconds=seconds
    )
