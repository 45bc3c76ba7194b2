"""Epipolar grids of a pair's RPC models, and the maps they define from the epipolar frame to each image.

CNES shareloc traces the grids (:func:`shareloc.geofunctions.rectification.
compute_stereorectification_epipolar_grids`; de Franchis et al. 2014, "On stereo-
rectification of pushbroom images", ICIP): every ``step`` px of the epipolar frame, the
reference position on a local epipolar line and its target correspondent at a constant
altitude (no DEM is used). Between nodes the positions are interpolated bilinearly
(:class:`EpipolarSide`), and a few nodes are extrapolated around the frame so that
positions just off it are defined. A point ``dh`` metres above the grids' altitude moves
by ``dh / m`` px along its epipolar line (``m``, metres per pixel of disparity, from the
models at the frame's centre, eq. 1); the frame is turned by 180 deg when needed so that
higher points have larger disparity ``d = x_ref - x_tgt`` (the convention of stereo pairs
whose reference is the left image). :mod:`radcons.stages.rectify.rpc` builds the
rectification on these maps.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.ndimage

from radcons.errors import StageError
from radcons.rpc import Rpc

__all__ = ["RpcMisfit", "EpipolarSide", "shareloc_model", "epipolar_sides"]

# numba's thread pool costs more than it gives on grids of a few thousand nodes; shareloc
# reads the switch when it is first imported.
os.environ.setdefault("SHARELOC_NUMBA_PARALLEL", "False")

#: Altitude step (m) of shareloc's local epipolar lines and of the disparity-height slope.
_ELEVATION_OFFSET = 50.0
_NEWTON_STEPS = 8
#: Grid nodes added on each side by linear extrapolation (positions just off the frame).
_GRID_PAD = 8
#: Largest error, px, of an inverted position (:meth:`EpipolarSide.locate`); larger ones are NaN.
_LOCATE_TOLERANCE = 0.01


class RpcMisfit(StageError):
    """The RPC models do not fit the images' pixels (the rectified rows do not correspond)."""


@dataclass(frozen=True)
class EpipolarSide:
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


def shareloc_model(rpc: Rpc) -> Any:
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
    from shareloc.geofunctions.rectification import (
        compute_stereorectification_epipolar_grids,
    )
    from shareloc.image import Image

    def image(rpc: Rpc, shape: tuple[int, int]) -> Image:
        im = Image(None)
        im.set_metadata(shape[0], shape[1], 1, (1.0, 0.0, rpc.crop_offset[0], 0.0, 1.0, rpc.crop_offset[1]))
        return im

    try:
        ref_grid, tgt_grid, size, _ = compute_stereorectification_epipolar_grids(
            image(ref_rpc, ref_shape), shareloc_model(ref_rpc), image(tgt_rpc, tgt_shape), shareloc_model(tgt_rpc),
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


def _disparity_per_metre(
    ref_rpc: Rpc, tgt_rpc: Rpc, ref: EpipolarSide, tgt: EpipolarSide, altitude: float
) -> float:
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
    ground = shareloc_model(ref_rpc).direct_loc_h(scene_row, scene_col, heights)
    tgt_col, tgt_row = tgt_rpc.project(ground[:, 0], ground[:, 1], heights)
    x_tgt, _ = tgt.locate(tgt_col, tgt_row, tgt.frame)
    disparity = cols / 2.0 - x_tgt
    return float((disparity[1] - disparity[0]) / (2 * _ELEVATION_OFFSET))


def epipolar_sides(
    ref_rpc: Rpc, tgt_rpc: Rpc, shapes: tuple[tuple[int, int], tuple[int, int]], altitude: float, step: int
) -> tuple[EpipolarSide, EpipolarSide, float]:
    """Both images' maps from the epipolar grids at ``altitude``, and the disparity per metre (> 0).

    The frame is turned by 180 deg when higher points would get smaller disparities.
    """
    ref_grid, tgt_grid, frame = _shareloc_grids(ref_rpc, tgt_rpc, *shapes, altitude, step)
    ref, tgt = EpipolarSide(ref_grid, step, frame), EpipolarSide(tgt_grid, step, frame)
    slope = _disparity_per_metre(ref_rpc, tgt_rpc, ref, tgt, altitude)
    if not np.isfinite(slope) or slope == 0:
        raise RpcMisfit("the models give no disparity for a change of height (no stereo baseline)")
    flip = bool(slope < 0)
    return EpipolarSide(ref_grid, step, frame, flip), EpipolarSide(tgt_grid, step, frame, flip), abs(slope)
