"""The stage pipeline: runs the paper's stages in order and caches each stage's result.

Stages and what each depends on::

    rectify      <- pair                      (epipolar resampling; only for unrectified pairs)
    objects      <- rectify                   (labels of both images)
    association  <- objects                   (SIFT matches, object pairs, D̄m, invariant points)
    uniformity   <- rectify                   (eq 1-3, each image)
    global       <- uniformity                (eq 4-6)
    refine       <- global, association       (eq 7-12)
    sharpness    <- refine                    (one point spread for both images; not the paper's)
    smoothness   <- sharpness, objects, association   (eq 13-19)

A stage's cache key is its own parameters, whether it is switched on, and the keys of the
stages it depends on (the pair enters through a content fingerprint). Changing one
parameter therefore recomputes that stage and the stages downstream of it, no more; a
stage switched off passes its input images through.

The association's SIFT matches depend on the working pair and the association's
parameters only, not on the objects: when a run computes the objects and then the
association, the matching starts in a worker thread before the objects and runs beside
them (OpenCV releases the GIL), and the matches are kept per pair and parameters. While
it runs beside the objects, OpenCV works on one thread (:class:`_OneOpenCVThread`).

Likewise the height method's census matching of the pair
(:class:`radcons.stages.objects.matching.PairMatching`) depends on the working pair and the
objects stage's census fields only, not on its rules: it is kept per pair and census
fields, so that a rule's threshold changed (the inspector's live tuning) runs the rules
again, not the matching (1.0 s against 1.9 s at 1024 x 1024 px,
``benchmarks/bench_objects.py --only timing``).
"""

from __future__ import annotations

import contextlib
import hashlib
import threading
import time
from collections import Counter, OrderedDict
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Callable, Hashable, Iterator

import cv2
import numpy as np

from radcons.errors import ParamsError
from radcons.io import Pair, Raster
from radcons.params import Params
from radcons.results import Association, ObjectLabels, StageImages
from radcons.stages import IMAGE_STAGES, STAGE, STAGES, StageInputs
from radcons.stages.objects.step import finds_objects_from_height, height_geometry
from radcons.validate import check_params_for_shape

__all__ = ["Pipeline", "Run", "IMAGE_STAGES", "pair_images", "to_output_dtype"]


#: SIFT match sets kept (pairs x association parameters), least recently used dropped.
_MATCHES_KEPT = 4
#: Census matchings of the height method kept (pairs x census parameters), least recently used dropped:
#: each holds the census descriptors, gradient scales and segments of a pair, about 36 bytes a pixel.
_MATCHINGS_KEPT = 2



