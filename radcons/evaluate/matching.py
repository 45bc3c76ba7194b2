"""Dense matching of a rectified pair: OpenCV's semi-global (or block) matcher, or census.

The paper evaluates radiometric consistency by area-based dense matching (section 6.4);
semi-global matching (Hirschmueller 2008, OpenCV ``StereoSGBM``) is the standard such
matcher. Every method of a comparison is matched with the same parameters and the same
disparity range, so that only the images differ.

Two matchers are registered in :data:`MATCHERS`, each with its own frozen parameters, and
each maps the images to its input itself: "sgbm" (OpenCV, both images on the reference's
8-bit range, :class:`MatcherParams`) and "census" (census + SGM by CNES Pandora, each image
on its own range, :class:`radcons.numerics.census.CensusParams`). :func:`dense_disparity`
runs the matcher its parameters belong to; :func:`matcher_params` makes a matcher's
parameters from its name and :func:`matcher_name` names the matcher of some parameters.

Sign convention (the project's and OpenCV's): ``reference(x, y) <-> target(x - d, y)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from radcons.errors import InputError, ParamsError
from radcons.numerics.census import CensusParams, census_disparity
from radcons.numerics.stretch import robust_range
from radcons.numerics.valid_pixels import overlap_share
from radcons.results import Matches

__all__ = [
    "MatcherParams",
    "MATCHERS",
    "matcher_params",
    "matcher_name",
    "dense_disparity",
    "to_uint8_pair",
    "disparity_range_from_truth",
    "disparity_range_from_matches",
    "widen_range",
    "left_right_shares",
    "left_right_consistent",
    "searched_bounds",
]

_MODES = {
    "sgbm": cv2.STEREO_SGBM_MODE_SGBM,
    "hh": cv2.STEREO_SGBM_MODE_HH,
    "sgbm_3way": cv2.STEREO_SGBM_MODE_SGBM_3WAY,
    "hh4": cv2.STEREO_SGBM_MODE_HH4,
}




@dataclass(frozen=True)
class MatcherParams:
    """Parameters of the dense matcher.

    The paper does not give its matcher's settings; the defaults are OpenCV's usual
    semi-global settings for a grey image (P1 = 8 * block^2, P2 = 32 * block^2).

    Attributes
    ----------
    method : {"sgbm", "bm"}
        Semi-global block matching or plain block matching.
    block_size : int
        Odd matching window size in pixels (BM needs at least 5).
    p1_factor, p2_factor : int
        SGBM smoothness penalties ``P1 = p1_factor * block_size**2`` (disparity change of
        1) and ``P2 = p2_factor * block_size**2`` (larger changes).
    uniqueness_ratio : int
        Margin in percent by which the best cost must beat the second best.
    speckle_window_size : int
        Largest disparity blob size treated as speckle and invalidated (0 = off).
    speckle_range : int
        Disparity variation in pixels allowed inside one connected blob.
    disp12_max_diff : int
        Left-right consistency tolerance in pixels (negative = off).
    pre_filter_cap : int
        Clipping of the prefiltered image (x-derivative for SGBM).
    min_disparity : int or None
        Smallest disparity searched; None takes it from the caller's disparity range.
    num_disparities : int or None
        Number of disparities searched (rounded up to a multiple of 16); None takes it
        from the caller's disparity range.
    mode : {"sgbm", "hh", "sgbm_3way", "hh4"}
        SGBM path mode (5 paths, 8 paths full, 3-way, 4 paths).
    """

    method: str = "sgbm"
    block_size: int = 5
    p1_factor: int = 8
    p2_factor: int = 32
    uniqueness_ratio: int = 10
    speckle_window_size: int = 100
    speckle_range: int = 2
    disp12_max_diff: int = 1
    pre_filter_cap: int = 63
    min_disparity: int | None = None
    num_disparities: int | None = None
    mode: str = "sgbm"

    def __post_init__(self) -> None:
        if self.method not in ("sgbm", "bm"):
            raise ParamsError(f"matcher method must be 'sgbm' or 'bm', got {self.method!r}")
        if self.mode not in _MODES:
            raise ParamsError(f"matcher mode must be one of {sorted(_MODES)}, got {self.mode!r}")
        low = 5 if self.method == "bm" else 1
        if self.block_size < low or self.block_size % 2 == 0:
            raise ParamsError(f"block_size must be odd and >= {low}, got {self.block_size}")
        if not 0 < self.p1_factor < self.p2_factor:
            raise ParamsError("need 0 < p1_factor < p2_factor")
        if self.num_disparities is not None and self.num_disparities < 1:
            raise ParamsError(f"num_disparities must be positive, got {self.num_disparities}")
        if self.uniqueness_ratio < 0 or self.speckle_window_size < 0 or self.speckle_range < 0:
            raise ParamsError("uniqueness_ratio, speckle_window_size and speckle_range must be >= 0")
        if self.pre_filter_cap < 1:
            raise ParamsError("pre_filter_cap must be positive")


#: Dense matchers by name -> the class of their parameters (defaults: the matcher's).
MATCHERS: dict[str, type[MatcherParams] | type[CensusParams]] = {"sgbm": MatcherParams, "census": CensusParams}


def matcher_params(name: str, **overrides: object) -> MatcherParams | CensusParams:
    """Parameters of the matcher called ``name``: its defaults, with ``overrides`` set.

    Raises
    ------
    ParamsError
        No matcher of that name, or an override it does not have or rejects.
    """
    if name not in MATCHERS:
        raise ParamsError(f"unknown matcher {name!r}: choose one of {', '.join(MATCHERS)}")
    try:
        return MATCHERS[name](**overrides)
    except TypeError as error:
        raise ParamsError(f"matcher {name!r}: {error}") from error


def matcher_name(params: MatcherParams | CensusParams) -> str:
    """The name in :data:`MATCHERS` of the matcher ``params`` belong to."""
    for name, kind in MATCHERS.items():
        if type(params) is kind:
            return name
    raise ParamsError(f"not the parameters of a registered matcher: {type(params).__name__}")


def to_uint8_pair(reference: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Map both images to 8 bits with one linear mapping: the reference's robust range.

    The range is the reference's 0.5th to 99.5th percentile of valid pixels, and the same
    mapping (clipped to 0..255) is applied to both images, so the radiometric differences
    between them stay as they are (a per-image stretch would hide part of what radiometric
    normalisation must fix). The reference is the radiometry every method aims at, so every
    method's pair is judged on the same scale; a range taken from both images, or from
    their extremes, would let a few outlying pixels of one method's output lower the
    contrast the matcher sees, and change its score for reasons that have nothing to do
    with consistency. NaN pixels become 0; :func:`dense_disparity` invalidates their
    disparities.
    """
    finite = reference[np.isfinite(reference)]
    if finite.size == 0:
        raise InputError("the reference has no valid pixel")
    low, high = (float(v) for v in robust_range(finite))
    if high <= low:
        low, high = float(finite.min()), float(finite.max())
    if high <= low:
        high = low + 1.0
    scale = 255.0 / (high - low)
    out = []
    for image in (reference, target):
        scaled = (np.nan_to_num(image.astype(np.float32), nan=low) - low) * scale
        out.append(np.clip(np.rint(scaled), 0, 255).astype(np.uint8))
    return out[0], out[1]


