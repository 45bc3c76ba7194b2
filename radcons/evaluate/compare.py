"""Compare radiometric normalisation methods on one pair, as the paper's Tables 1 and 2.

For every method (the original images, each baseline, the paper's method) the same
measurements are taken on the pair of images it produced:

* eq 20 improved histogram similarity of each associated object pair (Table 1), with 256
  levels over the common value range of that method's two images;
* dense disparity with one matcher and one disparity range for all methods, its
  correct-matching rate over all pixels with ground truth and inside each reference object
  (Table 2), when the pair has ground-truth disparity;
* the noise ratio of the two images (the smoothness consistency of section 5);
* timings.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field

import numpy as np

from radcons.baselines import BASELINES
from radcons.errors import InputError, ParamsError
from radcons.evaluate.matching import (
    MatcherParams,
    disparity_range_from_truth,
    matcher_name,
)
from radcons.evaluate.measure import (
    check_images,
    matching_rates,
    object_pairs_of,
    rate_labels,
    similarity_and_noise,
    timed_disparity,
)
from radcons.io import Pair
from radcons.numerics.census import CensusParams

__all__ = ["MethodResult", "Comparison", "Evaluation", "evaluate_methods", "evaluate_matchers", "baseline_images"]


def _nanmean(values: Iterable[float]) -> float:
    finite = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.mean(finite)) if finite else float("nan")


def _json_number(value: float | None) -> float | None:
    return None if value is None or not math.isfinite(value) else float(value)


@dataclass(frozen=True)
class MethodResult:
    """The measurements of one method's images.

    Attributes
    ----------
    name : str
        Method name ("original", "histmatch", ..., "ours").
    similarity : dict
        Reference object id -> eq 20 similarity C.
    disparity : ndarray
        Dense disparity (float32, NaN where matching failed), kept for display.
    correct_rate : float or None
        Correct-matching rate over every pixel with ground truth; None without ground truth.
    object_rates : dict
        Reference object id -> correct-matching rate inside it; empty without ground truth.
    noise_ratio : float
        Larger over smaller noise sigma of the two images.
    seconds : dict
        Timings: ``"matching"``, ``"similarity"``, and ``"normalisation"`` where given.
    """

    name: str
    similarity: dict[int, float]
    disparity: np.ndarray = field(repr=False)
    correct_rate: float | None
    object_rates: dict[int, float]
    noise_ratio: float
    seconds: dict[str, float]

    @property
    def mean_similarity(self) -> float:
        """Mean similarity over the objects (NaN without objects)."""
        return _nanmean(self.similarity.values())

    @property
    def mean_object_rate(self) -> float:
        """Mean correct-matching rate over the objects (NaN without objects or ground truth)."""
        return _nanmean(self.object_rates.values())

    def to_json_dict(self) -> dict:
        """The measurements as JSON-ready values (no arrays; NaN becomes None)."""
        return {
            "similarity": {str(k): _json_number(v) for k, v in self.similarity.items()},
            "mean_similarity": _json_number(self.mean_similarity),
            "correct_rate": _json_number(self.correct_rate),
            "object_rates": {str(k): _json_number(v) for k, v in self.object_rates.items()},
            "mean_object_rate": _json_number(self.mean_object_rate),
            "noise_ratio": _json_number(self.noise_ratio),
            "seconds": {k: round(v, 4) for k, v in self.seconds.items()},
        }


@dataclass(frozen=True)
class Comparison:
    """Measurements of several methods on one pair.

    Attributes
    ----------
    pair_name : str
    methods : tuple of MethodResult
        In the order the methods were given.
    object_pairs : tuple of (int, int)
        The ``(ref_id, tgt_id)`` object pairs measured.
    disparity_range : (float, float)
        The disparity range searched for every method.
    matcher : MatcherParams or CensusParams
        The one dense matcher of every method (its class names it, :data:`MATCHERS`).
    threshold : float
        Error below which a match is correct, in pixels.
    has_ground_truth : bool
    """

    pair_name: str
    methods: tuple[MethodResult, ...]
    object_pairs: tuple[tuple[int, int], ...]
    disparity_range: tuple[float, float]
    matcher: MatcherParams | CensusParams
    threshold: float
    has_ground_truth: bool

    def method(self, name: str) -> MethodResult:
        """The result of the method called ``name``."""
        for result in self.methods:
            if result.name == name:
                return result
        raise KeyError(f"no method {name!r} in this comparison ({', '.join(m.name for m in self.methods)})")

    def to_json_dict(self) -> dict:
        """Everything but the disparity arrays, JSON-ready."""
        return {
            "pair": self.pair_name,
            "object_pairs": [list(p) for p in self.object_pairs],
            "disparity_range": list(self.disparity_range),
            "matcher": asdict(self.matcher),
            "threshold": self.threshold,
            "has_ground_truth": self.has_ground_truth,
            "methods": {m.name: m.to_json_dict() for m in self.methods},
        }

    def format_table(self) -> str:
        """Plain-text tables like the paper's Tables 1 and 2: one row per object, one column
        per method, a mean row; then the whole-image rate, noise ratio and timings."""
        table = _Table([m.name for m in self.methods])
        lines = table.similarity(self.pair_name, self.methods, self.object_pairs)
        if self.has_ground_truth:
            title = f"correct-matching rate (|d - d_gt| < {self.threshold:g} px)"
            lines += ["", *table.rates(title, self.methods, self.object_pairs)]
        lines += ["", *table.method_rows(self.methods, ("normalisation", "matching", "similarity"))]
        return "\n".join(lines)


class _Table:
    """Rows of plain-text tables with one column per method."""

    label_width = 18

    def __init__(self, names: Sequence[str]) -> None:
        self.names = list(names)
        self.width = max(10, *(len(n) + 2 for n in self.names))

    def row(self, label: str, values: Sequence[float | None], digits: int = 3) -> str:
        cells = []
        for value in values:
            text = "-" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"
            cells.append(text.rjust(self.width))
        return label.ljust(self.label_width) + "".join(cells)

    def header(self, label: str) -> str:
        return label.ljust(self.label_width) + "".join(n.rjust(self.width) for n in self.names)

    def similarity(self, pair_name: str, methods: Sequence[MethodResult], object_pairs) -> list[str]:
        ids = [ref_id for ref_id, _ in object_pairs]
        lines = [f"pair {pair_name}: object similarity C (eq 20)", self.header("object")]
        lines += [self.row(str(i), [m.similarity.get(i) for m in methods]) for i in ids]
        lines.append(self.row("mean", [m.mean_similarity for m in methods]))
        return lines

    def rates(self, title: str, methods: Sequence[MethodResult], object_pairs) -> list[str]:
        ids = [ref_id for ref_id, _ in object_pairs]
        lines = [title, self.header("object")]
        lines += [self.row(str(i), [m.object_rates.get(i) for m in methods]) for i in ids]
        lines.append(self.row("mean (objects)", [m.mean_object_rate for m in methods]))
        lines.append(self.row("all pixels", [m.correct_rate for m in methods]))
        return lines

    def method_rows(self, methods: Sequence[MethodResult], keys: Sequence[str], suffix: str = "") -> list[str]:
        lines = [self.header("method")]
        lines.append(self.row("noise ratio", [m.noise_ratio for m in methods], 2))
        for key in keys:
            if any(key in m.seconds for m in methods):
                lines.append(self.row(f"{key} s{suffix}", [m.seconds.get(key) for m in methods], 2))
        return lines


@dataclass(frozen=True)
class Evaluation:
    """The methods of one pair measured with several dense matchers.

    Similarity and noise ratio do not depend on the matcher and are measured once; every
    matcher has its own :class:`Comparison` (disparities, rates, matching time), over the
    same disparity range, methods and objects.

    Attributes
    ----------
    comparisons : dict
        Matcher name (:data:`radcons.evaluate.matching.MATCHERS`) -> its Comparison, in
        the order the matchers were given.
    """

    comparisons: dict[str, Comparison]

    def __post_init__(self) -> None:
        if not self.comparisons:
            raise InputError("an evaluation needs at least one matcher")

    @property
    def first(self) -> Comparison:
        """The comparison of the first matcher (similarity, noise and objects are shared)."""
        return next(iter(self.comparisons.values()))

    def to_json_dict(self) -> dict:
        """JSON-ready: shared measurements under ``methods``, rates under ``matchers``.

        ``matchers.NAME.methods.METHOD`` holds ``rate_all`` (correct-matching rate over every
        pixel with ground truth), ``rate_objects`` (its mean over the objects),
        ``object_rates`` and the matching ``seconds``; ``matchers.NAME.params`` the matcher's
        parameters. Rates are None without ground truth.
        """
        first = self.first
        shared = {}
        for method in first.methods:
            entry = method.to_json_dict()
            shared[method.name] = {
                "similarity": entry["similarity"],
                "mean_similarity": entry["mean_similarity"],
                "noise_ratio": entry["noise_ratio"],
                "seconds": {k: v for k, v in entry["seconds"].items() if k != "matching"},
            }
        matchers = {}
        for name, comparison in self.comparisons.items():
            matchers[name] = {
                "params": asdict(comparison.matcher),
                "methods": {
                    m.name: {
                        "rate_all": _json_number(m.correct_rate),
                        "rate_objects": _json_number(m.mean_object_rate),
                        "object_rates": {str(k): _json_number(v) for k, v in m.object_rates.items()},
                        "seconds": {"matching": round(m.seconds["matching"], 4)},
                    }
                    for m in comparison.methods
                },
            }
        return {
            "pair": first.pair_name,
            "object_pairs": [list(p) for p in first.object_pairs],
            "disparity_range": list(first.disparity_range),
            "threshold": first.threshold,
            "has_ground_truth": first.has_ground_truth,
            "methods": shared,
            "matchers": matchers,
        }

    def format_table(self) -> str:
        """The similarity table once, then each matcher's correct-matching rates, then noise
        ratio and timings (matching time per matcher)."""
        first = self.first
        table = _Table([m.name for m in first.methods])
        lines = table.similarity(first.pair_name, first.methods, first.object_pairs)
        for name, comparison in self.comparisons.items():
            if comparison.has_ground_truth:
                title = f"correct-matching rate, {name} (|d - d_gt| < {comparison.threshold:g} px)"
                lines += ["", *table.rates(title, comparison.methods, comparison.object_pairs)]
        lines += ["", *table.method_rows(first.methods, ("normalisation", "similarity"))]
        for name, comparison in self.comparisons.items():
            lines.append(table.row(f"matching s {name}", [m.seconds["matching"] for m in comparison.methods], 2))
        return "\n".join(lines)


def baseline_images(
    pair: Pair, names: Sequence[str] | None = None, seconds: dict[str, float] | None = None
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Run registered baselines on the pair's float32 images.

    Parameters
    ----------
    pair : Pair
    names : sequence of str, optional
        Keys of :data:`radcons.baselines.BASELINES`; default all, in registry order.
    seconds : dict, optional
        When given, receives each baseline's run time in seconds (for ``normalise_seconds``
        of :func:`evaluate_methods`).

    Returns
    -------
    dict
        ``name -> (reference, normalised target)``; the reference is the pair's own.

    Raises
    ------
    ParamsError
        An unknown baseline name.
    """
    names = list(BASELINES) if names is None else list(names)
    unknown = [n for n in names if n not in BASELINES]
    if unknown:
        raise ParamsError(f"unknown baseline(s) {', '.join(unknown)}; known: {', '.join(BASELINES)}")
    reference, target = pair.reference.as_float32(), pair.target.as_float32()
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for name in names:
        start = time.perf_counter()
        out[name] = (reference, BASELINES[name](reference, target))
        if seconds is not None:
            seconds[name] = time.perf_counter() - start
    return out


