"""Epipolar-rectified stereo geometry: the nadir reference view and the oblique target view.

Both views are parallel projections with rows along the epipolar lines. The reference
looks straight down, so reference pixel ``(r, c)`` sees the surface point above ground
position ``x = (c + 0.5) g``. The target is tilted along the rows: a surface point at
``(x, y)`` with height ``h`` appears in target column ``c_t`` with

    (c_t + 0.5) g = x - B - r h,

``B`` the ground offset between the views (m) and ``r`` the base-to-height ratio. Hence the
disparity ``d = c - c_t = (B + r h) / g`` exactly, for every surface point.

Along a target row the surface is the polyline through the grid samples. The ray of
target column ``c_t`` first meets it at the largest ``x`` whose projection is not right of
``c_t``; with ``u(x) = x - r h(x)`` and ``m(x) = min_{x' >= x} u(x')`` (non-decreasing),
that is a search in ``m``. A grid sample is visible in the target when no sample further
along the row projects left of it. Where the hit segment drops by more than a storey from
a building sample, the ray has struck that building's east wall, and the facade is drawn.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from demo_data_gen.lighting import Sun
from demo_data_gen.rasterize import Grid, Layers

__all__ = ["Stereo", "Facades", "TargetView", "target_columns", "target_view", "render_target", "visible_in_target", "disparity"]

#: A drop larger than this (m) from a building sample to the next one is a wall.
WALL_MIN_DROP = 3.0


@dataclass(frozen=True)
class Stereo:
    """The pair's viewing geometry.

    Attributes
    ----------
    base : float
        Ground offset ``B`` between the views (m): the disparity of the ground is
        ``B / g`` pixels.
    ratio : float
        Base-to-height ratio ``r``: one metre of height adds ``r / g`` pixels of disparity.
    """

    base: float
    ratio: float


@dataclass(frozen=True)
class Facades:
    """Facade appearance per building id (index 0 unused).

    Attributes
    ----------
    wall_albedo, window_albedo, floor_height, window_spacing : ndarray
        Per id, as in :class:`demo_data_gen.scene.Building`.
    """

    wall_albedo: np.ndarray
    window_albedo: np.ndarray
    floor_height: np.ndarray
    window_spacing: np.ndarray


@dataclass(frozen=True)
class TargetView:
    """Where each target pixel's ray meets the surface.

    Attributes
    ----------
    left : ndarray, int64
        Grid column of the polyline sample left of the hit (rows are the reference rows).
    frac : ndarray, float64
        Position of the hit between ``left`` and ``left + 1`` (0..1).
    wall : ndarray, bool
        The ray hit a building's east wall.
    elevation : ndarray, float64
        Height of the hit above the terrain (m).
    labels : ndarray, int32
        Building id seen by each target pixel (walls included), 0 elsewhere.
    """

    left: np.ndarray
    frac: np.ndarray
    wall: np.ndarray
    elevation: np.ndarray
    labels: np.ndarray


def _rows(grid: Grid, size: int) -> slice:
    return slice(grid.row0, grid.row0 + size)


def target_columns(height: np.ndarray, grid: Grid, stereo: Stereo, size: int) -> np.ndarray:
    """Target column coordinate ``c_t`` of every grid sample on the image rows (float64)."""
    x = grid.x().astype(np.float64)[None, :]
    return (x - stereo.base - stereo.ratio * height[_rows(grid, size)].astype(np.float64)) / grid.gsd - 0.5


def _reverse_min(values: np.ndarray) -> np.ndarray:
    """``m[j] = min(values[j:])`` along rows."""
    return np.minimum.accumulate(values[:, ::-1], axis=1)[:, ::-1]


def target_view(layers: Layers, columns: np.ndarray, grid: Grid, size: int) -> TargetView:
    """Trace the ray of every target pixel to the surface of ``layers``.

    Parameters
    ----------
    layers : Layers
        The scene at the target date.
    columns : ndarray
        :func:`target_columns` of its height.
    grid : Grid
    size : int
        Side of the square images.

    Returns
    -------
    TargetView
    """
    sub = _rows(grid, size)
    height = layers.height[sub]
    ct = columns
    # J(c) = max{j : m_j <= c} per row, as one search over the rows laid end to end
    env = _reverse_min(ct)
    lo = float(env.min())
    stride = float(np.ceil(env.max() - lo)) + size + 8.0
    offsets = (np.arange(size, dtype=np.float64) * stride)[:, None]
    keys = (env - lo + offsets).ravel()
    queries = (np.arange(size, dtype=np.float64)[None, :] - lo + offsets).ravel()
    found = np.searchsorted(keys, queries, side="right").reshape(size, size) - 1
    width = grid.shape[1]
    left = np.clip(found - np.arange(size)[:, None] * width, 0, width - 2)
    rows = np.arange(size)[:, None]
    c0 = ct[rows, left]
    c1 = ct[rows, left + 1]
    pixels = np.arange(size, dtype=np.float64)[None, :]
    frac = np.clip((pixels - c0) / np.maximum(c1 - c0, 1e-9), 0.0, 1.0)
    h0 = height[rows, left].astype(np.float64)
    h1 = height[rows, left + 1].astype(np.float64)
    labels = layers.labels[sub]
    label0 = labels[rows, left]
    wall = (label0 > 0) & (h0 - h1 > WALL_MIN_DROP)
    elevation = h0 + frac * (h1 - h0) - layers.ground[sub][rows, left + 1]
    seen = np.where(wall | (frac < 0.5), label0, labels[rows, left + 1]).astype(np.int32)
    return TargetView(left, frac, wall, elevation, seen)


def render_target(
    view: TargetView,
    radiance: np.ndarray,
    facades: Facades,
    sun: Sun,
    grid: Grid,
    stereo: Stereo,
    size: int,
) -> np.ndarray:
    """Target radiance: the surface radiance at each hit, or the facade where a wall was hit.

    The surface radiance is read at the hit's sub-pixel position by cubic interpolation
    along the row (the radiance is band-limited, see ``generate``).

    Facades face east (they are the walls the tilted view sees); their pattern of window
    columns (period ``window_spacing`` along the wall) and storeys (``floor_height``) is
    faded out where the target grid cannot resolve it. They receive direct light
    ``max(s_east, 0)`` and half the sky light.

    Parameters
    ----------
    view : TargetView
    radiance : ndarray
        Surface radiance on the grid at the target date.
    facades : Facades
    sun : Sun
        The target date's sun.
    grid : Grid
    stereo : Stereo
    size : int

    Returns
    -------
    ndarray, float32, shape (size, size)
    """
    sub = np.ascontiguousarray(radiance[_rows(grid, size)], dtype=np.float32)
    map_x = (view.left + view.frac).astype(np.float32)
    map_y = np.broadcast_to(np.arange(size, dtype=np.float32)[:, None], map_x.shape)
    surface = cv2.remap(sub, map_x, np.ascontiguousarray(map_y), cv2.INTER_CUBIC, borderMode=cv2.BORDER_REPLICATE)
    wall = view.wall
    ids = view.labels[wall]
    y = (np.nonzero(wall)[0] + 0.5) * grid.gsd
    storey, spacing = facades.floor_height[ids], facades.window_spacing[ids]
    # fade the patterns the target grid cannot resolve (period under ~2.5-5 px)
    fade_z = np.clip((storey * stereo.ratio / grid.gsd - 2.5) / 2.5, 0.0, 1.0)
    fade_s = np.clip((spacing / grid.gsd - 2.5) / 2.5, 0.0, 1.0)
    storeys = 0.5 + 0.5 * fade_z * np.cos(2 * np.pi * view.elevation[wall] / storey)
    columns = 0.5 + 0.5 * fade_s * np.cos(2 * np.pi * y / spacing)
    albedo = facades.wall_albedo[ids] + storeys * columns * (facades.window_albedo[ids] - facades.wall_albedo[ids])
    east = float(sun.vector()[0])
    surface[wall] = albedo * (max(east, 0.0) + 0.5 * sun.ambient)
    return surface


def visible_in_target(ref_columns: np.ndarray, tgt_columns: np.ndarray, grid: Grid, size: int) -> np.ndarray:
    """True where a reference-date surface sample is seen by the target view.

    A sample is hidden when a sample of the target-date surface further along its row
    projects left of it (strictly). Samples that project outside the target image
    (``c_t < 0`` or ``c_t > size - 1``) count as not seen.

    Parameters
    ----------
    ref_columns, tgt_columns : ndarray
        :func:`target_columns` of the reference-date and target-date heights.
    grid : Grid
    size : int

    Returns
    -------
    ndarray, bool, shape (size, size)
        On the reference image's pixels.
    """
    ahead = np.concatenate([_reverse_min(tgt_columns)[:, 1:], np.full((size, 1), np.inf)], axis=1)
    seen = (ref_columns <= ahead + 1e-9) & (ref_columns >= 0.0) & (ref_columns <= size - 1)
    return seen[:, grid.col0 : grid.col0 + size]


def disparity(ref_height: np.ndarray, grid: Grid, stereo: Stereo, size: int, seen: np.ndarray) -> np.ndarray:
    """Ground-truth disparity ``(B + r h) / g`` on the reference pixels, NaN where not seen."""
    h = ref_height[_rows(grid, size), grid.col0 : grid.col0 + size].astype(np.float64)
    d = (stereo.base + stereo.ratio * h) / grid.gsd
    return np.where(seen, d, np.nan).astype(np.float32)
