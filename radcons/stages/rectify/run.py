"""Epipolar resampling of an unrectified pair: from the RPC models, or from the images (affine cameras).

:func:`rectify_pair` chooses. When both images carry RPC camera models (:mod:`radcons.rpc`:
an OSSIM ``.geom`` beside the image, RPC tags in TIFF, NITF or JPEG 2000), the pair is
rectified from them (:mod:`radcons.stages.rectify.rpc`, CNES shareloc's epipolar grids),
unless the models do not fit the pixels (the rows of the RPC-rectified pair do not
correspond); otherwise, and for pairs without models, from the images as below. The method
used and the reason are kept in the result (``method``, ``reason``) and the summary.

Every stage after object association, and dense matching, assume an epipolar-rectified
pair: rows correspond and ``reference(x, y) <-> target(x - d, y)`` (Su et al. 2018 start
from such epipolar images and do not describe this step). Crops of two satellite scenes
are not: their rows differ by tens of pixels, and their sizes, scales and orientations
differ a little. Over a small crop a pushbroom scene is well approximated by
an affine camera, and two affine cameras have parallel epipolar lines (Hartley and
Zisserman 2004, chapter 14; Morgan et al. 2006, "Epipolar resampling of space-borne
linear array scanner scenes using parallel projection", PE&RS 72(11)), so each image is
rectified by one affine map:

1. SIFT keypoints (Lowe 2004) on both images, each stretched to 8 bits between its own
   0.5th and 99.5th percentiles, matched by nearest neighbour with Lowe's ratio test.
2. The affine fundamental matrix ``a x' + b y' + c x + d y + e = 0`` by RANSAC and least
   squares (:mod:`radcons.stages.rectify.epipolar`); ``c**2 + d**2 = 1``.
3. Reference: the rotation ``x_r = d x - c y``, ``y_r = c x + d y`` (angle below 90 deg
   since ``d >= 0``), so epipolar lines become rows and the reference keeps its scale and
   nearly its orientation. Target: rows ``y_t = -(a x' + b y' + e)``, which equals ``y_r``
   at every match up to the epipolar residual (this fixes the target's vertical scale,
   shear and offset), and columns ``x_t = g x' + h y' + k`` fitted by least squares to
   ``x_r`` at the inliers (a horizontal scale, shear and offset removing the best-fitting
   plane of disparity, so the disparities left are the relief, centred on zero).
4. Both images are resampled (``cv2.warpAffine``, float32) into one frame; pixels whose
   interpolation footprint leaves the source, or touches an invalid pixel, are NaN.

The transforms are kept in the result, so rectified images and disparity maps can be taken
back to the original geometry (:meth:`Rectification.to_original`,
:meth:`Rectification.disparity_to_original`,
:meth:`Rectification.correspondences_to_original`).

Choices the method leaves open (exposed in :class:`RectifyParams`):

* The affine model (4 degrees of freedom) rather than a projective fundamental matrix
  (7) with ``cv2.findFundamentalMat`` and ``cv2.stereoRectifyUncalibrated``: for near
  affine cameras the epipoles lie near infinity, the projective estimate is poorly
  conditioned and its rectifying homographies bend the images, leaving more vertical
  parallax at its inliers (``benchmarks/bench_rectify.py`` compares the two).
* ``method``: ``"auto"`` (default) takes the RPC route when both models are there and
  fit, ``"rpc"`` insists on it, ``"affine"`` never takes it. The cameras are not disturbed
  by changes of content between dates (``benchmarks/bench_rectify_rpc.py``).
* The target's columns remove the best disparity plane (a pure rotation of the target
  would keep tilt-induced disparity ramps across the crop).
* ``output_size``: ``"reference"`` (default) is the bounding box of the rotated reference,
  so nothing of the reference is lost and the size stays close to the original.
* Affine cameras cannot tell which view is physically the left one, so the rotation rule
  above fixes the sign of the disparity, and may give higher points smaller disparities.
  With ``orient = "relief"`` (default) the
  pair is then turned by 180 deg when its relief leans downward: buildings and trees
  stand on a ground that is most of the scene, so the disparity of a pair the right way
  up has a long upper tail around its local median
  (:mod:`radcons.stages.rectify.orientation`). ``flip`` turns the result by a further
  180 deg, which negates the disparity.
* ``interpolation``: bicubic by default (sharper than bilinear, so the radiometric stages
  see less resampling blur). ``cv2.warpAffine`` samples positions at 1/32 px.
* A scene whose matches fit one affine map between the images (no relief) does not fix
  the epipolar direction, and a few mismatches lying along a line would decide it; such a
  pair is refused with a :class:`~radcons.errors.StageError` (fewer than ``min_matches``
  inliers with a disparity beyond ``min_relief`` once the best disparity plane is
  removed) rather than rectified along an arbitrary direction.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from radcons.errors import InputError, ParamsError, StageError
from radcons.results import Matches
from radcons.rpc import Rpc
from radcons.stages.rectify.epipolar import (
    AffineEpipolar,
    apply_affine,
    checked_interpolation,
    ransac_affine_epipolar,
    rectified_frame,
    rectifying_maps,
    resample_nan,
    validated_image,
)
from radcons.stages.rectify.features import match_sift
from radcons.stages.rectify.orientation import ORIENTATION_SKEW, relief_skew
from radcons.stages.rectify.params import DISPARITY_PERCENTILES, RectifyParams
from radcons.stages.rectify.rpc import RpcMisfit, RpcRectification, rectify_rpc

__all__ = ["RectifyParams", "Rectification", "rectify_pair", "rectify_affine", "match_sift"]


def _warp(
    image: np.ndarray, matrix: np.ndarray, shape: tuple[int, int], interpolation: str, *, inverse: bool
) -> np.ndarray:
    """Resample ``image`` by an affine map into a grid of ``shape``, NaN where not covered.

    ``matrix`` (3x3) maps source pixel coordinates to destination coordinates, or, with
    ``inverse``, destination coordinates to source coordinates (:func:`resample_nan`).
    """
    flags = cv2.WARP_INVERSE_MAP if inverse else 0
    size = (int(shape[1]), int(shape[0]))
    affine = np.ascontiguousarray(matrix[:2], dtype=np.float64)
    return resample_nan(
        image,
        interpolation,
        lambda array, mode: cv2.warpAffine(
            array, affine, size, flags=flags | mode, borderMode=cv2.BORDER_CONSTANT, borderValue=0.0
        ),
    )


@dataclass(frozen=True)
class Rectification:
    """An epipolar-rectified pair and the affine maps that made it.

    Attributes
    ----------
    reference, target : ndarray, shape ``shape``, float32
        Rectified images, NaN outside their source (and where the source was invalid).
        ``reference(x, y) <-> target(x - d, y)``.
    ref_transform, tgt_transform : ndarray, shape (3, 3), float64
        Affine maps from original pixel coordinates ``(x, y, 1)`` to rectified ones.
        ``ref_transform`` is a rotation (by less than 90 deg unless turned by the
        relief, :attr:`orientation`, or :attr:`RectifyParams.flip`) and a translation.
    shape : tuple of int
        ``(rows, columns)`` of the rectified images.
    residual_parallax_median, residual_parallax_p90 : float
        Median and 90th percentile of ``|y_ref - y_tgt|``, px, at the inlier matches after
        rectification.
    n_matches, n_inliers : int
        SIFT matches after the ratio test, and those RANSAC kept.
    ref_shape, tgt_shape : tuple of int
        Shapes of the original images.
    matches : Matches
        The inlier matches in rectified coordinates.
    disparity_range : tuple of float
        0.5th and 99.5th percentiles of the inlier matches' disparity ``x_ref - x_tgt``,
        px: a search range for dense matching.
    epipolar : AffineEpipolar
        The affine fundamental matrix fitted on the inliers, original pixel coordinates.
    interpolation : str
        Interpolation used to resample the images.
    method, reason : str
        ``"affine"``, and why this method was used (e.g. why RPC models were not).
    orientation : str
        Whether the pair was turned by 180 deg because its relief leaned downward, and
        its relief skew (:mod:`radcons.stages.rectify.orientation`; empty with
        ``orient = "rotation"``).
    """

    reference: np.ndarray
    target: np.ndarray
    ref_transform: np.ndarray
    tgt_transform: np.ndarray
    shape: tuple[int, int]
    residual_parallax_median: float
    residual_parallax_p90: float
    n_matches: int
    n_inliers: int
    ref_shape: tuple[int, int]
    tgt_shape: tuple[int, int]
    matches: Matches
    disparity_range: tuple[float, float]
    epipolar: AffineEpipolar
    interpolation: str
    method: str = "affine"
    reason: str = ""
    orientation: str = ""

    def _side(self, which: str) -> tuple[np.ndarray, tuple[int, int]]:
        if which == "reference":
            return self.ref_transform, self.ref_shape
        if which == "target":
            return self.tgt_transform, self.tgt_shape
        raise InputError(f"which must be 'reference' or 'target', got {which!r}")

    def _rectified_input(self, image: np.ndarray, name: str) -> np.ndarray:
        image = np.asarray(image)
        if image.shape != tuple(self.shape):
            raise InputError(f"{name} must have the rectified shape {self.shape}, got {image.shape}")
        return image

    def to_rectified(
        self, image: np.ndarray, which: str = "reference", interpolation: str | None = None
    ) -> np.ndarray:
        """Resample an image of the original ``which`` geometry into the rectified frame.

        For rasters that share an original image's grid (ground truth, masks; use
        ``interpolation="nearest"`` for labels and masks).

        Parameters
        ----------
        image : ndarray
            Shape of the original reference or target.
        which : str
            ``"reference"`` or ``"target"``.
        interpolation : str, optional
            Defaults to the rectification's own.

        Returns
        -------
        ndarray, shape ``self.shape``, float32, NaN outside the source.
        """
        matrix, shape = self._side(which)
        image = np.asarray(image)
        if image.shape != tuple(shape):
            raise InputError(f"the original {which} has shape {shape}, got an image of shape {image.shape}")
        return _warp(image, matrix, self.shape, checked_interpolation(interpolation, self.interpolation), inverse=False)

    def to_original(
        self, image_rectified: np.ndarray, which: str = "reference", interpolation: str | None = None
    ) -> np.ndarray:
        """Resample a rectified-frame image back onto the original ``which`` grid.

        Parameters
        ----------
        image_rectified : ndarray, shape ``self.shape``
            E.g. a radiometrically corrected rectified image.
        which : str
            ``"reference"`` or ``"target"``: whose original grid to return to.
        interpolation : str, optional
            Defaults to the rectification's own.

        Returns
        -------
        ndarray, float32, the original image's shape, NaN where the rectified frame holds
        nothing (outside it, or NaN there).
        """
        matrix, shape = self._side(which)
        image = self._rectified_input(image_rectified, "image_rectified")
        return _warp(image, matrix, shape, checked_interpolation(interpolation, self.interpolation), inverse=True)

    def disparity_to_original(self, disparity: np.ndarray) -> np.ndarray:
        """Sample a rectified reference-frame disparity map on the original reference grid.

        The reference transform is a rotation, so the values stay in reference pixels,
        measured along the epipolar direction. Nearest-neighbour sampling keeps
        disparity discontinuities sharp.

        Parameters
        ----------
        disparity : ndarray, shape ``self.shape``
            ``reference_r(x, y) <-> target_r(x - d, y)``, NaN where unknown.

        Returns
        -------
        ndarray, shape ``self.ref_shape``, float32, NaN where unknown.
        """
        disparity = self._rectified_input(disparity, "disparity")
        return _warp(disparity, self.ref_transform, self.ref_shape, "nearest", inverse=True)

    def correspondences_to_original(self, disparity: np.ndarray) -> np.ndarray:
        """Original target position matched to each original reference pixel.

        Parameters
        ----------
        disparity : ndarray, shape ``self.shape``
            Rectified reference-frame disparity, NaN where unknown.

        Returns
        -------
        ndarray, shape ``self.ref_shape + (2,)``, float32
            ``(x', y')`` in the original target for the reference pixel ``(x, y)`` at
            ``[y, x]``; NaN where the disparity is unknown.
        """
        d = self.disparity_to_original(disparity).astype(np.float64)
        rows, cols = np.indices(self.ref_shape, dtype=np.float64)
        rectified = apply_affine(self.ref_transform, np.stack([cols.ravel(), rows.ravel()], axis=1))
        rectified[:, 0] -= d.ravel()
        original = apply_affine(np.linalg.inv(self.tgt_transform), rectified)
        return original.reshape(*self.ref_shape, 2).astype(np.float32)


def rectify_pair(
    reference: np.ndarray,
    target: np.ndarray,
    params: RectifyParams = RectifyParams(),
    rpcs: tuple[Rpc, Rpc] | None = None,
    no_rpcs: str = "the images carry no RPC models",
) -> Rectification | RpcRectification:
    """Epipolar-rectify an unrectified pair from its RPC models or, failing them, its images.

    Parameters
    ----------
    reference, target : ndarray
        Single-band images, NaN where invalid; the reference is the left image.
    params : RectifyParams
        ``method`` chooses the route (module notes).
    rpcs : tuple of Rpc, optional
        The models of the reference and the target (:func:`radcons.rpc.read_rpc`).
    no_rpcs : str
        Why ``rpcs`` is None, for the reason recorded in the result.

    Returns
    -------
    Rectification or RpcRectification
        ``method`` and ``reason`` say which route was taken and why.

    Raises
    ------
    InputError
        An image is not 2-D, smaller than 16 px on a side, or entirely invalid.
    StageError
        ``method="rpc"`` without models or with models that do not fit; the affine route
        failed (its reason, and why the RPC route was not taken).
    """
    if params.method == "affine":
        reason = "the rectify method is 'affine'"
    elif rpcs is None:
        if params.method == "rpc":
            raise StageError(f"the rectify method is 'rpc' but {no_rpcs}")
        reason = no_rpcs
    else:
        try:
            rectification = rectify_rpc(reference, target, *rpcs, params)
        except RpcMisfit as exc:
            if params.method == "rpc":
                raise
            reason = f"RPC models not used: {exc.reason}"
        else:
            sources = " / ".join(rpc.source for rpc in rpcs)
            fit = f"{rectification.rpc_row_offset:.2f} px vertical offset before correction"
            return replace(rectification, reason=f"RPC models of both images ({sources}; {fit})")
    try:
        return replace(rectify_affine(reference, target, params), reason=reason)
    except StageError as exc:
        raise StageError(f"{exc.reason} (affine rectification, used because {reason})") from exc


def rectify_affine(
    reference: np.ndarray, target: np.ndarray, params: RectifyParams = RectifyParams()
) -> Rectification:
    """Epipolar-rectify an unrectified pair with affine maps estimated from SIFT matches.

    See the module notes for the method (affine fundamental matrix, HZ section 14.2; rotation
    of the reference, affine map of the target).

    Parameters
    ----------
    reference, target : ndarray
        Single-band images on their original range (any real dtype, computed in float32),
        NaN where invalid; their sizes may differ. The reference is the left image.
    params : RectifyParams

    Returns
    -------
    Rectification

    Raises
    ------
    InputError
        An image is not 2-D, smaller than 16 px on a side, or entirely invalid.
    StageError
        Fewer than ``params.min_matches`` matches or RANSAC inliers (the images do not
        overlap, or the crop is too large for affine cameras), a scene without measurable
        relief (the epipolar direction is undetermined), or a target that the maps would
        mirror.
    """
    reference = validated_image(reference, "reference")
    target = validated_image(target, "target")
    matches = match_sift(reference, target, params)
    if len(matches) < params.min_matches:
        raise StageError(
            f"only {len(matches)} SIFT matches between the images passed the ratio test "
            f"(rectification needs at least {params.min_matches}): do the images overlap?"
        )
    try:
        geometry, inliers = ransac_affine_epipolar(
            matches.ref_xy, matches.tgt_xy, params.ransac_threshold, params.ransac_trials, params.seed
        )
    except InputError as exc:
        raise StageError(f"no affine epipolar geometry fits the {len(matches)} matches: {exc}") from exc
    n_inliers = int(inliers.sum())
    if n_inliers < params.min_matches:
        raise StageError(
            f"only {n_inliers} of {len(matches)} matches agree on one affine epipolar geometry within "
            f"{params.ransac_threshold} px (rectification needs at least {params.min_matches}): the images may "
            "not overlap, or the crop is too large for an affine camera model"
        )
    ref_xy = matches.ref_xy[inliers].astype(np.float64)
    tgt_xy = matches.tgt_xy[inliers].astype(np.float64)
    counts = (len(matches), n_inliers)
    rectification = _rectified(reference, target, geometry, ref_xy, tgt_xy, counts, False, params)
    turned, orientation = False, ""
    if params.orient == "relief":
        turned, orientation = _relief_turns(rectification)
    if turned != params.flip:
        rectification = _rectified(reference, target, geometry, ref_xy, tgt_xy, counts, True, params)
    if params.flip:
        orientation = f"{orientation}; then turned by 180 deg (flip)" if orientation else "turned by 180 deg (flip)"
    return replace(rectification, orientation=orientation)


def _relief_turns(rectification: Rectification) -> tuple[bool, str]:
    """Whether the rotation rule's pair should be turned by 180 deg (its relief leans downward), and why."""
    try:
        skew = relief_skew(rectification.reference, rectification.target, rectification.disparity_range)
    except (InputError, StageError, ParamsError) as exc:
        return False, f"as the rotation rule turned it: its relief could not be measured ({exc})"
    if skew < -ORIENTATION_SKEW:
        return True, f"turned by 180 deg from the rotation rule: relief skew {skew:+.2f}, below -{ORIENTATION_SKEW:g}"
    return False, f"as the rotation rule turned it: relief skew {skew:+.2f}, not below -{ORIENTATION_SKEW:g}"


