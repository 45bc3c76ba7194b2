"""Epipolar resampling of an unrectified pair from the RPC camera models of both images.

When both images carry RPC models (:mod:`radcons.rpc`) the epipolar geometry comes from
the cameras rather than from the images, as s2p and CARS do; the change of image content
between two dates (a city seven years apart) then no longer decides the geometry.

1. Epipolar grids (CNES shareloc, :func:`shareloc.geofunctions.rectification.
   compute_stereorectification_epipolar_grids`; de Franchis et al. 2014, "On stereo-
   rectification of pushbroom images", ICIP): every ``grid_step`` px of the epipolar frame,
   the reference position on a local epipolar line and its target correspondent at a
   constant altitude (no DEM is used). Between nodes the positions are interpolated
   bilinearly; both images are resampled with ``cv2.remap`` (NaN where the interpolation
   footprint leaves the source or touches an invalid pixel). A first pass (grids four
   times coarser) uses the mean of the two models' height offsets; the median disparity of
   its SIFT matches (step 3) gives the scene's altitude (eq. 3), and the grids are computed
   again there, since pushbroom epipolar lines are exact only near the altitude they were
   traced at (on the Kahramanmaras pairs the scene lies about 235 m above the models'
   offset). The first pass's matches are carried into the second frame through the
   original images.
2. Disparity and height: a point ``dh`` metres above ``h0`` moves by ``dh / m`` px along
   its epipolar line (``m``, metres per pixel of disparity, from the models at the frame's
   centre, eq. 1). Both images are turned by 180 deg when needed so that higher points
   have larger disparity ``d = x_ref - x_tgt`` (the convention of stereo pairs whose
   reference is the left image).
3. Check and pointing correction (s2p's "pointing error" correction, de Franchis et al.
   2014): SIFT matches of the two rectified images. Their vertical offset is the models'
   relative pointing error; its mode (the offset shared by most matches within
   ``2 ransac_threshold``) above
   :data:`radcons.stages.rectify_params.UNRECTIFIED_PARALLAX_PX`, or fewer than
   ``min_matches`` matches sharing it, means that the RPCs do not fit the pixels (e.g. a
   crop whose offset in its scene was not recorded): :class:`RpcMisfit` is raised
   and the caller falls back to the image-based method. Otherwise the target is corrected
   by a plane of vertical offset ``dy = a x + b y + c`` fitted to the matches (eq. 2,
   least squares on those within ``ransac_threshold``, twice) and shifted horizontally by
   the median disparity, so disparities are centred on zero as with the affine method;
   the altitude of zero disparity is kept (eq. 3: ``h = h_zero + m d``).

The result has the interface of :class:`radcons.stages.rectify.Rectification` (images,
residuals, matches, and the maps to and from the original geometry).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from typing import Any

import cv2
import numpy as np
import scipy.ndimage

from radcons.errors import InputError, StageError
from radcons.results import Matches
from radcons.rpc import Rpc
from radcons.stages.rectify_epipolar import checked_interpolation, match_sift, resample_nan, validated_image
from radcons.stages.rectify_params import DISPARITY_PERCENTILES, UNRECTIFIED_PARALLAX_PX, RectifyParams
from radcons.stages.row_levelling import vertical_offset_plane

__all__ = ["RpcMisfit", "RpcRectification", "rectify_rpc"]

# numba's thread pool costs more than it gives on grids of a few thousand nodes (measured on
# two cores); shareloc reads the switch when it is first imported.
os.environ.setdefault("SHARELOC_NUMBA_PARALLEL", "False")

#: Altitude step (m) of shareloc's local epipolar lines and of the disparity-height slope.
_ELEVATION_OFFSET = 50.0
_NEWTON_STEPS = 8
#: The first pass's grids are this many times coarser: it only has to bring rows within a
#: pixel or two for SIFT and the scene's altitude (the grids' cost grows with their nodes).
_FIRST_PASS_COARSER = 4
#: Grid nodes added on each side by linear extrapolation (positions just off the frame).
_GRID_PAD = 8
#: Largest error, px, of an inverted position (:meth:`_Side.locate`); larger ones are NaN.
_LOCATE_TOLERANCE = 0.01


class RpcMisfit(StageError):
    """The RPC models do not fit the images' pixels (the rectified rows do not correspond)."""