def _checked_range(disparity_range: tuple[float, float]) -> tuple[float, float]:
    """``(low, high)`` of a disparity range, refused unless finite with ``high >= low``."""
    low, high = float(disparity_range[0]), float(disparity_range[1])
    if not (math.isfinite(low) and math.isfinite(high) and high >= low):
        raise ParamsError(f"disparity_range must be finite with high >= low, got {disparity_range}")
    return low, high


def _search_range(params: MatcherParams, disparity_range: tuple[float, float] | None) -> tuple[int, int]:
    """Return OpenCV's ``(minDisparity, numDisparities)``."""
    min_disp, num_disp = params.min_disparity, params.num_disparities
    if min_disp is None or num_disp is None:
        if disparity_range is None:
            raise ParamsError(
                "no disparity range: set min_disparity and num_disparities or pass disparity_range"
            )
        low, high = _checked_range(disparity_range)
        if min_disp is None:
            min_disp = math.floor(low)
        if num_disp is None:
            num_disp = math.ceil(high) - min_disp + 1
    return int(min_disp), int(16 * math.ceil(num_disp / 16))


def dense_disparity(
    reference: np.ndarray,
    target: np.ndarray,
    params: MatcherParams | CensusParams = MatcherParams(),
    disparity_range: tuple[float, float] | None = None,
) -> np.ndarray:
    """Dense disparity of the reference by SGBM (or BM), or by census with ``CensusParams``.

    Parameters
    ----------
    reference, target : ndarray
        Rectified images of the same shape, any value range, NaN where invalid. For SGBM
        both are mapped to 8 bits by :func:`to_uint8_pair` (one mapping for both); census
        maps each on its own (:func:`radcons.numerics.census.to_census_input`).
    params : MatcherParams or CensusParams
        The matcher's parameters; their class chooses the matcher (:data:`MATCHERS`).
    disparity_range : (float, float), optional
        Smallest and largest disparity to search, used where ``params`` leaves
        ``min_disparity`` / ``num_disparities`` at None (census always needs it). For SGBM
        the number of disparities is rounded up to a multiple of 16, as OpenCV requires.

    Returns
    -------
    ndarray of float32
        Disparity in the reference frame, ``reference(x, y) <-> target(x - d, y)``. SGBM:
        OpenCV's 1/16 px resolution; NaN where the matcher failed (no unique match, left-
        right check, speckle, left border) and where the reference pixel or its match in
        the target is invalid. Census: see
        :func:`radcons.numerics.census.census_disparity`.

    Raises
    ------
    InputError
        Images not 2-D of the same shape.
    ParamsError
        No disparity range.
    StageError
        Census only: Pandora failed.

    References
    ----------
    Hirschmueller, H. (2008). Stereo processing by semiglobal matching and mutual
    information. IEEE TPAMI 30(2), 328-341.
    """
    if isinstance(params, CensusParams):
        if disparity_range is None:
            raise ParamsError("no disparity range: census matching needs disparity_range")
        return census_disparity(reference, target, disparity_range, params)
    reference = np.asarray(reference)
    target = np.asarray(target)
    if reference.ndim != 2 or reference.shape != target.shape:
        raise InputError(
            f"dense matching needs two 2-D images of the same shape, got {reference.shape} and {target.shape}"
        )
    min_disp, num_disp = _search_range(params, disparity_range)
    left, right = to_uint8_pair(reference, target)
    if params.method == "sgbm":
        area = params.block_size**2
        matcher = cv2.StereoSGBM_create(
            minDisparity=min_disp,
            numDisparities=num_disp,
            blockSize=params.block_size,
            P1=params.p1_factor * area,
            P2=params.p2_factor * area,
            disp12MaxDiff=params.disp12_max_diff,
            preFilterCap=params.pre_filter_cap,
            uniquenessRatio=params.uniqueness_ratio,
            speckleWindowSize=params.speckle_window_size,
            speckleRange=params.speckle_range,
            mode=_MODES[params.mode],
        )
    else:
        matcher = cv2.StereoBM_create(numDisparities=num_disp, blockSize=params.block_size)
        matcher.setMinDisparity(min_disp)
        matcher.setUniquenessRatio(params.uniqueness_ratio)
        matcher.setSpeckleWindowSize(params.speckle_window_size)
        matcher.setSpeckleRange(params.speckle_range)
        matcher.setDisp12MaxDiff(params.disp12_max_diff)
        matcher.setPreFilterCap(min(params.pre_filter_cap, 63))
    raw = matcher.compute(left, right)
    disparity = raw.astype(np.float32) / 16.0
    disparity[raw < min_disp * 16] = np.nan
    _invalidate_nodata(disparity, np.isfinite(reference), np.isfinite(target))
    return disparity