def _search_range(
    pair: Pair, matcher: MatcherParams | CensusParams, disparity_range: tuple[float, float] | None
) -> tuple[float, float]:
    if disparity_range is not None:
        return float(disparity_range[0]), float(disparity_range[1])
    low, count = getattr(matcher, "min_disparity", None), getattr(matcher, "num_disparities", None)
    if low is not None and count is not None:
        return float(low), float(low + count - 1)
    if pair.disparity is not None:
        return disparity_range_from_truth(pair.disparity)
    raise ParamsError(
        "no disparity range: the pair has no ground truth; pass disparity_range (e.g. "
        "disparity_range_from_matches of the sparse matches) or set it in the matcher"
    )


def evaluate_methods(
    pair: Pair,
    images: Mapping[str, tuple[np.ndarray, np.ndarray]],
    pairs: Sequence[tuple[int, int]] | None = None,
    matcher: MatcherParams | CensusParams = MatcherParams(),
    *,
    disparity_range: tuple[float, float] | None = None,
    threshold: float = 1.0,
    normalise_seconds: Mapping[str, float] | None = None,
    measured: Comparison | None = None,
) -> Comparison:
    """Measure every method's images on one pair (Tables 1 and 2 of the paper).

    Parameters
    ----------
    pair : Pair
        Supplies the object labels (``reference_objects``, ``target_objects``) and the
        ground-truth disparity (reference frame), when present.
    images : mapping
        Method name -> its ``(reference, target)`` float32 images (NaN where invalid), in
        the order the table shows them (measured as given: images radcons writes are
        passed as written, :func:`radcons.evaluate.measure.as_written`).
    pairs : sequence of (int, int), optional
        Object pairs ``(ref_id, tgt_id)`` (e.g. from the association stage); default the
        ids present in both label rasters, paired with themselves (ground-truth ids).
    matcher : MatcherParams or CensusParams
        One matcher for all methods.
    disparity_range : (float, float), optional
        Disparity range searched for all methods; default the matcher's own range, else the
        ground truth's with a 2 px margin.
    threshold : float
        Correct-match threshold in pixels (paper: 1).
    normalise_seconds : mapping, optional
        Method name -> seconds its normalisation took, recorded with the results.
    measured : Comparison, optional
        An earlier comparison of the same images and objects with another matcher: its
        similarities, noise ratios and their timings are taken instead of measured again.

    Returns
    -------
    Comparison

    Raises
    ------
    InputError
        No method, images of the wrong shape, or object pairs without label rasters.
    ParamsError
        No disparity range can be found.
    StageError
        The matcher failed (census: Pandora's message, after the pair and the method).
    """
    check_images(pair, images)
    object_pairs = object_pairs_of(pair, pairs)
    search = _search_range(pair, matcher, disparity_range)
    truth = pair.disparity
    labels = rate_labels(pair, object_pairs, truth)
    results = []
    for name, (reference, target) in images.items():
        seconds: dict[str, float] = {}
        if normalise_seconds is not None and name in normalise_seconds:
            seconds["normalisation"] = float(normalise_seconds[name])
        similarity, noise = similarity_and_noise(pair, name, reference, target, object_pairs, measured, seconds)
        disparity = timed_disparity(pair.name, name, reference, target, matcher, search, seconds)
        correct, per_object = matching_rates(disparity, truth, labels, threshold)
        results.append(
            MethodResult(name, similarity, disparity, correct, per_object, noise, seconds)
        )
    return Comparison(
        pair_name=pair.name,
        methods=tuple(results),
        object_pairs=object_pairs,
        disparity_range=search,
        matcher=matcher,
        threshold=float(threshold),
        has_ground_truth=truth is not None,
    )


