"""Affine epipolar geometry of a stereo pair from point matches: least squares and RANSAC.

Over a small crop a pushbroom satellite camera is well approximated by an affine camera
(Hartley and Zisserman 2004, "Multiple View Geometry", 2nd ed., section 6.3.4 and
chapter 14; Morgan, Kim, Habib and Lee 2006, "Epipolar resampling of space-borne linear
array scanner scenes using parallel projection", PE&RS 72(11)). Two affine cameras have
an *affine fundamental matrix* (HZ section 14.2)::

        [0 0 a]
    F = [0 0 b]      x'^T F x = a x' + b y' + c x + d y + e = 0
        [c d e]

for a reference point ``(x, y)`` and its target match ``(x', y')``: all epipolar lines of
one image are parallel, with normal ``(c, d)`` in the reference and ``(a, b)`` in the
target.

Choices, made here and documented:

* Normalisation ``c**2 + d**2 = 1`` (with ``d >= 0``). The epipolar residual
  ``c x + d y + a x' + b y' + e`` is then, in reference pixels, exactly the vertical
  parallax that remains after rectification (:mod:`radcons.stages.rectify.run` maps the
  reference row to ``c x + d y`` and the target row to ``-(a x' + b y' + e)``), so the
  least-squares fit below minimises the quantity the rectification is judged by, and the
  RANSAC threshold is a vertical parallax in pixels. The Gold Standard fit of HZ
  section 14.3 (total least squares, ``a**2 + b**2 + c**2 + d**2 = 1``) minimises a
  4-D distance instead, which splits the error between both images.
* Least squares under that constraint is a 2x2 eigenproblem: for a fixed ``(c, d)`` the
  best ``(a, b, e)`` is a linear regression on the target coordinates, and what remains
  is minimised over unit ``(c, d)`` by the eigenvector of the smallest eigenvalue of
  ``M = A_r^T (I - P_t) A_r`` (``A_r`` the reference coordinates, ``P_t`` the projector on
  the span of the target coordinates and 1). When the matches fit one affine map between
  the images (a planar scene) ``M`` vanishes and the epipolar direction is undetermined;
  the caller checks that enough matches show relief.
* RANSAC (Fischler and Bolles 1981) with minimal samples of 4 matches (4 degrees of
  freedom), solved as the null vector of the 4x5 system; samples whose system has rank
  below 4 (target points on a line, all points on one affine map) are skipped, a
  degeneracy test in the spirit of DEGENSAC (Chum, Werner and Matas 2005). Hypotheses are
  solved in batches with numpy and ranked by the MSAC cost (truncated squared residual;
  Torr and Zisserman 2000), which ranks equal inlier counts by their fit. The winner is
  refined by alternating least squares on its inliers and re-selection of the inliers
  (local optimisation, Chum, Matas and Kittler 2003).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import cv2
import numpy as np

from radcons.errors import InputError, StageError
from radcons.stages.rectify.params import INTERPOLATIONS
from radcons.validate import single_band_image

__all__ = [
    "AffineEpipolar", "fit_affine_epipolar", "ransac_affine_epipolar", "rectifying_maps",
    "rectified_frame", "apply_affine", "resample_nan", "checked_interpolation", "validated_image",
]

_MIN_SAMPLE = 4
_BATCH = 256
_RANK_TOL = 1e-7
_MAX_REFINEMENTS = 20
_CONFIDENCE = 0.999
#: Half-width beyond the bilinear 2x2 footprint of each interpolation's footprint, px.
_FOOTPRINT_RADIUS = {"nearest": 0, "linear": 0, "cubic": 1, "lanczos": 3}
#: A bilinearly resampled validity mask at or above this is fully covered (weights sum to 1).
_COVERED = 1.0 - 1e-5


@dataclass(frozen=True)
class AffineEpipolar:
    """An affine fundamental matrix ``a x' + b y' + c x + d y + e = 0`` in pixel units.

    Attributes
    ----------
    coefficients : ndarray, shape (5,), float64
        ``(a, b, c, d, e)`` with ``c**2 + d**2 = 1`` and ``d >= 0``.
    """

    coefficients: np.ndarray

    @property
    def matrix(self) -> np.ndarray:
        """The 3x3 affine fundamental matrix F with ``x'^T F x = 0`` (HZ section 14.2)."""
        a, b, c, d, e = self.coefficients
        return np.array([[0.0, 0.0, a], [0.0, 0.0, b], [c, d, e]])

    def residuals(self, ref_xy: np.ndarray, tgt_xy: np.ndarray) -> np.ndarray:
        """Signed epipolar residual of each match, px (the rectified vertical parallax).

        Parameters
        ----------
        ref_xy, tgt_xy : ndarray, shape (N, 2)
            Matched ``(x, y)`` positions in the reference and the target.

        Returns
        -------
        ndarray, shape (N,), float64
        """
        a, b, c, d, e = self.coefficients
        ref_xy = np.asarray(ref_xy, np.float64)
        tgt_xy = np.asarray(tgt_xy, np.float64)
        return c * ref_xy[:, 0] + d * ref_xy[:, 1] + a * tgt_xy[:, 0] + b * tgt_xy[:, 1] + e


