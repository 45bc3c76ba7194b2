"""Census matching of the pair for the height method, kept apart from its rules.

The height method (:func:`radcons.stages.objects.run.height_objects`) starts from the
census disparity of the working pair on a reduced grid
(:func:`radcons.numerics.coarse_disparity.coarse_disparity`: census and semi-global
matching, CNES Pandora). That matching, and what the method needs of the images alone
(their census descriptors at full resolution, the reference's gradient scales and graph
segments: :class:`ImageWork`), depend only on the images, the census fields of
:class:`~radcons.stages.objects.params.ObjectsParams`, the ground sample distance and a
known disparity range. :func:`match_pair` computes them once as a :class:`PairMatching`,
which a caller tuning the rules' thresholds keeps and hands back to ``height_objects``.
The images' own measures are computed in a worker thread while Pandora matches.
"""

from __future__ import annotations

from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from radcons.errors import InputError, ParamsError, StageError
from radcons.numerics.census import CensusParams
from radcons.numerics.coarse_disparity import census_factor, coarse_disparity
from radcons.stages.objects.disparity import census_descriptors
from radcons.stages.objects.features import ImageScales
from radcons.stages.objects.memo import LastResults
from radcons.stages.objects.params import ObjectsParams
from radcons.stages.objects.searches.missed import reference_segments
from radcons.validate import single_band_image

__all__ = [
    "PairMatching", "ImageWork", "match_pair", "match_validated_pair", "resolved_gsd", "validated_pair",
    "TEXTURE_SCALE_M",
]

#: Smallest side of a pair the height method matches (the range-finding run halves it
#: twice more than the census grid, and census needs its 5 x 5 window).
_MIN_SIDE = 32
#: Scale (m) of the gradient the tree rule's texture is measured with, and of the smoothing
#: of both images before an object is matched into the target.
TEXTURE_SCALE_M = 0.5
#: The worker thread of :class:`ImageWork`, shared by every call (jobs queue in order;
#: the thread starts with the first job).
_WORKER = ThreadPoolExecutor(max_workers=1, thread_name_prefix="radcons-objects")


@dataclass(frozen=True)
class PairMatching:
    """What the height method computes of a pair before any of its rules.

    The census disparity (:func:`radcons.numerics.coarse_disparity.coarse_disparity`) and the images'
    own measures (:class:`ImageWork`) depend on the images, the census fields of
    :class:`ObjectsParams` (``census_cell_m``, ``census_side``, ``search_share``,
    ``census_cross_check``), the ground sample distance and a known disparity range,
    not on the thresholds of the rules and searches. A caller that runs the method again
    on one pair with other thresholds (the pipeline, when an analyst tunes the objects
    stage) keeps this and hands it to :func:`radcons.stages.objects.run.height_objects`,
    which then skips the matching, about half of the method's time.

    Attributes
    ----------
    key : tuple
        The images' shape and the values above it was computed with.
    disparity : ndarray or None
        The census disparity at the grid's resolution, full-image pixels, NaN where
        invalid (None when matching failed).
    searched : tuple of float
        The disparity range of the final run, px.
    valid_share : float
        Share of the overlap the cross-checked disparity holds.
    factor : int
        The census grid's reduction.
    failure : str
        Why the pair could not be matched ("" when it was).
    work : ImageWork or None
        The census descriptors, gradient scales and graph segments of the images.
    kept : LastResults
        Results of the method's first steps, kept for a run with other thresholds
        (:mod:`radcons.stages.objects.memo`).
    """

    key: tuple
    disparity: np.ndarray | None
    searched: tuple[float, float]
    valid_share: float
    factor: int
    failure: str = ""
    work: "ImageWork | None" = None
    kept: LastResults = field(default_factory=LastResults, compare=False, repr=False)

    @staticmethod
    def key_of(
        shape: tuple[int, ...],
        params: ObjectsParams,
        gsd_m: float | None = None,
        disparity_range: tuple[float, float] | None = None,
    ) -> tuple:
        """The :attr:`key` of the matching of a pair of ``shape`` with these arguments of :func:`match_pair`."""
        gsd = resolved_gsd(gsd_m, params)
        census = (params.census_cell_m, params.census_side, params.search_share, params.census_cross_check)
        return (tuple(shape), census, gsd, None if disparity_range is None else tuple(map(float, disparity_range)))


def match_pair(
    reference: np.ndarray,
    target: np.ndarray,
    params: ObjectsParams = ObjectsParams(method="height"),
    *,
    gsd_m: float | None = None,
    disparity_range: tuple[float, float] | None = None,
) -> PairMatching:
    """The census matching of a pair for the height method, kept while its rules are tuned.

    Parameters
    ----------
    reference, target : ndarray
        The working (rectified) pair, NaN where invalid.
    params : ObjectsParams
        Its census fields are used (:class:`PairMatching`).
    gsd_m : float, optional
        Ground sample distance, m (``params.assumed_gsd_m`` without it).
    disparity_range : tuple of float, optional
        Known disparity range (px); else it is searched.

    Returns
    -------
    PairMatching
        With ``failure`` set when the pair is too small or census matching fails.

    Raises
    ------
    InputError
        Images not 2-D, of different shapes or without a valid pixel.
    """
    reference, target = validated_pair(reference, target)
    return match_validated_pair(reference, target, params, resolved_gsd(gsd_m, params), disparity_range)