@dataclass
class Run:
    """Everything one pipeline run produced.

    Attributes
    ----------
    pair : Pair
        The input pair.
    params : Params
        The parameters used.
    working_pair : Pair
        The pair every stage works on: the input itself when it is rectified, else its
        epipolar resampling (images, labels and ground truth in the rectified geometry,
        no georeferencing, since it no longer fits the grid).
    results : dict
        Stage name -> result: ``"original"``, ``"uniformity"``, ``"global"``, ``"refine"``,
        ``"sharpness"``, ``"smoothness"`` -> :class:`StageImages`; ``"objects"`` -> :class:`ObjectLabels`;
        ``"association"`` -> :class:`Association`; ``"rectify"`` ->
        :class:`~radcons.stages.rectify.run.Rectification` or None (pair already rectified).
        Only the stages run (see ``until``).
    timings : dict
        Stage name -> seconds spent computing it in this run (0.0 when cached).
    cached : dict
        Stage name -> True when the result came from the cache.
    """

    pair: Pair
    params: Params
    working_pair: Pair | None = None
    results: dict[str, Any] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)
    cached: dict[str, bool] = field(default_factory=dict)

    @property
    def image_stages(self) -> list[str]:
        """The image stages present in this run, in order."""
        return [name for name in IMAGE_STAGES if name in self.results]

    @property
    def final_stage(self) -> str:
        """The last image stage of the run."""
        return self.image_stages[-1]

    def images(self, stage: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Return ``(reference, target)`` float32 images of an image stage (default: last)."""
        result: StageImages = self.results[stage or self.final_stage]
        return result.reference, result.target

    @property
    def rectification(self) -> Any:
        """The epipolar resampling of an unrectified pair, or None."""
        return self.results.get("rectify")

    @property
    def objects(self) -> ObjectLabels | None:
        """Object labels of both images, if the objects stage ran."""
        return self.results.get("objects")

    @property
    def association(self) -> Association | None:
        """Object association, if that stage ran."""
        return self.results.get("association")

    @property
    def fits(self) -> tuple:
        """Per-object fits of the refined stage (eq 7-11), empty if it did not run."""
        refine = self.results.get("refine")
        return tuple(refine.info.get("fits", ())) if refine is not None else ()

    @property
    def total_time(self) -> float:
        """Seconds spent computing in this run."""
        return float(sum(self.timings.values()))


def pair_images(pair: Pair) -> tuple[np.ndarray, np.ndarray]:
    """Return the pair's images as float32 with NaN where a pixel is nodata."""
    return pair.reference.as_float32(), pair.target.as_float32()


def to_output_dtype(image: np.ndarray, dtype: np.dtype, nodata: float | None) -> np.ndarray:
    """Convert a float32 stage image back to the input's dtype.

    Integer outputs are rounded and clipped to the dtype's range; NaN pixels become
    ``nodata`` (0 when there is none). Float outputs keep NaN (or take ``nodata``).
    """
    dtype = np.dtype(dtype)
    invalid = ~np.isfinite(image)
    if dtype.kind == "f":
        out = image.astype(dtype, copy=True)
        if nodata is not None:
            out[invalid] = nodata
        return out
    info = np.iinfo(dtype)
    out = np.clip(np.rint(np.nan_to_num(image, nan=0.0)), info.min, info.max).astype(dtype)
    out[invalid] = 0 if nodata is None else nodata
    return out


def _smallest_shape(pair: Pair) -> tuple[int, int]:
    """Rows and columns of the smaller of the pair's two images, side by side."""
    (r1, c1), (r2, c2) = pair.reference.data.shape[:2], pair.target.data.shape[:2]
    return min(r1, r2), min(c1, c2)


def _fingerprint(pair: Pair) -> str:
    """Content hash of everything in the pair that a stage reads."""
    digest = hashlib.blake2b(digest_size=16)
    for array in (pair.reference.data, pair.target.data, pair.reference_objects, pair.target_objects):
        if array is None:
            digest.update(b"none")
            continue
        digest.update(str((array.shape, array.dtype.str)).encode())
        digest.update(np.ascontiguousarray(array).data)
    digest.update(repr((pair.reference.nodata, pair.target.nodata, pair.rectified)).encode())
    return digest.hexdigest()


class Pipeline:
    """Runs the stages of the method in order, caching each stage's result.

    Parameters
    ----------
    params : Params, optional
        Stage parameters; defaults to the paper preset.
    cache_size : int
        How many stage results to keep (least recently used are dropped).

    Attributes
    ----------
    calls : collections.Counter
        How many times each stage was really computed (not served from the cache).

    Examples
    --------
    >>> run = Pipeline().run(pair)                       # doctest: +SKIP
    >>> run.images("refine")                             # doctest: +SKIP
    """

    def __init__(self, params: Params | None = None, cache_size: int = 48) -> None:
        self.params = params or Params()
        self.calls: Counter[str] = Counter()
        self._cache: OrderedDict[Hashable, Any] = OrderedDict()
        self._cache_size = cache_size
        self._fingerprints: dict[int, tuple[Pair, str]] = {}
        self._matches: OrderedDict[Hashable, Future] = OrderedDict()
        self._matchings: OrderedDict[Hashable, Any] = OrderedDict()
        self._matcher: ThreadPoolExecutor | None = None

    def run(
        self,
        pair: Pair,
        params: Params | None = None,
        *,
        until: str | None = None,
        progress: Callable[[str, int, int], None] | None = None,
    ) -> Run:
        """Run the stages on ``pair`` and return every stage's result.

        Parameters
        ----------
        pair : Pair
            Input pair (rectified).
        params : Params, optional
            Parameters for this run; default the pipeline's own. Also becomes the
            pipeline's parameters.
        until : str, optional
            Last stage to run (a name in :data:`radcons.params.STAGES`).
        progress : callable, optional
            Called as ``progress(stage, index, total)`` before each stage starts.

        Returns
        -------
        Run
        """
        if params is not None:
            self.params = params
        params = self.params
        names = list(STAGES)
        if until is not None:
            if until not in STAGES:
                raise ParamsError(f"unknown stage {until!r} (known: {', '.join(STAGES)})")
            names = names[: names.index(until) + 1]
        check_params_for_shape(params, _smallest_shape(pair))
        run = Run(pair=pair, params=params)
        token = self._token(pair)
        keys: dict[str, Hashable] = {}
        for index, name in enumerate(names):
            deps = STAGE[name].depends
            key = (name, token, params.stage(name), params.enabled(name), tuple(keys[d] for d in deps))
            keys[name] = key
            if progress is not None:
                progress(name, index, len(names))
            if key in self._cache:
                self._cache.move_to_end(key)
                run.results[name] = self._cache[key]
                run.timings[name] = 0.0
                run.cached[name] = True
            else:
                if name == "objects" and "association" in names:
                    heavy = finds_objects_from_height(run.working_pair, params.stage("objects"))
                    self._start_matching(run, keys["rectify"], beside_objects=heavy)
                start = time.perf_counter()
                result = self._compute(name, run, keys)
                run.timings[name] = time.perf_counter() - start
                run.cached[name] = False
                self.calls[name] += 1
                run.results[name] = result
                self._cache[key] = result
            if name == "rectify":
                self._start(run)
            while len(self._cache) > self._cache_size:
                self._cache.popitem(last=False)
        return run

    def _start(self, run: Run) -> None:
        """Set the working pair and the "original" images once ``rectify`` is known."""
        rectification = run.results["rectify"]
        run.working_pair = run.pair if rectification is None else rectified_pair(run.pair, rectification)
        reference, target = pair_images(run.working_pair)
        run.results["original"] = StageImages(reference, target, {})

    def clear(self) -> None:
        """Forget every cached result."""
        self._cache.clear()
        self._fingerprints.clear()
        self._matches.clear()
        self._matchings.clear()

    # ------------------------------------------------------------------ internals

    def _token(self, pair: Pair) -> str:
        known = self._fingerprints.get(id(pair))
        if known is not None and known[0] is pair:
            return known[1]
        token = _fingerprint(pair)
        self._fingerprints = {id(pair): (pair, token)}
        return token

    def _start_matching(self, run: Run, rectify_key: Hashable, beside_objects: bool = False) -> Future:
        """The SIFT matches of the run's working pair, started in the worker thread if new.

        ``beside_objects``: the height method's objects are computed meanwhile (its two
        threads keep both cores busy), and OpenCV works on one thread until the matches
        are done. Supplied labels and the image-only objects leave it every thread.
        """
        from radcons.stages.association.run import match_features

        key = (rectify_key, run.params.stage("association"))
        if key in self._matches:
            self._matches.move_to_end(key)
            return self._matches[key]
        if self._matcher is None:
            self._matcher = ThreadPoolExecutor(max_workers=1, thread_name_prefix="radcons-matches")
        reference, target = run.images("original")
        match = _ONE_OPENCV_THREAD.around(match_features) if beside_objects else match_features
        future = self._matcher.submit(
            match, reference, target, run.params.stage("association"), rectified=run.working_pair.rectified
        )
        self._matches[key] = future
        while len(self._matches) > _MATCHES_KEPT:
            self._matches.popitem(last=False)
        return future

    def _pair_matching(self, run: Run, rectify_key: Hashable) -> Any:
        """The height method's census matching of the run's working pair, kept per pair and census parameters.

        A change to the objects stage's rules or searches then runs them again on the kept
        matching (:class:`radcons.stages.objects.matching.PairMatching`); a change to its census
        fields, or another pair, matches again.
        """
        from radcons.stages.objects.matching import PairMatching, match_pair

        params = run.params.stage("objects")
        geometry = height_geometry(run.working_pair, run.rectification)
        reference, target = run.images("original")
        key = (rectify_key, PairMatching.key_of(reference.shape, params, geometry["gsd_m"], geometry["disparity_range"]))
        if key in self._matchings:
            self._matchings.move_to_end(key)
            return self._matchings[key]
        matching = match_pair(
            reference, target, params, gsd_m=geometry["gsd_m"], disparity_range=geometry["disparity_range"]
        )
        self._matchings[key] = matching
        while len(self._matchings) > _MATCHINGS_KEPT:
            self._matchings.popitem(last=False)
        return matching

    def _compute(self, name: str, run: Run, keys: dict[str, Hashable]) -> Any:
        """Stage ``name``'s result: its step (:meth:`radcons.stages.Stage.step`) on the results so far.

        An image stage switched off passes the images of the stage before it through.
        """
        stage = STAGE[name]
        inputs = StageInputs(
            pair=run.pair,
            working_pair=run.working_pair,
            params=run.params,
            results=run.results,
            matches=lambda: self._start_matching(run, keys["rectify"]).result(),
            pair_matching=lambda: self._pair_matching(run, keys["rectify"]),
        )
        if stage.image_stage and not run.params.enabled(name):
            reference, target = inputs.previous_images(name)
            return StageImages(reference, target, {"enabled": False})
        return stage.step()(inputs)


def rectified_pair(pair: Pair, rectification: Any) -> Pair:
    """The pair resampled into the rectified geometry (its label rasters and change mask too).

    Integer images keep their dtype; pixels outside the source take the nodata value
    (NaN for float images, else the pair's nodata, else 0).
    """

    def image(raster: Raster, data: np.ndarray) -> Raster:
        dtype = raster.data.dtype
        nodata = raster.nodata if raster.nodata is not None else (float("nan") if dtype.kind == "f" else 0)
        return Raster(to_output_dtype(data, dtype, nodata), {}, nodata, None)

    def labels(array: np.ndarray | None, which: str) -> np.ndarray | None:
        if array is None:
            return None
        mapped = rectification.to_rectified(array.astype(np.float32), which, "nearest")
        return np.nan_to_num(mapped, nan=0.0).astype(array.dtype)

    # A disparity is defined for rectified pairs only (DESIGN: conventions), so an
    # unrectified pair carries none to resample.
    return Pair(
        reference=image(pair.reference, rectification.reference),
        target=image(pair.target, rectification.target),
        reference_objects=labels(pair.reference_objects, "reference"),
        target_objects=labels(pair.target_objects, "target"),
        change_mask=None if pair.change_mask is None else labels(pair.change_mask, "reference").astype(bool),
        rectified=True,
        metadata={**pair.metadata, "rectified_by": f"radcons {rectification.method} epipolar resampling"},
        name=pair.name,
        source=pair.source,
    )


class _OneOpenCVThread:
    """OpenCV's thread count, one while any SIFT matching runs beside the objects.

    OpenCV's thread pool keeps its workers spinning while they wait. With SIFT on two
    threads beside the objects' census matching and worker thread, on two cores, the
    1024 px demo pair takes 1.63 s to the association against 1.42 s with SIFT on one
    (``benchmarks/bench_objects.py --only timing``). The count is process-wide, so
    overlapping runs (the inspector's) are counted, and the last to finish restores the
    count the first found.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._users = 0
        self._saved = 1

    @contextlib.contextmanager
    def held(self) -> Iterator[None]:
        """OpenCV on one thread for the duration of the block."""
        with self._lock:
            if self._users == 0:
                self._saved = cv2.getNumThreads()
                cv2.setNumThreads(1)
            self._users += 1
        try:
            yield
        finally:
            with self._lock:
                self._users -= 1
                if self._users == 0:
                    cv2.setNumThreads(self._saved)

    def around(self, function: Callable[..., Any]) -> Callable[..., Any]:
        """``function`` run with OpenCV on one thread."""

        def call(*args: Any, **kwargs: Any) -> Any:
            with self.held():
                return function(*args, **kwargs)

        return call


_ONE_OPENCV_THREAD = _OneOpenCVThread()