@dataclass(frozen=True)
class _Normalisation:
    """Centre each image's points and divide all coordinates by one common scale."""

    ref_mean: np.ndarray
    tgt_mean: np.ndarray
    scale: float

    @classmethod
    def of(cls, ref_xy: np.ndarray, tgt_xy: np.ndarray) -> "_Normalisation":
        ref_mean, tgt_mean = ref_xy.mean(axis=0), tgt_xy.mean(axis=0)
        spread = np.sqrt((((ref_xy - ref_mean) ** 2).sum() + ((tgt_xy - tgt_mean) ** 2).sum()) / (4 * len(ref_xy)))
        return cls(ref_mean, tgt_mean, float(spread) if spread > 0 else 1.0)

    def design(self, ref_xy: np.ndarray, tgt_xy: np.ndarray) -> np.ndarray:
        """Rows ``(x', y', x, y, 1)`` in normalised coordinates, shape (N, 5)."""
        ref = (ref_xy - self.ref_mean) / self.scale
        tgt = (tgt_xy - self.tgt_mean) / self.scale
        return np.column_stack([tgt, ref, np.ones(len(ref))])

    def to_pixels(self, coefficients: np.ndarray) -> np.ndarray:
        """Coefficients ``(a, b, c, d, e)`` of normalised coordinates -> pixel coordinates.

        ``(c, d)`` must already be unit length; the common scale leaves it unit length.
        """
        a, b, c, d, e = coefficients
        e_px = self.scale * e - np.dot([c, d], self.ref_mean) - np.dot([a, b], self.tgt_mean)
        out = np.array([a, b, c, d, e_px])
        return -out if d < 0 or (d == 0 and c < 0) else out


def _checked(ref_xy: np.ndarray, tgt_xy: np.ndarray, minimum: int) -> tuple[np.ndarray, np.ndarray]:
    ref_xy = np.asarray(ref_xy, np.float64)
    tgt_xy = np.asarray(tgt_xy, np.float64)
    if ref_xy.ndim != 2 or ref_xy.shape[1:] != (2,) or ref_xy.shape != tgt_xy.shape:
        raise InputError(
            f"matches must be two (N, 2) arrays of equal length, got {ref_xy.shape} and {tgt_xy.shape}"
        )
    if len(ref_xy) < minimum:
        raise InputError(f"the affine epipolar geometry needs at least {minimum} matches, got {len(ref_xy)}")
    if not (np.isfinite(ref_xy).all() and np.isfinite(tgt_xy).all()):
        raise InputError("match coordinates hold NaN or infinite values")
    return ref_xy, tgt_xy


def fit_affine_epipolar(ref_xy: np.ndarray, tgt_xy: np.ndarray) -> AffineEpipolar:
    """Least-squares affine fundamental matrix minimising the rectified vertical parallax.

    Minimises ``sum (c x + d y + a x' + b y' + e)**2`` subject to ``c**2 + d**2 = 1``
    (HZ section 14.2, with the normalisation of this module's notes), in closed form.

    Parameters
    ----------
    ref_xy, tgt_xy : ndarray, shape (N, 2)
        Matched ``(x, y)`` positions, N >= 5 (4 give an exact fit, see
        :func:`ransac_affine_epipolar`).

    Returns
    -------
    AffineEpipolar

    Raises
    ------
    InputError
        Fewer than 5 matches, mismatched shapes, non-finite coordinates, or target
        points all on one line.
    """
    ref_xy, tgt_xy = _checked(ref_xy, tgt_xy, _MIN_SAMPLE + 1)
    norm = _Normalisation.of(ref_xy, tgt_xy)
    design = norm.design(ref_xy, tgt_xy)
    target_part, reference_part = design[:, [0, 1, 4]], design[:, 2:4]
    basis, triangular = np.linalg.qr(target_part)
    if np.abs(np.diag(triangular)).min() <= _RANK_TOL * np.abs(triangular).max():
        raise InputError("the target match positions lie on one line; they cannot fix an epipolar geometry")
    remainder = reference_part - basis @ (basis.T @ reference_part)
    normal = np.linalg.eigh(remainder.T @ remainder)[1][:, 0]
    a, b, e = -np.linalg.lstsq(target_part, reference_part @ normal, rcond=None)[0]
    return AffineEpipolar(norm.to_pixels(np.array([a, b, normal[0], normal[1], e])))