def evaluate_matchers(
    pair: Pair,
    images: Mapping[str, tuple[np.ndarray, np.ndarray]],
    pairs: Sequence[tuple[int, int]] | None = None,
    matchers: Sequence[MatcherParams | CensusParams] = (MatcherParams(), CensusParams()),
    *,
    disparity_range: tuple[float, float] | None = None,
    threshold: float = 1.0,
    normalise_seconds: Mapping[str, float] | None = None,
) -> Evaluation:
    """:func:`evaluate_methods` with each of several matchers, over one disparity range.

    Parameters
    ----------
    pair, images, pairs, threshold, normalise_seconds
        As for :func:`evaluate_methods`.
    matchers : sequence of MatcherParams or CensusParams
        The matchers, at most one of each registered kind, in the order the tables show them.
    disparity_range : (float, float), optional
        Searched by every matcher; default the first matcher's own range, else the ground
        truth's with a 2 px margin.

    Returns
    -------
    Evaluation

    Raises
    ------
    ParamsError
        No matcher, or two of the same kind.
    """
    names = [matcher_name(m) for m in matchers]
    if not names or len(set(names)) != len(names):
        raise ParamsError(f"matchers must be one or more distinct ones, got {', '.join(names) or 'none'}")
    search = _search_range(pair, matchers[0], disparity_range)
    comparisons: dict[str, Comparison] = {}
    measured = None
    for name, matcher in zip(names, matchers):
        measured = evaluate_methods(
            pair, images, pairs, matcher, disparity_range=search, threshold=threshold,
            normalise_seconds=normalise_seconds, measured=measured,
        )
        comparisons[name] = measured
    return Evaluation(comparisons)
