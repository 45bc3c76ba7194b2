"""Pass 2: every image stage on one tile with a halo, from the pass-1 quantities.

A tile is read with a halo wide enough for the local filters that follow (the refine
stage's feathering, the sharpness blur, the smoothness stage's patches and block
matching); each stage then runs on the padded tile with the scene-wide values of pass 1
as explicit inputs, and the halo is cut off. At the scene's own borders there is no halo
and the filters reflect, as they do on a whole image.

Per stage:

* global (eq 4-6): ``lambda * I`` with the scene's ``lambda``;
* refine (eq 7-12): the background (histogram matching onto the reference, from the
  scene's grey-value counts, or the global result), each target object through its
  scene-wide fit, feathered as in the stage, clipped to the reference's scene range;
* sharpness: the scene's relative blur, as a Gaussian on the sharper image, then (noise
  matching, ``noise = "cleaner"``) the scene's smoothing Gaussian on the noisier one;
* smoothness (eq 13-19): the stage itself on the padded tile with the scene's noise
  sigmas and association. Its eq 18 noise update is computed per tile (the tile's
  own change), the one approximation of scene mode.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from radcons.params import Params
from radcons.pipeline import to_output_dtype
from radcons.results import Association
from radcons.scene.light import mapped_background
from radcons.scene.pairwide import SceneLabels
from radcons.scene.source import ScenePair, Window
from radcons.stages import TILE_STAGES
from radcons.stages.refine.light import LightField

__all__ = ["SceneQuantities", "tile_grid", "process_window", "output_tile", "halo_width", "TILE_STAGES"]



@dataclass(frozen=True)
class SceneQuantities:
    """Pair-wide inputs of the tiles, from pass 1.

    Attributes
    ----------
    params : Params
    lambdas : (float, float)
        Eq 5's lambda of the reference and the target (1 when the global stage is off).
    labels : SceneLabels
    fits : dict
        Target object id -> applied ``(gain, offset)``.
    background : (ndarray, ndarray) or None
        Histogram matching of the target's grey values onto the reference's
        (``np.interp(target, *background)``), or None for the global result.
    light : LightField or None
        The light correction across the scene applied after ``background``, or None.
    clip_range : (float, float) or None
        The refined target is clipped to this range (the reference's after eq 6).
    blur : (float, str)
        Gaussian sigma, px, and the image it blurs (``"reference"``, ``"target"``, ``"none"``).
    noise : (float, float) or None
        Noise sigma of each image after the sharpness stage (smoothness input).
    association : Association or None
        In full-resolution pixels (smoothness input).
    ranges : ((float, float), (float, float))
        Valid value range of the reference and the target as read.
    stages : tuple of str
        The image stages switched on, in order.
    denoise : float
        The sharpness stage's noise matching, as ``SharpnessParams.denoise``: the sigma
        (px) of the Gaussian that smooths the noisier image, positive for the target,
        negative for the reference, 0 for none.
    """

    params: Params
    lambdas: tuple[float, float]
    labels: SceneLabels
    fits: dict[int, tuple[float, float]]
    background: tuple[np.ndarray, np.ndarray] | None
    clip_range: tuple[float, float] | None
    blur: tuple[float, str]
    noise: tuple[float, float] | None
    association: Association | None
    ranges: tuple[tuple[float, float], tuple[float, float]]
    stages: tuple[str, ...]
    denoise: float = 0.0
    light: LightField | None = None


def tile_grid(shape: tuple[int, int], size: int) -> list[Window]:
    """Tiles of ``size`` px covering an image, row by row."""
    rows, columns = shape
    return [(r, min(r + size, rows), c, min(c + size, columns)) for r in range(0, rows, size) for c in range(0, columns, size)]


def halo_width(
    params: Params, stages: tuple[str, ...], blur_sigma: float, association: Association | None, denoise: float = 0.0
) -> int:
    """Pixels of halo the stages after ``global`` need around a tile (Gaussians reach 4 sigma)."""
    halo = 0
    if "refine" in stages and params.refine.blend_width > 0:
        halo += math.ceil(params.refine.blend_width) + 1
    for sigma in (blur_sigma, abs(denoise)):
        if "sharpness" in stages and sigma > 0:
            halo += math.ceil(4 * sigma) + 2
    if "smoothness" in stages:
        smooth = params.smoothness
        shifts = [abs(obj.modal_disparity) for obj in association.objects] if association is not None else []
        halo += 2 * smooth.patch_size + smooth.search_window + math.ceil(max(shifts, default=0.0))
    return halo


def _padded(window: Window, halo: int, shape: tuple[int, int]) -> tuple[Window, tuple[slice, slice]]:
    r0, r1, c0, c1 = window
    padded = (max(r0 - halo, 0), min(r1 + halo, shape[0]), max(c0 - halo, 0), min(c1 + halo, shape[1]))
    core = (slice(r0 - padded[0], r1 - padded[0]), slice(c0 - padded[2], c1 - padded[2]))
    return padded, core


def _feather_weight(mask: np.ndarray, width: float) -> np.ndarray:
    """``min(distance to the outside / width, 1)`` inside ``mask``; the mask continues past its edges."""
    padded = np.pad(mask.astype(np.uint8), 1, mode="edge")
    distance = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)[1:-1, 1:-1]
    return np.minimum(distance / np.float32(width), np.float32(1.0))


def _refine(target: np.ndarray, original: np.ndarray, labels: np.ndarray, q: SceneQuantities,
            origin: tuple[int, int]) -> np.ndarray:
    """The refined target of one padded tile whose first pixel is at ``origin`` (row,
    column) of the scene (eq 8, feathered; background and light; clip)."""
    params = q.params.refine
    if q.background is not None:
        refined = mapped_background(original, q.background, q.light, origin)
    else:
        refined = target.copy()
    present = np.unique(labels)
    width = params.blend_width
    for tgt_id in present[present > 0]:
        fit = q.fits.get(int(tgt_id))
        if fit is None:
            continue
        if width == 0:
            mask = labels == tgt_id
            corrected = np.float32(fit[0]) * target[mask] + np.float32(fit[1])
            refined[mask] = corrected
            continue
        rows, columns = np.nonzero(labels == tgt_id)
        margin = math.ceil(width) + 1
        box = (
            slice(max(rows.min() - margin, 0), min(rows.max() + 1 + margin, labels.shape[0])),
            slice(max(columns.min() - margin, 0), min(columns.max() + 1 + margin, labels.shape[1])),
        )
        weight = _feather_weight(labels[box] == tgt_id, width)
        region = refined[box]
        region += weight * (np.float32(fit[0]) * target[box] + np.float32(fit[1]) - region)
    if q.clip_range is not None:
        np.clip(refined, *q.clip_range, out=refined)
    return refined


def _sharpness(reference: np.ndarray, target: np.ndarray, q: SceneQuantities) -> tuple[np.ndarray, np.ndarray]:
    """The scene's relative blur on the sharper image, then its noise matching on the noisier one."""
    from radcons.numerics.valid_pixels import gaussian_blur

    images = [reference, target]
    sigma, blurred = q.blur
    if blurred != "none":
        index = ("reference", "target").index(blurred)
        images[index] = gaussian_blur(images[index], sigma)
    if q.denoise != 0.0:
        index = int(q.denoise > 0)
        images[index] = gaussian_blur(images[index], abs(q.denoise))
    return images[0], images[1]


def process_window(pair: ScenePair, q: SceneQuantities, window: Window, until: str | None = None,
                   halo: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The image stages of ``q.stages`` (up to ``until``) on one window; float32, NaN kept.

    Parameters
    ----------
    pair : ScenePair
    q : SceneQuantities
    window : (row_start, row_stop, column_start, column_stop)
    until : str, optional
        Last stage to run (default: all of ``q.stages``).
    halo : int, optional
        Halo width, px (default :func:`halo_width` of the stages run).
    """
    stages = q.stages if until is None else tuple(s for s in q.stages if TILE_STAGES.index(s) <= TILE_STAGES.index(until))
    if halo is None:
        halo = halo_width(q.params, stages, q.blur[0], q.association, q.denoise)
    padded, core = _padded(window, halo, pair.shape)
    reference_raw = pair.reference.read_float(padded)
    target_raw = pair.target.read_float(padded)
    reference = reference_raw * np.float32(q.lambdas[0])
    target = target_raw * np.float32(q.lambdas[1])
    if "refine" in stages:
        target = _refine(target, target_raw, q.labels.window("target", padded), q, (padded[0], padded[2]))
    if "sharpness" in stages:
        reference, target = _sharpness(reference, target, q)
    if "smoothness" in stages:
        from radcons.stages.smoothness.run import smoothness_consistency

        result = smoothness_consistency(
            reference, target, q.labels.window("reference", padded), q.labels.window("target", padded),
            q.association, q.params.smoothness, q.noise,
        )
        reference, target = result.reference, result.target
    return reference[core], target[core]


def output_tile(window: Window, pair: ScenePair, q: SceneQuantities,
                dtypes: tuple[np.dtype, np.dtype]) -> tuple[np.ndarray, np.ndarray]:
    """One tile of the consistent pair in the output dtypes (as :func:`radcons.summary.output_images`)."""
    reference, target = process_window(pair, q, window)
    if pair.reference.dtype != pair.target.dtype and dtypes[1] == pair.target.dtype:
        (lo_r, hi_r), (lo_t, hi_t) = q.ranges
        scale = (hi_t - lo_t) / (hi_r - lo_r) if hi_r > lo_r else 1.0
        target = ((target - lo_r) * scale + lo_t).astype(np.float32)
    return (
        to_output_dtype(reference, dtypes[0], pair.reference.nodata),
        to_output_dtype(target, dtypes[1], pair.target.nodata),
    )