def _invalidate_nodata(disparity: np.ndarray, valid_ref: np.ndarray, valid_tgt: np.ndarray) -> None:
    """Set NaN where the reference pixel or its nearest match in the target is invalid."""
    disparity[~valid_ref] = np.nan
    if valid_tgt.all():
        return
    rows, cols = np.nonzero(np.isfinite(disparity))
    match_cols = np.rint(cols - disparity[rows, cols]).astype(np.intp)
    inside = (match_cols >= 0) & (match_cols < disparity.shape[1])
    bad = ~inside
    bad[inside] = ~valid_tgt[rows[inside], match_cols[inside]]
    disparity[rows[bad], cols[bad]] = np.nan


def disparity_range_from_truth(ground_truth: np.ndarray, margin: float = 2.0) -> tuple[float, float]:
    """Disparity search range from a ground-truth map: ``(nanmin - margin, nanmax + margin)``.

    Raises
    ------
    InputError
        The map has no finite value.
    """
    finite = ground_truth[np.isfinite(ground_truth)]
    if finite.size == 0:
        raise InputError("the ground-truth disparity has no known value")
    return float(finite.min()) - margin, float(finite.max()) + margin


def disparity_range_from_matches(
    matches: Matches | np.ndarray, margin: float = 4.0, quantile: float = 0.01
) -> tuple[float, float]:
    """Disparity search range from sparse matches, robust to a few wrong ones.

    Parameters
    ----------
    matches : Matches or ndarray
        Feature matches, or their horizontal disparities ``x_ref - x_tgt``.
    margin : float
        Pixels added on both sides.
    quantile : float
        The range spans the ``quantile`` to ``1 - quantile`` quantiles of the disparities
        (0 = their minimum and maximum).

    Raises
    ------
    InputError
        No match with a finite disparity.
    ParamsError
        ``quantile`` outside [0, 0.5).
    """
    if not 0.0 <= quantile < 0.5:
        raise ParamsError(f"quantile must be in [0, 0.5), got {quantile}")
    values = matches.disparity if isinstance(matches, Matches) else np.asarray(matches, np.float64)
    values = values[np.isfinite(values)]
    if values.size == 0:
        raise InputError("no sparse match to take a disparity range from")
    low, high = np.quantile(values, [quantile, 1.0 - quantile])
    return float(low) - margin, float(high) + margin