def _minimal_hypotheses(design: np.ndarray, samples: np.ndarray) -> np.ndarray:
    """Exact models of 4-match samples: (K, 5) coefficients with unit ``(c, d)``.

    Rank-deficient samples, and models that ignore the reference coordinates, get NaN.
    """
    systems = design[samples]
    _, singular, vt = np.linalg.svd(systems)
    models = vt[:, -1, :]
    normal_length = np.hypot(models[:, 2], models[:, 3])
    degenerate = (singular[:, 3] <= _RANK_TOL * singular[:, 0]) | (normal_length <= _RANK_TOL)
    models = models / np.where(degenerate, np.nan, normal_length)[:, None]
    return models


def _trials_needed(inlier_fraction: float) -> float:
    """Samples that draw one all-inlier sample with probability ``_CONFIDENCE``."""
    all_inliers = inlier_fraction**_MIN_SAMPLE
    if all_inliers >= 1.0:
        return 1.0
    if all_inliers <= 0.0:
        return np.inf
    return np.log(1.0 - _CONFIDENCE) / np.log1p(-all_inliers)


def ransac_affine_epipolar(
    ref_xy: np.ndarray,
    tgt_xy: np.ndarray,
    threshold: float,
    trials: int = 2000,
    rng: np.random.Generator | int | None = 0,
) -> tuple[AffineEpipolar, np.ndarray]:
    """Robust affine fundamental matrix: MSAC on 4-match samples, then least squares.

    Parameters
    ----------
    ref_xy, tgt_xy : ndarray, shape (N, 2)
        Matched ``(x, y)`` positions, N >= 5.
    threshold : float
        Largest epipolar residual (rectified vertical parallax), px, of an inlier.
    trials : int
        Most random 4-match samples; sampling stops earlier, in batches of 256, once an
        all-inlier sample has been drawn with probability 0.999 given the best inlier
        fraction so far (Fischler and Bolles 1981).
    rng : Generator or int or None
        Random generator or seed of the sampling.

    Returns
    -------
    geometry : AffineEpipolar
        Least-squares fit (:func:`fit_affine_epipolar`) on the final inliers.
    inliers : ndarray of bool, shape (N,)
        Matches whose residual under ``geometry`` is below ``threshold``.

    Raises
    ------
    InputError
        Fewer than 5 matches, a non-positive threshold or trial count, or no sample that
        fixes a model with at least 5 inliers.
    """
    ref_xy, tgt_xy = _checked(ref_xy, tgt_xy, _MIN_SAMPLE + 1)
    if not threshold > 0:
        raise InputError(f"the RANSAC threshold must be positive, got {threshold}")
    if trials < 1:
        raise InputError(f"the RANSAC trial count must be at least 1, got {trials}")
    rng = np.random.default_rng(rng)
    norm = _Normalisation.of(ref_xy, tgt_xy)
    design = norm.design(ref_xy, tgt_xy)
    limit = threshold / norm.scale
    samples = np.sort(rng.integers(0, len(ref_xy), (trials, _MIN_SAMPLE)), axis=1)
    samples = samples[(np.diff(samples, axis=1) > 0).all(axis=1)]
    best_cost, best_model, needed = np.inf, None, len(samples)
    for start in range(0, len(samples), _BATCH):
        if start >= needed:
            break
        models = _minimal_hypotheses(design, samples[start : start + _BATCH])
        models = models[np.isfinite(models).all(axis=1)]
        if not len(models):
            continue
        squared = (models @ design.T) ** 2
        costs = np.minimum(squared, limit**2).sum(axis=1)
        index = int(np.argmin(costs))
        if costs[index] < best_cost:
            best_cost, best_model = costs[index], models[index]
            needed = _trials_needed(float((squared[index] < limit**2).mean()))
    if best_model is None:
        raise InputError("every RANSAC sample was degenerate (matches on one line or one affine map)")
    inliers = np.abs(design @ best_model) < limit
    for _ in range(_MAX_REFINEMENTS):
        if inliers.sum() <= _MIN_SAMPLE:
            raise InputError(f"the best RANSAC model has only {int(inliers.sum())} inliers")
        geometry = fit_affine_epipolar(ref_xy[inliers], tgt_xy[inliers])
        refined = np.abs(geometry.residuals(ref_xy, tgt_xy)) < threshold
        if np.array_equal(refined, inliers):
            break
        inliers = refined
    return geometry, refined


# ----------------------------------------------------------------- affine maps


