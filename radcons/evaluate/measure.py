"""The measurements of one method's images, the steps of :func:`radcons.evaluate.compare.evaluate_methods`.

Checks of the method images and object pairs, then per method: eq 20 similarity and noise
ratio, a timed dense disparity and its correct-matching rates.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from radcons.errors import InputError, StageError
from radcons.evaluate.matching import MatcherParams, dense_disparity
from radcons.evaluate.rates import correct_matching_rate, object_matching_rates
from radcons.evaluate.similarity import object_similarities
from radcons.io import Pair
from radcons.noise import noise_ratio
from radcons.numerics.census import CensusParams
from radcons.pipeline import to_output_dtype

if TYPE_CHECKING:
    from radcons.evaluate.compare import Comparison

__all__ = [
    "as_written", "check_images", "object_pairs_of", "rate_labels", "similarity_and_noise", "timed_disparity", "matching_rates",
]


def _default_object_pairs(pair: Pair) -> tuple[tuple[int, int], ...]:
    """The ids present in both object label rasters, each paired with itself (none without labels)."""
    if pair.reference_objects is None or pair.target_objects is None:
        return ()
    common = np.intersect1d(np.unique(pair.reference_objects), np.unique(pair.target_objects))
    return tuple((int(i), int(i)) for i in common if i > 0)


def as_written(pair: Pair, reference: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A method's float32 images as the pair's output files hold them, read back as float32.

    ``radcons process`` writes an integer pair in its input dtype
    (:func:`radcons.pipeline.to_output_dtype`; a pair of two integer
    dtypes, in the wider one at the common level: ``--output-dtype common``), so a matcher
    a user runs reads those images rounded to whole levels. Measured as floats, they would
    carry differences below one level that no file holds; census reads them: where an
    8-bit image has equal neighbours (ties), any smooth field added to it orders them.
    Float pairs are returned as they are. NaN stays NaN.

    Parameters
    ----------
    pair : Pair
        Its two images' dtypes decide.
    reference, target : ndarray
        The method's images (float, NaN where invalid).

    Returns
    -------
    reference, target : ndarray of float32
    """
    dtype = np.promote_types(pair.reference.data.dtype, pair.target.data.dtype)
    if dtype.kind not in "iub":
        return reference, target

    def held(image: np.ndarray) -> np.ndarray:
        return np.where(np.isfinite(image), to_output_dtype(image, dtype, None), np.nan).astype(np.float32)

    return held(reference), held(target)


def check_images(pair: Pair, images: Mapping[str, tuple[np.ndarray, np.ndarray]]) -> None:
    """Refuse an empty set of method images, or images of another shape than the pair's.

    Parameters
    ----------
    pair : Pair
    images : mapping
        Method name -> its ``(reference, target)`` images.

    Raises
    ------
    InputError
        No method, or a method whose images differ in shape from the pair.
    """
    if not images:
        raise InputError("no method images to evaluate")
    shape = pair.shape
    for name, (reference, target) in images.items():
        if reference.shape != shape or target.shape != shape:
            raise InputError(
                f"method {name!r}: images {reference.shape}, {target.shape} differ from the pair's {shape}"
            )


def object_pairs_of(pair: Pair, pairs: Sequence[tuple[int, int]] | None) -> tuple[tuple[int, int], ...]:
    """The object pairs to measure: those given, else the ids in both label rasters.

    Parameters
    ----------
    pair : Pair
    pairs : sequence of (int, int) or None
        Object pairs ``(ref_id, tgt_id)``; None for the default.

    Returns
    -------
    tuple of (int, int)

    Raises
    ------
    InputError
        Object pairs but no object label rasters.
    """
    object_pairs = _default_object_pairs(pair) if pairs is None else tuple((int(a), int(b)) for a, b in pairs)
    if object_pairs and (pair.reference_objects is None or pair.target_objects is None):
        raise InputError("object pairs were given but the pair has no object label rasters")
    return object_pairs