def widen_range(disparity_range: tuple[float, float], share: float = 0.1, pixels: float = 4.0) -> tuple[float, float]:
    """A disparity range widened on both sides by ``share`` of its span plus ``pixels``.

    Raises
    ------
    ParamsError
        A range that is not finite with ``high >= low``, or a negative margin.
    """
    low, high = _checked_range(disparity_range)
    if share < 0 or pixels < 0:
        raise ParamsError(f"the margin must be >= 0, got share {share} and pixels {pixels}")
    margin = share * (high - low) + pixels
    return low - margin, high + margin


def left_right_shares(
    reference: np.ndarray,
    target: np.ndarray,
    disparity: np.ndarray,
    params: MatcherParams | CensusParams,
    disparity_range: tuple[float, float],
    tolerance: float = 1.0,
) -> tuple[float, float]:
    """Shares of the pair's overlap with a disparity, and with one the target confirms.

    The overlap is where both images hold data at the same position: a reference pixel
    facing the target's nodata (an epipolar frame's corners) cannot be matched, and is
    not counted against the pair (disparities are small beside the frame, so the same
    position stands for the match's).

    The target's own disparity is matched by the same matcher on the mirrored pair
    (mirroring turns ``target(x') <-> reference(x' + d)`` into the project's convention, so
    the same ``disparity_range`` applies); a reference pixel ``x`` with disparity ``d``
    passes the left-right check when the target's disparity at ``round(x - d)`` is within
    ``tolerance`` px of ``d``. Census with Pandora's accurate cross-check at ``tolerance``
    or less has made that check already (its right map is a second matching too): its
    disparities are all consistent, and it is not matched again. Without ground truth, the
    second share is what methods are compared on: a pair made more consistent is matched,
    both ways, in more places.

    Parameters
    ----------
    reference, target : ndarray
        The images ``disparity`` was matched on (same shape, NaN where invalid).
    disparity : ndarray
        The reference's disparity by :func:`dense_disparity` with ``params`` (NaN where
        it failed); census' is taken as it is (see above).
    params : MatcherParams or CensusParams
        The matcher that made ``disparity``.
    disparity_range : (float, float)
        The range it searched.
    tolerance : float
        Largest difference, px, between the two disparities of a consistent pixel.

    Returns
    -------
    matched : float
        Share of the overlap's pixels with a finite disparity.
    consistent : float
        Share of the overlap's pixels whose disparity passes the left-right check.

    Raises
    ------
    InputError
        Arrays of different shapes, or a reference without a valid pixel.
    """
    consistent = left_right_consistent(reference, target, disparity, params, disparity_range, tolerance)
    return overlap_share(np.isfinite(disparity), reference, target), overlap_share(consistent, reference, target)


