"""The ground under the pair's census disparity, and the height above it.

A building is what stands above the ground around it. From the census disparity of the
reduced grid (:mod:`radcons.stages.objects.matching`):

1. **Ground** (:func:`ground_disparity`): the ``ground_percentile`` of the valid
   disparities in windows of ``ground_window_m`` (overlapping by half), interpolated
   bilinearly (:func:`radcons.numerics.coarse_disparity.window_surface`): a window larger than the largest building always
   holds ground. Four passes of Gaussian-weighted local plane fits (first-order
   normalised convolution, sigma a quarter of the window; :func:`_local_plane`) through
   the pixels less than 3, 2, 1 and 1 times the height threshold above the current
   ground then remove the low percentile's bias on sloped ground: a percentile of a
   tilted plane lies below its centre, and the first, looser passes let the pixels of
   the upper side of the window back in.
   With ``ground = "bulldozer"`` the ground is CNES Bulldozer's instead
   (:func:`drape_ground`): a cloth draped under the disparity taken as a surface model,
   an optional dependency (``pip install 'radcons[bulldozer]'``). :func:`ground_under`
   takes the one the parameters name.
2. **Height** (:func:`height_above_ground`): ``(d - ground) / px_per_unit``, in metres when
   the ground sample distance and the base-to-height ratio are known (``px_per_unit =
   ratio / gsd``) or the RPC models give the metres of one disparity pixel, else in
   disparity pixels of the full image.

:class:`HeightMap` holds the three maps on the census grid.

References
----------
Knutsson, H., Westin, C.-F. (1993). Normalized and differential convolution. CVPR 1993,
515-523.
Lallement, D. et al. (2023). Bulldozer, a free open source scalable software for DTM
extraction. ISPRS Archives XLVIII-4/W7-2023, 89-94.
Zhang, K. et al. (2003). A progressive morphological filter for removing nonground
measurements from airborne LIDAR data. IEEE TGRS 41(4), 872-882 (ground under buildings
by filters larger than the largest building).
"""

from __future__ import annotations

import contextlib
import io
import logging
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np
from scipy import ndimage

from radcons.errors import ParamsError
from radcons.numerics.coarse_disparity import upsample, window_surface

if TYPE_CHECKING:
    from radcons.stages.objects.params import ObjectsParams

__all__ = [
    "BULLDOZER_OBJECT_SHARE", "HeightMap", "drape_ground", "ground_disparity", "ground_under", "height_above_ground",
]

#: Bulldozer's largest object above the ground (``max_object_size``) as a share of
#: ``ground_window_m`` (see :func:`drape_ground`; chosen in ``docs/tuning.md``).
BULLDOZER_OBJECT_SHARE = 0.25

#: The ground's plane fits are solved on blocks of sigma over this many pixels
#: (see :func:`_local_plane`).
_BLUR_STEP_SIGMAS = 4.0


@dataclass(frozen=True)
class HeightMap:
    """Disparity, ground and height above ground of the reference, at census resolution.

    Attributes
    ----------
    disparity : ndarray, float32
        Census disparity in pixels of the full image (``reference(x, y) <-> target(x - d,
        y)``), at the reduced resolution, NaN where invalid.
    ground : ndarray, float32
        Ground disparity under every pixel (full-image pixels), same grid.
    height : ndarray, float32
        Height above ground in :attr:`unit`, NaN where the disparity is invalid.
    unit : str
        ``"m"`` or ``"px"`` (disparity pixels of the full image).
    px_per_unit : float
        Disparity pixels per unit of height.
    factor : int
        Reduction of the census grid against the full image.
    disparity_range : tuple of float
        Range searched by the census run (full-image pixels).
    valid_share : float
        Share of the pair's overlap the left-right-checked range-finding run kept valid
        (:func:`radcons.numerics.coarse_disparity.consistent_share`).
    """

    disparity: np.ndarray
    ground: np.ndarray
    height: np.ndarray
    unit: str
    px_per_unit: float
    factor: int
    disparity_range: tuple[float, float]
    valid_share: float

    def searched_disparities(self) -> np.ndarray:
        """The integer disparities (full-image px) that take in :attr:`disparity_range`."""
        low, high = self.disparity_range
        return np.arange(int(np.floor(low)), int(np.ceil(high)) + 1)

    @property
    def step(self) -> float:
        """Height, in :attr:`unit`, of one step of the census disparity (:attr:`factor` px).

        A building lower than a step stands out only by the census's sub-pixel refinement
        (Kahramanmaras 2016 / 2023 images 1, a short base: a step is 14 m), and the
        objects found below it may come and go with small changes of the pair.
        """
        return self.factor / self.px_per_unit

    def full(self, shape: tuple[int, int], which: str = "height") -> np.ndarray:
        """One of the maps resampled bilinearly to the full image ``shape`` (NaN kept)."""
        grid = getattr(self, which)
        return upsample(grid, shape)