def _rectified(
    reference: np.ndarray,
    target: np.ndarray,
    geometry: AffineEpipolar,
    ref_xy: np.ndarray,
    tgt_xy: np.ndarray,
    counts: tuple[int, int],
    flip: bool,
    params: RectifyParams,
) -> Rectification:
    """The pair rectified by the maps of ``geometry``, turned by 180 deg when ``flip``.

    ``counts`` are the SIFT matches after the ratio test and the RANSAC inliers
    (``ref_xy``, ``tgt_xy``).
    """
    ref_map, tgt_map = rectifying_maps(geometry, ref_xy, tgt_xy, flip)
    if np.linalg.det(tgt_map[:2, :2]) <= 0:
        raise StageError(
            "the rectifying map would mirror the target: the matches are inconsistent with a stereo pair"
        )
    shift, shape = rectified_frame(ref_map, tgt_map, reference.shape, target.shape, params.output_size)
    ref_transform, tgt_transform = shift @ ref_map, shift @ tgt_map
    ref_rect, tgt_rect = apply_affine(ref_transform, ref_xy), apply_affine(tgt_transform, tgt_xy)
    parallax = np.abs(ref_rect[:, 1] - tgt_rect[:, 1])
    disparity = ref_rect[:, 0] - tgt_rect[:, 0]
    n_relief = int((np.abs(disparity) > params.min_relief).sum())
    if n_relief < params.min_matches:
        raise StageError(
            f"only {n_relief} inlier matches have a disparity more than {params.min_relief} px off the best "
            f"disparity plane (rectification needs at least {params.min_matches}): the scene shows too little "
            "relief to fix the epipolar direction; if the pair is already rectified, mark it so"
        )
    low, high = np.percentile(disparity, DISPARITY_PERCENTILES)
    return Rectification(
        reference=_warp(reference, ref_transform, shape, params.interpolation, inverse=False),
        target=_warp(target, tgt_transform, shape, params.interpolation, inverse=False),
        ref_transform=ref_transform,
        tgt_transform=tgt_transform,
        shape=shape,
        residual_parallax_median=float(np.median(parallax)),
        residual_parallax_p90=float(np.percentile(parallax, 90)),
        n_matches=counts[0],
        n_inliers=counts[1],
        ref_shape=tuple(reference.shape),
        tgt_shape=tuple(target.shape),
        matches=Matches(ref_rect.astype(np.float32), tgt_rect.astype(np.float32)),
        disparity_range=(float(low), float(high)),
        epipolar=geometry,
        interpolation=params.interpolation,
    )