@dataclass(frozen=True)
class _Side:
    """Map from the final epipolar frame to one original image (pixel centres).

    ``(x, y)`` -> ``(x + x0, y + y0)`` (crop of the frame) -> target only: ``(u - shift,
    v - (a u + b v + c))`` (pointing correction) -> 180 deg turn of the full frame when
    ``flip`` -> bilinear interpolation of ``grid`` (original ``(column, row)`` every
    ``step`` px, node ``(i, j)`` at frame position ``((j - pad) step, (i - pad) step)``
    with :data:`_GRID_PAD` extrapolated nodes around the frame).
    """

    grid: np.ndarray
    step: int
    frame: tuple[int, int]
    flip: bool = False
    origin: tuple[int, int] = (0, 0)
    shift: float = 0.0
    plane: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def source(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Original ``(column, row)`` of final-frame positions ``(x, y)``."""
        u = np.asarray(x, np.float64) + self.origin[0]
        v = np.asarray(y, np.float64) + self.origin[1]
        a, b, c = self.plane
        u, v = u - self.shift, v - (a * u + b * v + c)
        if self.flip:
            u, v = self.frame[1] - 1 - u, self.frame[0] - 1 - v
        nodes = [v / self.step + _GRID_PAD, u / self.step + _GRID_PAD]
        col = scipy.ndimage.map_coordinates(self.grid[..., 0], nodes, order=1, mode="nearest")
        row = scipy.ndimage.map_coordinates(self.grid[..., 1], nodes, order=1, mode="nearest")
        return col, row

    def maps(self, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """``cv2.remap`` maps (float32) of a final frame of ``shape``."""
        rows, cols = np.indices(shape, dtype=np.float64)
        col, row = self.source(cols, rows)
        return col.astype(np.float32), row.astype(np.float32)

    def locate(self, col: np.ndarray, row: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """Final-frame ``(x, y)`` of original positions: the inverse of :meth:`source`.

        Quasi-Newton iterations with the Jacobian of the affine map that best fits
        :meth:`source` over the frame (the map is nearly affine), from that affine map's
        inverse; NaN where they do not converge (far outside the grids).
        """
        ys, xs = np.meshgrid(np.linspace(0, shape[0] - 1, 9), np.linspace(0, shape[1] - 1, 9), indexing="ij")
        frame_xy = np.column_stack([xs.ravel(), ys.ravel(), np.ones(xs.size)])
        image_xy = np.column_stack(self.source(xs.ravel(), ys.ravel()))
        forward = np.linalg.lstsq(frame_xy, image_xy, rcond=None)[0].T  # 2x3: frame -> image
        inverse = np.linalg.inv(forward[:, :2])
        target = np.stack([np.asarray(col, np.float64), np.asarray(row, np.float64)], axis=-1)
        xy = (target - forward[:, 2]) @ inverse.T
        for _ in range(_NEWTON_STEPS):
            error = np.stack(self.source(xy[..., 0], xy[..., 1]), axis=-1) - target
            xy = xy - error @ inverse.T
        error = np.stack(self.source(xy[..., 0], xy[..., 1]), axis=-1) - target
        xy[np.hypot(error[..., 0], error[..., 1]) > _LOCATE_TOLERANCE] = np.nan
        return xy[..., 0], xy[..., 1]


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
    ref_side: _Side
    tgt_side: _Side
    method: str = "rpc"
    reason: str = ""

    def _side(self, which: str) -> tuple[_Side, tuple[int, int]]:
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


def _shareloc_model(rpc: Rpc) -> Any:
    """shareloc's model of ``rpc``, with pixel ``(0, 0)``'s corner at ``(0, 0)`` of its scene."""
    from shareloc.geomodels.rpc import RPC

    return RPC({
        "offset_row": rpc.line_off + 0.5, "scale_row": rpc.line_scale,
        "offset_col": rpc.samp_off + 0.5, "scale_col": rpc.samp_scale,
        "offset_x": rpc.long_off, "scale_x": rpc.long_scale, "offset_y": rpc.lat_off, "scale_y": rpc.lat_scale,
        "offset_alt": rpc.height_off, "scale_alt": rpc.height_scale,
        "num_row": list(rpc.line_num_coeff), "den_row": list(rpc.line_den_coeff),
        "num_col": list(rpc.samp_num_coeff), "den_col": list(rpc.samp_den_coeff),
        "num_x": None, "den_x": None, "num_y": None, "den_y": None, "driver_type": "radcons",
    })


def _shareloc_grids(
    ref_rpc: Rpc, tgt_rpc: Rpc, ref_shape: tuple[int, int], tgt_shape: tuple[int, int], altitude: float, step: int
) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    """Epipolar grids of shareloc as original ``(column, row)`` pixel positions, and the frame's shape.

    shareloc places pixel ``(0, 0)``'s corner at ``(0, 0)`` (its models' offsets are moved
    by half a pixel, as its own readers do) and reads a crop's offset from the image's
    transform.
    """
    from shareloc.geofunctions.rectification import compute_stereorectification_epipolar_grids
    from shareloc.image import Image

    def image(rpc: Rpc, shape: tuple[int, int]) -> Image:
        im = Image(None)
        im.set_metadata(shape[0], shape[1], 1, (1.0, 0.0, rpc.crop_offset[0], 0.0, 1.0, rpc.crop_offset[1]))
        return im

    try:
        ref_grid, tgt_grid, size, _ = compute_stereorectification_epipolar_grids(
            image(ref_rpc, ref_shape), _shareloc_model(ref_rpc), image(tgt_rpc, tgt_shape), _shareloc_model(tgt_rpc),
            elevation=altitude, epi_step=step, elevation_offset=_ELEVATION_OFFSET,
        )
    except (ValueError, ArithmeticError, RuntimeError) as exc:  # e.g. models that cannot be inverted there
        raise RpcMisfit(f"shareloc could not trace epipolar grids from the models ({exc})") from exc

    def pixels(grid: np.ndarray, rpc: Rpc) -> np.ndarray:
        col = grid[..., 1] - 0.5 - rpc.crop_offset[0]
        row = grid[..., 0] - 0.5 - rpc.crop_offset[1]
        pad = ((_GRID_PAD, _GRID_PAD), (_GRID_PAD, _GRID_PAD), (0, 0))
        return np.pad(np.stack([col, row], axis=-1), pad, mode="reflect", reflect_type="odd")

    if not (np.isfinite(ref_grid).all() and np.isfinite(tgt_grid).all()):
        raise RpcMisfit("the epipolar grids hold NaN: the models do not cover the images")
    return pixels(ref_grid, ref_rpc), pixels(tgt_grid, tgt_rpc), (int(size[0]), int(size[1]))


def _disparity_per_metre(ref_rpc: Rpc, tgt_rpc: Rpc, ref: _Side, tgt: _Side, altitude: float) -> float:
    """Disparity change per metre of height at the frame's centre, px/m (eq. 1), signed.

    The reference pixel at the centre is located on the ground at ``altitude +- 50 m``
    (:meth:`shareloc.geomodels.rpc.RPC.direct_loc_h`), projected into the target by its
    model, and both target positions are taken into the epipolar frame.
    """
    rows, cols = ref.frame
    col, row = ref.source(np.array([cols / 2.0]), np.array([rows / 2.0]))
    heights = np.array([altitude - _ELEVATION_OFFSET, altitude + _ELEVATION_OFFSET])
    scene_row = np.repeat(row + ref_rpc.crop_offset[1] + 0.5, 2)
    scene_col = np.repeat(col + ref_rpc.crop_offset[0] + 0.5, 2)
    ground = _shareloc_model(ref_rpc).direct_loc_h(scene_row, scene_col, heights)
    tgt_col, tgt_row = tgt_rpc.project(ground[:, 0], ground[:, 1], heights)
    x_tgt, _ = tgt.locate(tgt_col, tgt_row, tgt.frame)
    disparity = cols / 2.0 - x_tgt
    return float((disparity[1] - disparity[0]) / (2 * _ELEVATION_OFFSET))


def _epipolar_sides(
    ref_rpc: Rpc, tgt_rpc: Rpc, shapes: tuple[tuple[int, int], tuple[int, int]], altitude: float, step: int
) -> tuple[_Side, _Side, float]:
    """Both images' maps from the epipolar grids at ``altitude``, and the disparity per metre (> 0).

    The frame is turned by 180 deg when higher points would get smaller disparities.
    """
    ref_grid, tgt_grid, frame = _shareloc_grids(ref_rpc, tgt_rpc, *shapes, altitude, step)
    slope = _disparity_per_metre(ref_rpc, tgt_rpc, _Side(ref_grid, step, frame), _Side(tgt_grid, step, frame), altitude)
    if not np.isfinite(slope) or slope == 0:
        raise RpcMisfit("the models give no disparity for a change of height (no stereo baseline)")
    flip = bool(slope < 0)
    return _Side(ref_grid, step, frame, flip), _Side(tgt_grid, step, frame, flip), abs(slope)


def _common_rows(matches: Matches, params: RectifyParams) -> tuple[float, np.ndarray]:
    """The vertical offset most matches share, and the matches within ``2 ransac_threshold`` of it.

    Raises
    ------
    RpcMisfit
        Fewer than ``min_matches`` matches, fewer sharing an offset, or an offset beyond
        :data:`radcons.stages.rectify_params.UNRECTIFIED_PARALLAX_PX`.
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
    :func:`radcons.stages.row_levelling.vertical_offset_plane`; the shift is the inliers'
    median disparity.
    """
    ref_xy = matches.ref_xy.astype(np.float64)
    plane, inliers = vertical_offset_plane(ref_xy, ref_xy[:, 1] - matches.tgt_xy[:, 1], offset, threshold)
    shift = float(np.median(matches.disparity[inliers])) if inliers.any() else 0.0
    return shift, (float(plane[0]), float(plane[1]), float(plane[2])), inliers


def _frame_gsd(side: _Side, rpc: Rpc, shape: tuple[int, int], altitude: float) -> float:
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
        :data:`~radcons.stages.rectify_params.UNRECTIFIED_PARALLAX_PX` px.
    """
    reference = validated_image(reference, "reference")
    target = validated_image(target, "target")
    shapes = (reference.shape, target.shape)
    altitude = 0.5 * (ref_rpc.height_off + tgt_rpc.height_off)
    ref, tgt, slope = _epipolar_sides(ref_rpc, tgt_rpc, shapes, altitude, _FIRST_PASS_COARSER * params.rpc_grid_step)
    frame = ref.frame
    ref_image = _remap(reference, ref.maps(frame), params.interpolation)
    matches = match_sift(ref_image, _remap(target, tgt.maps(frame), params.interpolation), params)
    _, rows = _common_rows(matches, params)
    # The grids again at the scene's altitude (their epipolar lines hold exactly there), the
    # matches carried into them through the original images.
    low_h = max(rpc.height_off - rpc.height_scale for rpc in (ref_rpc, tgt_rpc))  # the models' range
    high_h = min(rpc.height_off + rpc.height_scale for rpc in (ref_rpc, tgt_rpc))
    altitude = float(np.clip(altitude + np.median(matches.disparity[rows]) / slope, low_h, max(low_h, high_h)))
    ref_orig, tgt_orig = ref.source(*matches.ref_xy.T), tgt.source(*matches.tgt_xy.T)
    ref, tgt, slope = _epipolar_sides(ref_rpc, tgt_rpc, shapes, altitude, params.rpc_grid_step)
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