def apply_affine(matrix: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Map (N, 2) points by a 3x3 affine matrix."""
    return xy @ matrix[:2, :2].T + matrix[:2, 2]


def rectifying_maps(
    geometry: AffineEpipolar, ref_xy: np.ndarray, tgt_xy: np.ndarray, flip: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Reference rotation and target affine map (before the common translation).

    The reference's rows become ``c x + d y``, the target's ``-(a x' + b y' + e)``, and the
    target's columns the least-squares fit of the reference's (see
    :mod:`radcons.stages.rectify.run`); ``flip`` turns both by 180 deg.
    """
    a, b, c, d, e = geometry.coefficients
    sign = -1.0 if flip else 1.0
    a, b, c, d, e = sign * a, sign * b, sign * c, sign * d, sign * e
    ref_map = np.array([[d, -c, 0.0], [c, d, 0.0], [0.0, 0.0, 1.0]])
    x_r = apply_affine(ref_map, ref_xy)[:, 0]
    design = np.column_stack([tgt_xy, np.ones(len(tgt_xy))])
    g, h, k = np.linalg.lstsq(design, x_r, rcond=None)[0]
    tgt_map = np.array([[g, h, k], [-a, -b, -e], [0.0, 0.0, 1.0]])
    return ref_map, tgt_map


def _corners(shape: tuple[int, int]) -> np.ndarray:
    rows, cols = shape
    return np.array([[0, 0], [cols - 1, 0], [0, rows - 1], [cols - 1, rows - 1]], np.float64)


def rectified_frame(
    ref_map: np.ndarray, tgt_map: np.ndarray, ref_shape: tuple[int, int], tgt_shape: tuple[int, int], policy: str
) -> tuple[np.ndarray, tuple[int, int]]:
    """Translation (3x3) into the rectified frame chosen by ``policy``, and its shape."""
    boxes = []
    for matrix, shape in ((ref_map, ref_shape), (tgt_map, tgt_shape)):
        corners = apply_affine(matrix, _corners(shape))
        boxes.append((np.floor(corners.min(axis=0)), np.ceil(corners.max(axis=0))))
    (ref_lo, ref_hi), (tgt_lo, tgt_hi) = boxes
    if policy == "reference":
        lo, hi = ref_lo, ref_hi
    elif policy == "union":
        lo, hi = np.minimum(ref_lo, tgt_lo), np.maximum(ref_hi, tgt_hi)
    else:
        lo, hi = np.maximum(ref_lo, tgt_lo), np.minimum(ref_hi, tgt_hi)
        if (hi < lo).any():
            raise StageError("the rectified images' bounding boxes do not intersect")
    shift = np.array([[1.0, 0.0, -lo[0]], [0.0, 1.0, -lo[1]], [0.0, 0.0, 1.0]])
    return shift, (int(hi[1] - lo[1]) + 1, int(hi[0] - lo[0]) + 1)


def resample_nan(image: np.ndarray, interpolation: str, sample: Callable[[np.ndarray, int], np.ndarray]) -> np.ndarray:
    """Resample ``image`` with ``sample(array, opencv_interpolation)``, NaN where not covered.

    An output pixel is NaN when any source pixel of its interpolation footprint is invalid
    or outside the source. The footprint test resamples the validity mask, eroded to the
    footprint's half-width, bilinearly (OpenCV's vectorised bicubic path spreads a NaN
    border value over 8-pixel blocks, so NaN is never passed to it). ``sample`` is an
    OpenCV warp (``cv2.warpAffine``, ``cv2.remap``) with a zero constant border.
    """
    image = np.asarray(image, dtype=np.float32)
    valid = np.isfinite(image)
    resampled = sample(np.where(valid, image, np.float32(0.0)), INTERPOLATIONS[interpolation])
    radius = _FOOTPRINT_RADIUS[interpolation]
    mask = valid.astype(np.float32)
    if radius:
        kernel = np.ones((2 * radius + 1, 2 * radius + 1), np.uint8)
        mask = cv2.erode(mask, kernel, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    covered = sample(mask, cv2.INTER_NEAREST if interpolation == "nearest" else cv2.INTER_LINEAR)
    resampled[covered < _COVERED] = np.nan
    return resampled


def checked_interpolation(requested: str | None, default: str) -> str:
    """``requested``, or ``default`` when None, after checking it names an interpolation."""
    name = default if requested is None else requested
    if name not in INTERPOLATIONS:
        raise InputError(f"interpolation must be one of {tuple(INTERPOLATIONS)}, got {name!r}")
    return name


def validated_image(image: np.ndarray, name: str) -> np.ndarray:
    """``image`` as float32 after the checks of a rectification input (16 px per side)."""
    return single_band_image(image, name, 16, "is too small to rectify (need 16 px or more per side)")
