"""Epipolar resampling of an unrectified pair from the RPC camera models of both images.

When both images carry RPC models (:mod:`radcons.rpc`) the epipolar geometry comes from
the cameras rather than from the images, as s2p and CARS do, so a change of image content
between two dates does not decide the geometry.

1. Epipolar grids (:mod:`radcons.stages.rectify.rpc_grids`: CNES shareloc's grids every
   ``rpc_grid_step`` px of the epipolar frame at a constant altitude, no DEM; the frame
   turned so that higher points have larger disparity). Both images are resampled with
   ``cv2.remap`` (NaN where the interpolation footprint leaves the source or touches an
   invalid pixel). A first pass (grids :data:`_FIRST_PASS_COARSER` times coarser) uses
   the mean of the two models' height offsets; the median disparity of its SIFT matches
   (step 3) gives the scene's altitude (eq. 3), and the grids are computed again there,
   since pushbroom epipolar lines are exact only near the altitude they were traced at
   (de Franchis et al. 2014, "On stereo-rectification of pushbroom images", ICIP), and a
   scene may lie hundreds of metres from the models' height offset. The first pass's
   matches are carried into the second frame through the original images.
2. Disparity and height: a point ``dh`` metres above the grids' altitude moves by
   ``dh / m`` px along its epipolar line (``m``, metres per pixel of disparity, eq. 1).
3. Check and pointing correction (s2p's "pointing error" correction, de Franchis et al.
   2014, "Automatic sensor orientation refinement of Pleiades stereo images", IGARSS):
   SIFT matches of the two rectified images (an approximate nearest-neighbour search:
   the row check below drops what it gets wrong). Their vertical offset is the models'
   relative pointing error; its mode (the offset shared by most matches within
   ``2 ransac_threshold``) above
   :data:`radcons.stages.rectify.params.UNRECTIFIED_PARALLAX_PX`, or fewer than
   ``min_matches`` matches sharing it, means that the RPCs do not fit the pixels (e.g. a
   crop whose offset in its scene was not recorded): :class:`RpcMisfit` is raised
   and the caller falls back to the image-based method. Otherwise the target is corrected
   by a plane of vertical offset ``dy = a x + b y + c`` fitted to the matches (eq. 2,
   least squares on those within ``ransac_threshold``, twice) and shifted horizontally by
   the median disparity, so disparities are centred on zero as with the affine method;
   the altitude of zero disparity is kept (eq. 3: ``h = h_zero + m d``).

The result has the interface of :class:`radcons.stages.rectify.run.Rectification` (images,
residuals, matches, and the maps to and from the original geometry).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from radcons.errors import InputError
from radcons.results import Matches
from radcons.rpc import Rpc
from radcons.stages.rectify.epipolar import (
    checked_interpolation,
    resample_nan,
    validated_image,
)
from radcons.stages.rectify.features import match_sift
from radcons.stages.rectify.params import (
    DISPARITY_PERCENTILES,
    UNRECTIFIED_PARALLAX_PX,
    RectifyParams,
)
from radcons.stages.rectify.row_levelling import vertical_offset_plane
from radcons.stages.rectify.rpc_grids import (
    EpipolarSide,
    RpcMisfit,
    epipolar_sides,
    shareloc_model,
)

__all__ = ["RpcMisfit", "RpcRectification", "rectify_rpc"]

#: The first pass's grids are this many times coarser: it only has to bring rows within a
#: pixel or two for SIFT and the scene's altitude (the grids' cost grows with their nodes).
_FIRST_PASS_COARSER = 4
#: :func:`radcons.stages.rectify.rpc_grids.shareloc_model`, also importable from here
#: (``benchmarks/bench_orientation.py`` reads it).
_shareloc_model = shareloc_model


def _remap(image: np.ndarray, maps: tuple[np.ndarray, np.ndarray], interpolation: str) -> np.ndarray:
    """Resample ``image`` at the positions of ``maps`` (``cv2.remap``), NaN where not covered."""
    return resample_nan(
        image,
        interpolation,
        lambda array, mode: cv2.remap(array, *maps, mode, borderMode=cv2.BORDER_CONSTANT, borderValue=0.0),
    )


@dataclass(frozen=True)
class RpcRectification:
    """An epipolar-rectified pair made from RPC models, and the maps that made it.

    Attributes
    ----------
    reference, target : ndarray, shape ``shape``, float32
        Rectified images, NaN outside their source. ``reference(x, y) <-> target(x - d, y)``.
    shape, ref_shape, tgt_shape : tuple of int
        Rectified and original ``(rows, columns)``.
    residual_parallax_median, residual_parallax_p90 : float
        ``|y_ref - y_tgt|``, px, at the inlier matches after the pointing correction.
    n_matches, n_inliers : int
        SIFT matches of the rectified images, and those within ``ransac_threshold`` px of
        common rows after the correction.
    matches : Matches
        The inlier matches in rectified coordinates.
    disparity_range : tuple of float
        0.5th and 99.5th percentiles of the inliers' disparity, px.
    interpolation : str
        Interpolation used to resample the images.
    altitude : float
        Altitude of the epipolar grids, m: the scene's, from a first pass at the mean of the
        models' height offsets.
    metres_per_pixel : float
        Height difference, m, of one pixel of disparity (eq. 1), positive.
    gsd_m : float
        Ground sample distance of the rectified frame at the grids' altitude, m
        (:func:`_frame_gsd`).
    zero_disparity_altitude : float
        Altitude, m, of the points with zero disparity (eq. 3: ``h = h_zero + m d``; it
        includes the models' horizontal pointing error, a few metres).
    rpc_row_offset : float
        Vertical offset, px, of the matches before the correction (at the grids' altitude):
        how well the models fit.
    pointing_correction : tuple of float
        ``(shift, a, b, c)``: the target's horizontal shift and vertical plane (eq. 2).
    grid_step : int
        Spacing of the epipolar grids' nodes, px.
    sources : tuple of str
        Where the two models came from.
    method, reason : str
        ``"rpc"``, and why this method was used.
    """

    reference: np.ndarray
    target: np.ndarray
    shape: tuple[int, int]
    ref_shape: tuple[int, int]
    tgt_shape: tuple[int, int]
    residual_parallax_median: float
    residual_parallax_p90: float
    n_matches: int
    n_inliers: int
    matches: Matches
    disparity_range: tuple[float, float]
    interpolation: str
    altitude: float
    metres_per_pixel: float
    gsd_m: float
    zero_disparity_altitude: float
    rpc_row_offset: float
    pointing_correction: tuple[float, float, float, float]
    grid_step: int
    sources: tuple[str, str]
    ref_side: EpipolarSide
    tgt_side: EpipolarSide
    method: str = "rpc"
    reason: str = ""

    def _side(self, which: str) -> tuple[EpipolarSide, tuple[int, int]]:
        if which == "reference":
            return self.ref_side, self.ref_shape
        if which == "target":
            return self.tgt_side, self.tgt_shape
        raise InputError(f"which must be 'reference' or 'target', got {which!r}")

    def to_rectified(self, image: np.ndarray, which: str = "reference", interpolation: str | None = None) -> np.ndarray:
        """Resample an image of the original ``which`` geometry into the rectified frame."""
        side, shape = self._side(which)
        if np.shape(image) != tuple(shape):
            raise InputError(f"the original {which} has shape {shape}, got an image of shape {np.shape(image)}")
        return _remap(image, side.maps(self.shape), checked_interpolation(interpolation, self.interpolation))

    def to_original(
        self, image_rectified: np.ndarray, which: str = "reference", interpolation: str | None = None
    ) -> np.ndarray:
        """Resample a rectified-frame image back onto the original ``which`` grid (NaN outside)."""
        side, shape = self._side(which)
        if np.shape(image_rectified) != tuple(self.shape):
            raise InputError(
                f"image_rectified must have the rectified shape {self.shape}, got {np.shape(image_rectified)}"
            )
        rows, cols = np.indices(shape, dtype=np.float64)
        x, y = side.locate(cols, rows, self.shape)
        maps = tuple(np.nan_to_num(z, nan=-1e6).astype(np.float32) for z in (x, y))  # NaN: outside
        return _remap(image_rectified, maps, checked_interpolation(interpolation, self.interpolation))

    def disparity_to_original(self, disparity: np.ndarray) -> np.ndarray:
        """A rectified reference-frame disparity map sampled (nearest) on the original reference grid."""
        return self.to_original(disparity, "reference", "nearest")

    def correspondences_to_original(self, disparity: np.ndarray) -> np.ndarray:
        """Original target ``(x', y')`` matched to each original reference pixel (NaN where unknown)."""
        d = self.disparity_to_original(disparity).astype(np.float64)
        rows, cols = np.indices(self.ref_shape, dtype=np.float64)
        x, y = self.ref_side.locate(cols, rows, self.shape)
        col, row = self.tgt_side.source(x - d, y)
        return np.stack([col, row], axis=-1).astype(np.float32)


def _common_rows(matches: Matches, params: RectifyParams) -> tuple[float, np.ndarray]:
    """The vertical offset most matches share, and the matches within ``2 ransac_threshold`` of it.

    Raises
    ------
    RpcMisfit
        Fewer than ``min_matches`` matches, fewer sharing an offset, or an offset beyond
        :data:`radcons.stages.rectify.params.UNRECTIFIED_PARALLAX_PX`.
    """
    if len(matches) < params.min_matches:
        raise RpcMisfit(
            f"only {len(matches)} SIFT matches between the RPC-rectified images (at least {params.min_matches} "
            "are needed to check that the models fit the pixels)"
        )
    dy = matches.ref_xy[:, 1].astype(np.float64) - matches.tgt_xy[:, 1]
    band = 2 * params.ransac_threshold
    offset, sharing = _row_offset(dy, band)
    if sharing < params.min_matches or abs(offset) > UNRECTIFIED_PARALLAX_PX:
        raise RpcMisfit(
            f"the RPCs do not fit the pixels: after RPC rectification the most common vertical offset of the "
            f"{len(matches)} SIFT matches is {offset:.1f} px, shared by {sharing} (a fit needs at most "
            f"{UNRECTIFIED_PARALLAX_PX:g} px and {params.min_matches} matches)"
        )
    return offset, np.abs(dy - offset) <= band


def _row_offset(dy: np.ndarray, band: float) -> tuple[float, int]:
    """The vertical offset shared by most matches within ``+-band`` px, and their count."""
    ordered = np.sort(dy)
    counts = np.searchsorted(ordered, ordered + band, "right") - np.searchsorted(ordered, ordered - band, "left")
    best = int(np.argmax(counts))
    members = ordered[np.abs(ordered - ordered[best]) <= band]
    return float(np.median(members)), int(counts[best])


def _pointing_correction(
    matches: Matches, offset: float, threshold: float
) -> tuple[float, tuple[float, float, float], np.ndarray]:
    """Horizontal shift and vertical plane of the target (eq. 2), and the final inliers.

    The plane ``dy = a x + b y + c`` (reference coordinates) is
    :func:`radcons.stages.rectify.row_levelling.vertical_offset_plane`; the shift is the inliers'
    median disparity.
    """
    ref_xy = matches.ref_xy.astype(np.float64)
    plane, inliers = vertical_offset_plane(ref_xy, ref_xy[:, 1] - matches.tgt_xy[:, 1], offset, threshold)
    shift = float(np.median(matches.disparity[inliers])) if inliers.any() else 0.0
    return shift, (float(plane[0]), float(plane[1]), float(plane[2])), inliers


def _frame_gsd(side: EpipolarSide, rpc: Rpc, shape: tuple[int, int], altitude: float) -> float:
    """Ground sample distance, m, of the rectified frame at its centre.

    The reference model's (:meth:`radcons.rpc.Rpc.ground_sample_distance`) times the side
    of a frame pixel in reference pixels (the root of the resampling map's Jacobian).
    """
    row, col = (shape[0] - 1) / 2.0, (shape[1] - 1) / 2.0
    x, y = side.source(np.array([col, col + 1.0, col]), np.array([row, row, row + 1.0]))
    scale = np.sqrt(abs((x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0])))
    return float(rpc.ground_sample_distance(altitude) * scale)


def _frame_box(reference: np.ndarray, target: np.ndarray, policy: str) -> tuple[int, int, int, int]:
    """``(x0, y0, x1, y1)`` (exclusive ends) of the frame ``policy`` keeps (``output_size``)."""
    if policy == "union":
        return 0, 0, reference.shape[1], reference.shape[0]
    valid = np.isfinite(reference) & (np.isfinite(target) if policy == "intersection" else True)
    rows, cols = np.nonzero(valid)
    if rows.size == 0:
        raise RpcMisfit("the rectified images do not overlap")
    return int(cols.min()), int(rows.min()), int(cols.max()) + 1, int(rows.max()) + 1


def rectify_rpc(
    reference: np.ndarray, target: np.ndarray, ref_rpc: Rpc, tgt_rpc: Rpc, params: RectifyParams = RectifyParams()
) -> RpcRectification:
    """Epipolar-rectify a pair with the epipolar grids of its RPC models (module notes).

    Parameters
    ----------
    reference, target : ndarray
        Single-band images (any real dtype, computed in float32), NaN where invalid; the
        reference is the left image.
    ref_rpc, tgt_rpc : Rpc
        Their models, with each image's offset in its scene.
    params : RectifyParams
        Uses ``rpc_grid_step``, ``ratio``, ``max_features``, ``ransac_threshold``,
        ``min_matches``, ``output_size`` and ``interpolation``.

    Returns
    -------
    RpcRectification

    Raises
    ------
    InputError
        An image is not 2-D, smaller than 16 px on a side, or entirely invalid.
    RpcMisfit
        The models do not fit the pixels: the grids leave the models' domain, or the matches
        of the rectified images do not share rows within
        :data:`~radcons.stages.rectify.params.UNRECTIFIED_PARALLAX_PX` px.
    """
    reference = validated_image(reference, "reference")
    target = validated_image(target, "target")
    shapes = (reference.shape, target.shape)
    altitude = 0.5 * (ref_rpc.height_off + tgt_rpc.height_off)
    ref, tgt, slope = epipolar_sides(ref_rpc, tgt_rpc, shapes, altitude, _FIRST_PASS_COARSER * params.rpc_grid_step)
    frame = ref.frame
    ref_image = _remap(reference, ref.maps(frame), params.interpolation)
    matches = match_sift(ref_image, _remap(target, tgt.maps(frame), params.interpolation), params, approximate=True)
    _, rows = _common_rows(matches, params)
    # The grids again at the scene's altitude (their epipolar lines hold exactly there), the
    # matches carried into them through the original images.
    low_h = max(rpc.height_off - rpc.height_scale for rpc in (ref_rpc, tgt_rpc))  # the models' range
    high_h = min(rpc.height_off + rpc.height_scale for rpc in (ref_rpc, tgt_rpc))
    altitude = float(np.clip(altitude + np.median(matches.disparity[rows]) / slope, low_h, max(low_h, high_h)))
    ref_orig, tgt_orig = ref.source(*matches.ref_xy.T), tgt.source(*matches.tgt_xy.T)
    ref, tgt, slope = epipolar_sides(ref_rpc, tgt_rpc, shapes, altitude, params.rpc_grid_step)
    frame = ref.frame
    ref_image = _remap(reference, ref.maps(frame), params.interpolation)
    matches = Matches(*(
        np.column_stack(side.locate(*xy, frame)).astype(np.float32) for side, xy in ((ref, ref_orig), (tgt, tgt_orig))
    ))
    offset, _ = _common_rows(matches, params)
    shift, plane, inliers = _pointing_correction(matches, offset, params.ransac_threshold)
    tgt = replace(tgt, shift=shift, plane=plane)
    tgt_image = _remap(target, tgt.maps(frame), params.interpolation)
    x0, y0, x1, y1 = _frame_box(ref_image, tgt_image, params.output_size)
    ref, tgt = replace(ref, origin=(x0, y0)), replace(tgt, origin=(x0, y0))
    ref_xy = matches.ref_xy[inliers].astype(np.float64)
    tgt_xy = matches.tgt_xy[inliers].astype(np.float64)
    tgt_x = tgt_xy[:, 0] + shift
    tgt_y = (tgt_xy[:, 1] + plane[0] * tgt_x + plane[2]) / (1.0 - plane[1])
    rectified = Matches(
        (ref_xy - (x0, y0)).astype(np.float32), np.column_stack([tgt_x - x0, tgt_y - y0]).astype(np.float32)
    )
    parallax = np.abs(rectified.ref_xy[:, 1] - rectified.tgt_xy[:, 1])
    low, high = np.percentile(rectified.disparity, DISPARITY_PERCENTILES)
    metres = 1.0 / slope
    return RpcRectification(
        reference=ref_image[y0:y1, x0:x1],
        target=tgt_image[y0:y1, x0:x1],
        shape=(y1 - y0, x1 - x0),
        ref_shape=tuple(reference.shape),
        tgt_shape=tuple(target.shape),
        residual_parallax_median=float(np.median(parallax)),
        residual_parallax_p90=float(np.percentile(parallax, 90)),
        n_matches=len(matches),
        n_inliers=int(inliers.sum()),
        matches=rectified,
        disparity_range=(float(low), float(high)),
        interpolation=params.interpolation,
        altitude=altitude,
        metres_per_pixel=metres,
        gsd_m=_frame_gsd(ref, ref_rpc, (y1 - y0, x1 - x0), altitude),
        zero_disparity_altitude=altitude + shift * metres,
        rpc_row_offset=offset,
        pointing_correction=(shift, *plane),
        grid_step=params.rpc_grid_step,
        sources=(ref_rpc.source, tgt_rpc.source),
        ref_side=ref,
        tgt_side=tgt,
    )