def rate_labels(
    pair: Pair, object_pairs: tuple[tuple[int, int], ...], truth: np.ndarray | None
) -> np.ndarray | None:
    """The reference labels of the measured objects (0 elsewhere), for per-object rates.

    Parameters
    ----------
    pair : Pair
    object_pairs : tuple of (int, int)
    truth : ndarray or None
        The pair's ground-truth disparity.

    Returns
    -------
    ndarray or None
        None without object pairs or without ground truth.
    """
    if not object_pairs or truth is None:
        return None
    return np.where(
        np.isin(pair.reference_objects, [ref_id for ref_id, _ in object_pairs]), pair.reference_objects, 0
    )


def similarity_and_noise(
    pair: Pair,
    name: str,
    reference: np.ndarray,
    target: np.ndarray,
    object_pairs: tuple[tuple[int, int], ...],
    measured: Comparison | None,
    seconds: dict[str, float],
) -> tuple[dict[int, float], float]:
    """Eq 20 similarity of each object pair and the noise ratio of one method's images.

    Parameters
    ----------
    pair : Pair
        Supplies the object label rasters.
    name : str
        The method.
    reference, target : ndarray
        The method's float32 images.
    object_pairs : tuple of (int, int)
    measured : Comparison or None
        An earlier comparison whose measurements of ``name`` are taken instead.
    seconds : dict
        Receives the ``"similarity"`` time.

    Returns
    -------
    similarity : dict
        Reference object id -> similarity C; empty without object pairs.
    noise : float
        The noise ratio.
    """
    if measured is not None:
        known = measured.method(name)
        seconds["similarity"] = known.seconds["similarity"]
        return known.similarity, known.noise_ratio
    start = time.perf_counter()
    similarity = (
        object_similarities(reference, target, pair.reference_objects, pair.target_objects, object_pairs)
        if object_pairs
        else {}
    )
    seconds["similarity"] = time.perf_counter() - start
    return similarity, noise_ratio(reference, target)


def timed_disparity(
    pair_name: str,
    name: str,
    reference: np.ndarray,
    target: np.ndarray,
    matcher: MatcherParams | CensusParams,
    search: tuple[float, float],
    seconds: dict[str, float],
) -> np.ndarray:
    """Dense disparity of one method's images, timed.

    Parameters
    ----------
    pair_name : str
        The pair, named in a matcher failure.
    name : str
        The method, named in a matcher failure.
    reference, target : ndarray
        The method's float32 images.
    matcher : MatcherParams or CensusParams
    search : (float, float)
        The disparity range.
    seconds : dict
        Receives the ``"matching"`` time.

    Returns
    -------
    ndarray
        Float32 disparity, NaN where matching failed.

    Raises
    ------
    StageError
        The matcher failed; the message names the pair and the method.
    """
    start = time.perf_counter()
    try:
        disparity = dense_disparity(reference, target, matcher, search)
    except StageError as error:  # Pandora's failure: name the pair and the method
        raise StageError(f"pair {pair_name}, method {name!r}: {error}") from error
    seconds["matching"] = time.perf_counter() - start
    return disparity


def matching_rates(
    disparity: np.ndarray, truth: np.ndarray | None, labels: np.ndarray | None, threshold: float
) -> tuple[float | None, dict[int, float]]:
    """Correct-matching rates of a disparity over all pixels and inside each object.

    Parameters
    ----------
    disparity : ndarray
    truth : ndarray or None
        Ground-truth disparity; None gives no rates.
    labels : ndarray or None
        Object labels from :func:`rate_labels`; None gives no per-object rates.
    threshold : float
        Correct-match threshold in pixels.

    Returns
    -------
    correct : float or None
        The rate over every pixel with ground truth; None without ground truth.
    per_object : dict
        Reference object id -> rate inside it; empty without ground truth or objects.
    """
    if truth is None:
        return None, {}
    correct = correct_matching_rate(disparity, truth, threshold=threshold)
    per_object = {} if labels is None else object_matching_rates(disparity, truth, labels, threshold)
    return correct, per_object