def left_right_consistent(
    reference: np.ndarray,
    target: np.ndarray,
    disparity: np.ndarray,
    params: MatcherParams | CensusParams,
    disparity_range: tuple[float, float],
    tolerance: float = 1.0,
) -> np.ndarray:
    """Where the reference's disparity passes the left-right check of :func:`left_right_shares`.

    Parameters
    ----------
    reference, target, disparity, params, disparity_range, tolerance
        As for :func:`left_right_shares`.

    Returns
    -------
    ndarray of bool
        True on the valid reference pixels whose finite disparity the target's own
        disparity (matched on the mirrored pair) confirms within ``tolerance`` px; census
        with Pandora's accurate cross-check at ``tolerance`` or less: every valid pixel
        with a finite disparity.

    Raises
    ------
    InputError
        Arrays of different shapes, or a reference without a valid pixel.
    """
    if not reference.shape == target.shape == disparity.shape:
        raise InputError(
            f"left-right check needs arrays of one shape, got {reference.shape}, {target.shape} and {disparity.shape}"
        )
    valid = np.isfinite(reference)
    if not valid.any():
        raise InputError("the reference has no valid pixel")
    finite = np.isfinite(disparity) & valid
    if isinstance(params, CensusParams) and params.cross_check == "accurate" and params.cross_check_threshold <= tolerance:
        return finite
    rows, cols = np.nonzero(finite)
    right = dense_disparity(target[:, ::-1], reference[:, ::-1], params, disparity_range)[:, ::-1]
    values = disparity[rows, cols]
    match = np.rint(cols - values).astype(np.intp)
    inside = (match >= 0) & (match < disparity.shape[1])
    consistent = np.zeros(disparity.shape, bool)
    agree = np.abs(right[rows[inside], match[inside]] - values[inside]) <= tolerance
    consistent[rows[inside][agree], cols[inside][agree]] = True
    return consistent


def searched_bounds(params: MatcherParams | CensusParams, disparity_range: tuple[float, float]) -> tuple[int, int]:
    """The smallest and largest disparity the matcher really searches for ``disparity_range``.

    SGBM searches ``numDisparities`` values from ``minDisparity`` (the count rounded up to
    a multiple of 16, :func:`dense_disparity`); census the whole pixels from the floor of
    the range's low end to the ceiling of its high end.

    Raises
    ------
    ParamsError
        A range that is not finite with ``high >= low``.
    """
    low, high = _checked_range(disparity_range)
    if isinstance(params, CensusParams):
        return math.floor(low), math.ceil(high)
    min_disp, num_disp = _search_range(params, disparity_range)
    return min_disp, min_disp + num_disp - 1