def resolved_gsd(gsd_m: float | None, params: ObjectsParams) -> float:
    """The ground sample distance (m) the method works at: ``gsd_m`` when positive, else ``params.assumed_gsd_m``."""
    return gsd_m if gsd_m and gsd_m > 0 else params.assumed_gsd_m


def validated_pair(reference: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both images as 2-D float arrays of one shape, each with a valid pixel; else InputError."""
    reference = single_band_image(reference, "reference", 1, "is empty")
    target = single_band_image(target, "target", 1, "is empty")
    if reference.shape != target.shape:
        raise InputError(f"height objects need a rectified pair of one shape, got {reference.shape} and {target.shape}")
    return reference, target


def match_validated_pair(
    reference: np.ndarray,
    target: np.ndarray,
    params: ObjectsParams,
    gsd: float,
    disparity_range: tuple[float, float] | None,
) -> PairMatching:
    """:func:`match_pair` on images checked by :func:`validated_pair`, at the ground sample distance ``gsd`` (m)."""
    key = PairMatching.key_of(reference.shape, params, gsd, disparity_range)
    if min(reference.shape) < _MIN_SIDE:
        reason = f"the pair is too small for a census disparity ({_MIN_SIDE} px a side)"
        return PairMatching(key, None, (0.0, 0.0), 0.0, 0, reason)
    work = ImageWork.start(reference, target, gsd, max(1.0, TEXTURE_SCALE_M / gsd), params)
    factor = census_factor(reference.shape, params.census_cell_m / gsd, params.census_side)
    census = CensusParams(cross_check=params.census_cross_check)
    try:
        disparity, searched, valid_share, factor = coarse_disparity(
            reference, target, factor, params.search_share, census, disparity_range
        )
    except (StageError, ParamsError) as error:
        return PairMatching(key, None, (0.0, 0.0), 0.0, factor, f"census matching failed ({error})")
    return PairMatching(key, disparity, searched, valid_share, factor, "", work)



@dataclass(frozen=True)
class ImageWork:
    """What the height method needs of the images alone, computed beside the census matching.

    The census descriptors of both images, the reference's gradient scales at 0.5 m
    (:class:`radcons.stages.objects.features.ImageScales`) and its graph segments
    (:func:`radcons.stages.objects.searches.missed.reference_segments`, at the scales of the
    searches switched on) do not depend on the disparity. They are computed in a worker
    thread while Pandora matches: both release the GIL for most of their work, and so
    does Pandora's C++. A pair that falls back or is flat leaves its jobs to finish unused.
    The reference and its ground sample distance (m) are kept for the segments at a
    scale not started with the others (a :class:`PairMatching` kept while the searches'
    scales are tuned).
    """

    scales_job: Future
    descriptor_jobs: tuple[Future, Future]
    segment_jobs: dict[float, Future]
    reference: np.ndarray
    gsd: float

    @classmethod
    def start(
        cls, reference: np.ndarray, target: np.ndarray, gsd: float, sigma: float, params: ObjectsParams
    ) -> "ImageWork":
        """Submit one pair's jobs to the worker thread, in the order they are needed.

        ``sigma`` is the smoothing of the gradient scales, px.
        """
        searches = ((params.missed_scale, params.find_missed), (params.removed_scale, params.find_in_removed))
        scales = {scale for scale, used in searches if used}
        return cls(
            _WORKER.submit(ImageScales.of, reference, sigma),
            (_WORKER.submit(census_descriptors, reference), _WORKER.submit(census_descriptors, target)),
            {scale: _WORKER.submit(reference_segments, reference, gsd, scale) for scale in sorted(scales)},
            reference,
            gsd,
        )

    def census(self) -> tuple[np.ndarray, np.ndarray]:
        """Census descriptors of the reference and the target (waits for them)."""
        return self.descriptor_jobs[0].result(), self.descriptor_jobs[1].result()

    def scales(self) -> ImageScales:
        """The reference's gradient scales at 0.5 m (waits for them)."""
        return self.scales_job.result()

    def segments(self, scale: float) -> np.ndarray:
        """The reference's graph segments at ``scale`` (waits for them; a scale not started yet is started now)."""
        if scale not in self.segment_jobs:
            self.segment_jobs[scale] = _WORKER.submit(reference_segments, self.reference, self.gsd, scale)
        return self.segment_jobs[scale].result()

