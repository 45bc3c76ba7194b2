"""Evaluating the method against the baselines on one pair (``radcons evaluate``).

Method names: ``original`` (the pair as it is), ``ours`` (the last stage of the pipeline
with the given parameters), ``paper`` (the pipeline with the ``paper`` preset, the text as
printed), any image stage of the "ours" pipeline (``uniformity``, ``global``, ``refine``,
``sharpness``, ``smoothness``) to see what each stage adds, and the baselines of
:data:`radcons.baselines.BASELINES`. Each method is matched with one dense matcher
(:func:`evaluate_pair`) or with several (:func:`evaluate_pair_matchers`, e.g. SGBM and
census).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

from radcons.baselines import BASELINES
from radcons.errors import ParamsError
from radcons.evaluate.compare import (
    Comparison,
    Evaluation,
    baseline_images,
    evaluate_matchers,
)
from radcons.evaluate.matching import MatcherParams
from radcons.evaluate.measure import as_written
from radcons.evaluate.search_range import search_range
from radcons.io import Pair
from radcons.numerics.census import CensusParams
from radcons.params import Params
from radcons.pipeline import IMAGE_STAGES, Pipeline, Run
from radcons.summary import run_noise_notice

__all__ = [
    "METHODS", "evaluate_pair", "evaluate_run", "evaluate_pair_matchers", "evaluate_run_matchers", "ours_noise_notice",
]

Matcher = MatcherParams | CensusParams

#: Every method name ``evaluate_pair`` knows.
METHODS: tuple[str, ...] = ("original", "ours", "paper", *IMAGE_STAGES[1:], *BASELINES)


def evaluate_pair(
    pair: Pair,
    methods: Sequence[str],
    params: Params | None = None,
    matcher: Matcher = MatcherParams(),
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
    matcher : MatcherParams or CensusParams
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
    run, evaluation = evaluate_pair_matchers(pair, methods, params, [matcher], pipeline=pipeline, progress=progress)
    return run, evaluation.first


def evaluate_pair_matchers(
    pair: Pair,
    methods: Sequence[str],
    params: Params | None = None,
    matchers: Sequence[Matcher] = (MatcherParams(), CensusParams()),
    *,
    pipeline: Pipeline | None = None,
    progress: Callable[[str, int, int], None] | None = None,
) -> tuple[Run, Evaluation]:
    """:func:`evaluate_pair` with each of several dense matchers (one of each kind).

    Raises
    ------
    ParamsError
        An unknown method, no method, no matcher or two matchers of one kind.
    """
    unknown = [name for name in methods if name not in METHODS]
    if unknown:
        raise ParamsError(f"unknown method(s) {', '.join(unknown)}; known: {', '.join(METHODS)}")
    if not methods:
        raise ParamsError("no method to evaluate")
    pipeline = pipeline or Pipeline(params)
    run = pipeline.run(pair, params, progress=progress)
    return run, evaluate_run_matchers(run, methods, matchers)


def evaluate_run(run: Run, methods: Sequence[str], matcher: Matcher = MatcherParams()) -> Comparison:
    """Compare ``methods`` on a finished run with one matcher (see :func:`evaluate_run_matchers`)."""
    return evaluate_run_matchers(run, methods, [matcher]).first


def evaluate_run_matchers(
    run: Run, methods: Sequence[str], matchers: Sequence[Matcher] = (MatcherParams(), CensusParams())
) -> Evaluation:
    """Compare ``methods`` on a finished run with each of ``matchers``.

    The images radcons writes (``ours``, ``paper``, a stage's) are measured as the output
    files hold them (:func:`radcons.evaluate.measure.as_written`); the baselines, which it
    does not write, as computed. Objects: the pair's own label rasters (ground truth) when it has them, else the run's
    segmented objects paired by the association stage. Disparity range: the pair's own
    (:func:`radcons.evaluate.search_range.search_range`: the ground truth's, else the
    rectification's, else the SIFT matches' without their outliers); the same for every
    matcher.
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
    written = {name: value if name in baselines else as_written(pair, *value) for name, value in images.items()}
    object_pairs = None
    if pair.reference_objects is None or pair.target_objects is None:
        pair = replace(pair, reference_objects=run.objects.reference, target_objects=run.objects.target)
        object_pairs = [(obj.ref_id, obj.tgt_id) for obj in run.association.objects if obj.tgt_id > 0]
    disparity_range = None
    if pair.disparity is None:
        disparity_range = search_range(run)[0]
    return evaluate_matchers(
        pair, written, object_pairs, matchers, disparity_range=disparity_range, normalise_seconds=seconds
    )


def ours_noise_notice(run: Run, evaluation: Evaluation) -> str | None:
    """The noise notice of the ``ours`` images of an evaluation of ``run``
    (:func:`radcons.summary.run_noise_notice`, from the noise ratio the evaluation
    measured); None when ``ours`` was not evaluated or its ratio is at most 1.5."""
    if "ours" not in [method.name for method in evaluation.first.methods]:
        return None
    return run_noise_notice(run, evaluation.first.method("ours").noise_ratio)
