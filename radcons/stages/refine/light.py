"""Light that varies across the scene: a gain and an offset per tile, blended (refine stage option).

After the target's whole-image mapping onto the reference (histogram matching), the
moments line of eq 10 (gain = ratio of standard deviations, offset matching the means) is
fitted per tile of a ``tiles x tiles`` grid, over the valid pixels of the tile's window
enlarged by half a tile on every side (rows correspond in a rectified pair and the
disparity is small against a tile). A pixel's gain and offset are the blends of the tiles'
with bilinear (tent) weights centred on the tile centres (:class:`LightField`), so both
vary smoothly, the correction has no seams, and a positive gain at every pixel keeps the
order of grey values. It takes out what one mapping cannot: a light gradient, vignetting
or haze across the scene.

* :func:`tile_windows`: each tile's window;
* :func:`tile_line`: one tile's gain and offset from the two images' moments there;
* :class:`LightField`: the tiles' lines and the blended gain and offset at any pixel
  (scene mode evaluates it window by window);
* :func:`local_light_correction`: the whole correction of an image in memory;
* :func:`light_spread`: how much a correction moves the target. Tiles differ also where no
  light does (parallax, changes between the dates, texture lost to compression); the
  refine stage applies the correction only when it is large
  (:func:`radcons.stages.refine.run.background_mapping`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from radcons.errors import ParamsError

__all__ = ["MIN_TILE_PIXELS", "tile_windows", "tile_line", "LightField", "local_light_correction", "light_spread"]

#: A tile whose window holds fewer valid pixels than this in either image keeps gain 1 and
#: offset 0 (the whole-image mapping).
MIN_TILE_PIXELS = 256


def tile_windows(shape: tuple[int, int], tiles: int) -> list[tuple[int, int, int, int, int, int]]:
    """``(i, j, y0, y1, x0, x1)`` of each tile of a ``tiles x tiles`` grid over an image of
    ``shape``: its window, the tile enlarged by half a tile on every side, cut at the border."""
    rows, cols = shape
    windows = []
    for i in range(tiles):
        y0, y1 = int(max(0, (i - 0.5) * rows / tiles)), int(min(rows, (i + 1.5) * rows / tiles))
        for j in range(tiles):
            x0, x1 = int(max(0, (j - 0.5) * cols / tiles)), int(min(cols, (j + 1.5) * cols / tiles))
            windows.append((i, j, y0, y1, x0, x1))
    return windows


def tile_line(reference: tuple[int, float, float], target: tuple[int, float, float]) -> tuple[float, float]:
    """Gain and offset of one tile (eq 10's moments line) from ``(count, mean, std)`` of the
    valid pixels of each image in its window; ``(1, 0)`` for fewer than
    :data:`MIN_TILE_PIXELS` pixels in either, or a flat target."""
    (n_ref, mean_ref, std_ref), (n_tgt, mean_tgt, std_tgt) = reference, target
    if min(n_ref, n_tgt) < MIN_TILE_PIXELS or not std_tgt > 0:
        return 1.0, 0.0
    gain = np.float64(std_ref / std_tgt)
    return float(gain), float(mean_ref - gain * mean_tgt)


@dataclass(frozen=True)
class LightField:
    """The tiles' gains and offsets over an image of ``shape``, blended between tile centres.

    Attributes
    ----------
    gains, offsets : ndarray
        ``(tiles, tiles)`` lines of the tiles (:func:`tile_line`).
    shape : (int, int)
        The image (or scene) the grid covers.
    """

    gains: np.ndarray
    offsets: np.ndarray
    shape: tuple[int, int]

    def at(self, rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gain and offset ``(len(rows), len(cols))`` at the pixels of rows ``rows`` and
        columns ``cols`` of the image (absolute indices)."""
        tiles = self.gains.shape[0]
        weight_y = _tents(np.asarray(rows) + 0.5, (np.arange(tiles) + 0.5) * self.shape[0] / tiles)
        weight_x = _tents(np.asarray(cols) + 0.5, (np.arange(tiles) + 0.5) * self.shape[1] / tiles)
        return weight_y.T @ self.gains @ weight_x, weight_y.T @ self.offsets @ weight_x

    def apply(self, target: np.ndarray, origin: tuple[int, int] = (0, 0)) -> np.ndarray:
        """``gain * target + offset`` (float32, NaN kept) of a window of the image whose first
        pixel is at ``origin`` (row, column)."""
        rows = np.arange(target.shape[0]) + origin[0]
        cols = np.arange(target.shape[1]) + origin[1]
        gain, offset = self.at(rows, cols)
        return (gain * target + offset).astype(np.float32)


def local_light_correction(reference: np.ndarray, target: np.ndarray, tiles: int) -> np.ndarray:
    """Tile-wise gain and offset of the target onto the reference, blended between tiles (module notes).

    Parameters
    ----------
    reference, target : ndarray
        2-D images of one shape, NaN where invalid.
    tiles : int
        Tiles per side (>= 1; 1 is one moments line for the whole image).

    Returns
    -------
    ndarray, float32
        The corrected target, NaN kept.

    Raises
    ------
    ParamsError
        ``tiles < 1`` or images of different shapes.
    """
    if tiles < 1:
        raise ParamsError(f"local light correction needs tiles >= 1, got {tiles}")
    if reference.shape != target.shape:
        raise ParamsError(f"local light correction needs images of one shape, got {reference.shape} and {target.shape}")
    gains, offsets = np.ones((tiles, tiles)), np.zeros((tiles, tiles))
    for i, j, y0, y1, x0, x1 in tile_windows(target.shape, tiles):
        windows = (reference[y0:y1, x0:x1], target[y0:y1, x0:x1])
        gains[i, j], offsets[i, j] = tile_line(*(_moments(w[np.isfinite(w)]) for w in windows))
    return LightField(gains, offsets, target.shape).apply(target)


def _moments(values: np.ndarray) -> tuple[int, float, float]:
    """``(count, mean, std)`` of valid values (NaN mean and std when there are none)."""
    return (values.size, values.mean(), values.std()) if values.size else (0, np.nan, np.nan)


def light_spread(reference: np.ndarray, target: np.ndarray, corrected: np.ndarray) -> float:
    """How much a light correction moves the target: the standard deviation of
    ``corrected - target`` over the valid pixels, as a share of the reference's 1st..99th
    percentile range (0.0 when either has no valid pixel or the reference is flat).

    A correction that follows content differing between tiles (parallax, changes between
    the dates, texture lost to compression) moves the target by a few hundredths and
    reorders grey values the matcher reads; light varying across the scene moves it by
    several (the values measured: ``docs/tuning.md``).
    """
    moved = (corrected - target)[np.isfinite(corrected) & np.isfinite(target)]
    valid = reference[np.isfinite(reference)]
    if moved.size == 0 or valid.size == 0:
        return 0.0
    low, high = np.percentile(valid, [1, 99])
    return float(moved.std() / (high - low)) if high > low else 0.0


def _tents(positions: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """Weights ``(len(centres), len(positions))`` of linear interpolation between centres.

    Each column sums to 1; positions before the first centre or after the last take that
    centre's weight 1.
    """
    weights = np.zeros((centres.size, positions.size))
    if centres.size == 1:
        weights[0] = 1.0
        return weights
    clamped = np.clip(positions, centres[0], centres[-1])
    index = np.clip(np.searchsorted(centres, clamped, side="right") - 1, 0, centres.size - 2)
    fraction = (clamped - centres[index]) / (centres[index + 1] - centres[index])
    columns = np.arange(positions.size)
    weights[index, columns] = 1.0 - fraction
    weights[index + 1, columns] += fraction
    return weights