def ground_disparity(
    disparity: np.ndarray, window: int, percentile: float, threshold: float
) -> np.ndarray:
    """Ground (terrain) disparity under every pixel of a disparity map.

    Parameters
    ----------
    disparity : ndarray
        Disparity map (NaN where invalid).
    window : int
        Side of the windows, px of this map: larger than the largest building.
    percentile : float
        Percentile of each window's valid disparities taken as its ground.
    threshold : float
        Pixels less than this (disparity px) above the ground are ground for the slope
        correction.

    Returns
    -------
    ndarray, float32
        Ground disparity, finite everywhere (NaN only when no pixel is valid).
    """
    window = max(3, min(int(window), max(disparity.shape)))
    ground = window_surface(disparity, window, percentile)
    if np.isnan(ground).all():
        return ground
    sigma = window / 4.0
    valid = np.isfinite(disparity)
    filled = np.where(valid, disparity, 0.0).astype(np.float32)
    for allowance in (3.0, 2.0, 1.0, 1.0):
        near = valid & (filled - ground < allowance * threshold)
        ground = _local_plane(filled, near, sigma, ground)
    return ground


def _local_plane(values: np.ndarray, weights: np.ndarray, sigma: float, previous: np.ndarray) -> np.ndarray:
    """Gaussian-weighted least-squares plane through ``values`` where ``weights``, at every pixel.

    First-order normalised convolution: unlike a weighted mean, a plane fit follows a
    slope without bias, at the image's edges too. Pixels whose neighbourhood holds too
    little weight, or weight along a line only, keep ``previous``. A fit over a Gaussian
    of ``sigma`` px varies little within ``sigma / 4`` px: the weighted moments are
    summed in blocks of ``step`` px (at most a quarter of sigma), blurred and solved
    there, and the planes' coefficients resampled bilinearly to every pixel.
    """
    step = max(1, int(sigma // _BLUR_STEP_SIGMAS))
    shape = values.shape
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float64)
    w = weights.astype(np.float64)
    d = np.where(weights, values, 0.0).astype(np.float64)

    def moment(array: np.ndarray) -> np.ndarray:
        small = _block_mean(array, step)
        return cv2.GaussianBlur(small, (0, 0), sigma / step, borderType=cv2.BORDER_CONSTANT)

    s0, sx, sy = moment(w), moment(w * cols), moment(w * rows)
    sxx, sxy, syy = moment(w * cols * cols), moment(w * cols * rows), moment(w * rows * rows)
    sd, sxd, syd = moment(w * d), moment(w * cols * d), moment(w * rows * d)
    normal = np.stack(
        [np.stack([s0, sx, sy], -1), np.stack([sx, sxx, sxy], -1), np.stack([sy, sxy, syy], -1)], -2
    )
    right = np.stack([sd, sxd, syd], -1)
    support = moment(np.ones_like(w))
    good = s0 > 0.05 * support
    good &= np.abs(np.linalg.det(normal)) > 1e-9 * np.maximum(s0, 1e-12) ** 3 * sigma**4
    coef = np.zeros(s0.shape + (3,))
    if good.any():
        coef[good] = np.linalg.solve(normal[good], right[good][:, :, None])[:, :, 0]
    if step > 1:  # the planes' coefficients, smooth, resampled to every pixel
        size = (s0.shape[1] * step, s0.shape[0] * step)
        good = cv2.resize(good.astype(np.float64), size, interpolation=cv2.INTER_LINEAR)[: shape[0], : shape[1]]
        coef = cv2.resize(coef, size, interpolation=cv2.INTER_LINEAR)[: shape[0], : shape[1]]
        with np.errstate(invalid="ignore", divide="ignore"):
            coef = coef / good[:, :, None]
        good = good > 0.999
    fitted = coef[:, :, 0] + coef[:, :, 1] * cols + coef[:, :, 2] * rows
    return np.where(good, fitted, previous).astype(np.float32)


def _block_mean(array: np.ndarray, step: int) -> np.ndarray:
    """Mean over blocks of ``step`` x ``step`` px (zero-padded at the far edges)."""
    if step == 1:
        return array
    padded = np.pad(array, ((0, -array.shape[0] % step), (0, -array.shape[1] % step)))
    return padded.reshape(padded.shape[0] // step, step, padded.shape[1] // step, step).mean(axis=(1, 3))


def ground_under(
    disparity: np.ndarray, params: ObjectsParams, gsd: float, factor: int, px_per_m: float | None
) -> np.ndarray:
    """The ground under the census disparity by the method ``params.ground`` names.

    ``"windows"``: :func:`ground_disparity` in windows of ``ground_window_m``, the slope
    correction's threshold the height threshold (``min_height_m``, or ``min_height_px``
    without geometry) in disparity px. ``"bulldozer"``: :func:`drape_ground`, objects up
    to :data:`BULLDOZER_OBJECT_SHARE` of ``ground_window_m``, heights scaled by
    ``px_per_m`` or, without geometry, one disparity px per ground sample distance of
    height (a base-to-height ratio of 1).

    Parameters
    ----------
    disparity : ndarray
        Census disparity (NaN where invalid), full-image px.
    params : ObjectsParams
    gsd : float
        Ground sample distance of the full image, metres.
    factor : int
        Reduction of the census grid against the full image.
    px_per_m : float or None
        Disparity px per metre of height, None where the pair's geometry is unknown.

    Returns
    -------
    ndarray, float32
        Ground disparity, full-image px.
    """
    if params.ground == "bulldozer":
        scale = px_per_m if px_per_m else 1.0 / gsd
        return drape_ground(disparity, gsd * factor, scale, params.ground_window_m * BULLDOZER_OBJECT_SHARE)
    window = int(round(params.ground_window_m / gsd / factor))
    threshold = params.min_height_m * px_per_m if px_per_m else params.min_height_px
    return ground_disparity(disparity, window, params.ground_percentile, threshold)


def drape_ground(disparity: np.ndarray, cell_m: float, px_per_m: float, max_object_m: float) -> np.ndarray:
    """Ground (terrain) disparity under a disparity map by CNES Bulldozer's drape cloth.

    The disparity grows towards the sensor, as a surface model's height does: divided by
    ``px_per_m`` it is written, in metres, to a temporary GeoTIFF of ``cell_m`` cells (a
    nominal transform at the origin), Bulldozer's terrain model is read back and
    multiplied by ``px_per_m`` again. Cells it leaves without terrain (invalid ones at the
    map's border) take the nearest cell's. Bulldozer runs on one process, its progress
    output and log muted.

    Parameters
    ----------
    disparity : ndarray
        Disparity map (NaN where invalid), full-image px.
    cell_m : float
        Side of the map's cells, metres.
    px_per_m : float
        Disparity px per metre of height (an assumed one where the pair's geometry is unknown).
    max_object_m : float
        Bulldozer's ``max_object_size``: the largest object above the ground, metres.

    Returns
    -------
    ndarray, float32
        Ground disparity, finite everywhere (NaN only when no pixel is valid).

    Raises
    ------
    ParamsError
        The ``bulldozer-dtm`` package is not installed.
    """
    import rasterio
    from rasterio.transform import from_origin

    try:
        from bulldozer import dsm_to_dtm
    except ImportError as error:
        raise ParamsError(
            "[objects] ground = \"bulldozer\" needs the bulldozer-dtm package: pip install 'radcons[bulldozer]'"
        ) from error
    valid = np.isfinite(disparity)
    if not valid.any():
        return np.full(disparity.shape, np.nan, np.float32)
    rows, cols = disparity.shape
    profile = {
        "driver": "GTiff", "height": rows, "width": cols, "count": 1, "dtype": "float32", "nodata": np.nan,
        "transform": from_origin(0.0, rows * cell_m, cell_m, cell_m),
    }
    with tempfile.TemporaryDirectory(prefix="radcons_ground_") as folder:
        surface, out = Path(folder) / "surface.tif", Path(folder) / "bulldozer"
        with rasterio.open(surface, "w", **profile) as raster:
            raster.write((disparity / np.float32(px_per_m)).astype(np.float32), 1)
        log = logging.getLogger("bulldozer")
        muted, log.disabled = log.disabled, True
        try:
            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
                dsm_to_dtm(
                    dsm_path=str(surface), output_dir=str(out), max_object_size=float(max_object_m), nb_max_workers=1
                )
        finally:
            log.disabled = muted
        with rasterio.open(out / "dtm.tif") as raster:
            ground = raster.read(1).astype(np.float32) * np.float32(px_per_m)
    known = np.isfinite(ground)
    if not known.all():
        nearest = ndimage.distance_transform_edt(~known, return_distances=False, return_indices=True)
        ground = ground[tuple(nearest)]
    return ground


def height_above_ground(
    disparity: np.ndarray, ground: np.ndarray, px_per_m: float | None
) -> tuple[np.ndarray, str, float]:
    """Height above ground, in metres when the geometry is known, else in disparity pixels.

    ``h = (d - ground) / px_per_m``: one metre of height adds ``px_per_m = r / g`` pixels of
    disparity (``r`` the base-to-height ratio, ``g`` the ground sample distance in metres;
    or the inverse of the metres per disparity pixel of RPC models).

    Returns
    -------
    height : ndarray, float32
    unit : str
        ``"m"`` or ``"px"``.
    px_per_unit : float
    """
    if px_per_m and px_per_m > 0:
        px_per_unit, unit = float(px_per_m), "m"
    else:
        px_per_unit, unit = 1.0, "px"
    return ((disparity - ground) / np.float32(px_per_unit)).astype(np.float32), unit, px_per_unit
