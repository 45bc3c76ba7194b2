"""Pass 1: the pair-wide quantities every tile needs, streamed over blocks and a decimated copy.

* eq 4-6: ``A`` (sums over row blocks) and ``sigma_max`` of each image (power iteration
  as block products, :func:`radcons.scene.stats.sigma_max_by_blocks`), hence ``lambda``;
* refine: the grey-value counts of both images (the background's histogram matching;
  with ``background_noise``, its noise-aware form, from both images' variances and their
  noise sigmas on the sample windows below), the clipping levels, the objects, their
  association and fits (:mod:`radcons.scene.pairwide`, :mod:`radcons.scene.object_fits`);
* sharpness: the relative blur of the pair, estimated as the stage does on sample windows
  of the refined scene (:data:`SAMPLE_PIXELS` of it: on the 4096 px demo pair a quarter
  of the scene moved the estimate by 3 % and left the rms difference of the output from
  the in-memory run at 0.043 % of the range, where sampling the whole scene ran the
  refine stage over it twice), stacked with NaN rows
  between them so that no Welch tile or noise block spans two windows; with ``noise =
  "cleaner"``, its noise matching decided as the stage does on the same windows after
  the blur (each window on whole 16 px rows of the stack, so that the code grid and the
  noise blocks of :mod:`radcons.stages.sharpness.noise_match` stay in phase);
* smoothness: each image's noise sigma after the sharpness stage, on the same windows.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, Callable

import numpy as np

from radcons.errors import InputError
from radcons.noise import noise_sigma
from radcons.params import Params
from radcons.results import Association
from radcons.scene import stats as st
from radcons.scene.cluster import SceneCluster
from radcons.scene.features import FEATURE_TILE, scene_matches, stretch_levels
from radcons.scene.object_fits import choose_fits, fit_objects
from radcons.scene.pairwide import (
    HEIGHT_NOTE,
    FitContext,
    decimated_images,
    decimation_factor,
    object_boxes,
    scene_labels,
)
from radcons.scene.light import block_moved_moments, block_tile_moments, scene_light, scene_spread
from radcons.scene.source import SceneImage, ScenePair, Window
from radcons.scene.tiles import SceneQuantities, process_window
from radcons.scene.window_association import sift_associations, with_matches
from radcons.stages.refine.light import LightField

__all__ = ["pair_quantities", "sample_windows", "SAMPLE_PIXELS"]

#: Pixels of each image the relative blur and the noise sigmas are estimated on.
SAMPLE_PIXELS = 1 << 22
#: Pixels of each image the response threshold of its strongest keypoints is found on
#: (:mod:`radcons.scene.features`): ``max_features`` keypoints per this many pixels, the
#: density of an in-memory run of a 4096 px image.
FEATURE_SAMPLE_PIXELS = 1 << 24
_SAMPLE_SIDE = 1024
#: Rows a sample window takes in the noise-matching stack are a multiple of this.
_NOISE_BLOCK_ROWS = 16
#: Pixels of one row block of the statistics and of sigma_max's products: a 4096 px
#: scene in 4 blocks per image, so that its passes spread over the workers.
_BLOCK_PIXELS = 1 << 22

Progress = Callable[[str, int, int], None]


def sample_windows(shape: tuple[int, int], pixels: int = SAMPLE_PIXELS, side: int = _SAMPLE_SIDE) -> list[Window]:
    """Windows of ``side`` px spread evenly over the scene, about ``pixels`` in all (all when it fits)."""
    rows, columns = shape
    grid = [(r, min(r + side, rows), c, min(c + side, columns)) for r in range(0, rows, side) for c in range(0, columns, side)]
    count = max(1, pixels // (side * side))
    if len(grid) <= count:
        return grid
    return [grid[i] for i in np.unique(np.linspace(0, len(grid) - 1, count).round().astype(int))]


def _stack(parts: list[np.ndarray], width: int, rows_multiple: int = 2) -> np.ndarray:
    """Windows one above the other, NaN-padded to ``width``, at least two NaN rows between them.

    Each window takes a whole multiple of ``rows_multiple`` rows (its rows and the NaN ones).
    """
    rows = []
    for part in parts:
        height = -(-(part.shape[0] + 2) // rows_multiple) * rows_multiple
        padded = np.full((height, width), np.nan, np.float32)
        padded[: part.shape[0], : part.shape[1]] = part
        rows.append(padded)
    return np.vstack(rows)


def _image_stats(cluster: SceneCluster, image: SceneImage, histogram: bool) -> st.ImageStats:
    blocks = st.row_blocks(image.shape, _BLOCK_PIXELS)
    stats = st.merge_stats(cluster.map(st.block_stats, blocks, image, what=f"statistics of {image.path.name}"))
    if stats.count == 0:
        raise InputError("the image has no valid pixel", image.path)
    if histogram and stats.counts is None:
        counts = cluster.map(st.block_histogram, blocks, image, stats.low, stats.high, what=f"histogram of {image.path.name}")
        stats.counts = np.sum(counts, axis=0)
        edges = np.linspace(stats.low, stats.high if stats.high > stats.low else stats.low + 1.0, st.FINE_BINS + 1)
        stats.grid = 0.5 * (edges[:-1] + edges[1:])
    return stats


def _sigma_max(cluster: SceneCluster, image: SceneImage, fill: float, params: Params) -> float:
    blocks = st.row_blocks(image.shape, _BLOCK_PIXELS)
    what = f"sigma_max of {image.path.name}"

    def gram(v: np.ndarray) -> np.ndarray:
        return np.sum(cluster.map(st.block_gram, blocks, image, fill, v, what=what), axis=0)

    def matvec(v: np.ndarray) -> np.ndarray:
        return np.concatenate(cluster.map(st.block_matvec, blocks, image, fill, np.ravel(v), what=what))

    def rmatvec(u: np.ndarray) -> np.ndarray:
        return np.sum(cluster.map(st.block_rmatvec, blocks, image, fill, np.ravel(u), what=what), axis=0)

    return st.sigma_max_by_blocks(
        gram, image.shape[1], params.global_norm, matvec=matvec, rmatvec=rmatvec, rows=image.shape[0]
    )


def _light(cluster: SceneCluster, pair: ScenePair, params: Params, lambdas: tuple[float, float],
           reference: st.ImageStats, background: Any) -> tuple[LightField | None, float]:
    """The refine stage's light correction across the scene (:mod:`radcons.scene.light`):
    the field if it moves the target by at least ``local_min_light``, else None; and its spread."""
    tiles = params.refine.local_tiles
    blocks = st.row_blocks(pair.shape, _BLOCK_PIXELS)
    moments = [
        np.sum(cluster.map(block_tile_moments, blocks, image, tiles, lam, lut, what=f"light tiles of {image.path.name}"), axis=0)
        for image, lam, lut in ((pair.reference, lambdas[0], None), (pair.target, lambdas[1], background))
    ]
    field = scene_light(*moments, tiles, pair.shape)
    moved = np.sum(cluster.map(block_moved_moments, blocks, pair.target, background, lambdas[1], field,
                               what=f"light correction of {pair.target.path.name}"), axis=0)
    spread = scene_spread(moved, reference, lambdas[0])
    return (field if spread >= params.refine.local_min_light else None), spread


def _fits(cluster: SceneCluster, pair: ScenePair, labels: Any, small: Any, association: Any, params: Params,
          lambdas: tuple[float, float], stats: tuple[st.ImageStats, st.ImageStats], factor: int,
          background: Any, match_labels: tuple[np.ndarray, np.ndarray], light: LightField | None) -> tuple[Any, list, dict]:
    """Objects associated and fitted on the cluster.

    ``association`` holds the SIFT associations; its unassociated objects are searched by
    template matching at full resolution. ``match_labels`` are the labels under each
    match's two points.
    """
    from radcons.stages.association.run import (
        _search_window,  # the stage's rule, not a copy of it
    )

    context = FitContext(
        pair, labels, association.matches, params, lambdas, tuple(s.clip_levels() for s in stats),
        object_boxes(small[0], pair.shape, factor), object_boxes(small[1], pair.shape, factor),
        _search_window(association.matches, params.association), stats[1].mean, background, light,
    )
    shared = cluster.scatter(context)
    items = list(association.objects) + list(association.unassociated_ref)
    # one object per task, the costliest first (template searches, then by window area), so
    # that the workers finish together
    chunks = [[item] for item in sorted(items, key=lambda item: _fit_cost(item, context.reference_boxes), reverse=True)]
    results = [row for part in cluster.map(fit_objects, chunks, shared, what="object association and fits") for row in part]
    matches = association.matches
    objects = sorted(
        (with_matches(obj, matches, *match_labels, params.association) if obj.method == "template" else obj
         for _, obj, _ in results if obj is not None),
        key=lambda obj: obj.ref_id,
    )
    unassociated = sorted(ref_id for ref_id, obj, _ in results if obj is None)
    fits, applied = choose_fits(sorted((fit for _, obj, fit in results if obj is not None), key=lambda fit: fit.ref_id))
    return Association(matches, tuple(objects), tuple(unassociated)), fits, applied


def _fit_cost(item: Any, boxes: dict[int, Window]) -> tuple[bool, int]:
    """Sort key of an object's association and fit: a template search first, then its window's area."""
    ref_id = item if isinstance(item, int) else item.ref_id
    r0, r1, c0, c1 = boxes.get(ref_id, (0, 0, 0, 0))
    return isinstance(item, int), (r1 - r0) * (c1 - c0)


def _relative_blur(cluster: SceneCluster, pair: ScenePair, q: SceneQuantities, windows: list[Window]) -> tuple[float, str, float]:
    from radcons.stages.sharpness.run import relative_blur

    params = q.params.sharpness
    if params.sigma is not None:
        estimate = float(params.sigma)
    else:
        parts = cluster.map(_refined_window, windows, pair, cluster.scatter(q), what="sharpness sample window")
        width = max(w[3] - w[2] for w in windows)
        estimate = relative_blur(_stack([p[0] for p in parts], width), _stack([p[1] for p in parts], width), params)
    sigma = min(params.strength * abs(estimate), params.max_sigma)
    if abs(estimate) < params.min_sigma or sigma == 0.0:
        return 0.0, "none", estimate
    return sigma, "reference" if estimate > 0 else "target", estimate


def _noise_matching(
    cluster: SceneCluster, pair: ScenePair, q: SceneQuantities, windows: list[Window]
) -> tuple[float, dict[str, Any]]:
    """The sharpness stage's noise matching decided on the sample windows after the blur.

    Returns the signed Gaussian sigma of :attr:`SceneQuantities.denoise` (the given
    ``SharpnessParams.denoise`` when there is one) and the gap's ratios.
    """
    from radcons.stages.sharpness.noise_match import noise_smoothing

    params = q.params.sharpness
    if params.denoise is not None:
        return float(params.denoise), {}
    parts = cluster.map(_sharpened_window, windows, pair, cluster.scatter(q), what="noise-matching sample window")
    width = max(w[3] - w[2] for w in windows)
    # whole 16 px rows a window, so that the stack keeps the images' 8 px code grid and noise blocks
    images = [_stack([p[i] for p in parts], width, _NOISE_BLOCK_ROWS) for i in (0, 1)]
    denoise, gap = noise_smoothing(*images, params)
    return denoise, {"noise_ratio": gap.ratio, "block_noise_ratio": gap.block_ratio, "lost_detail": gap.lost_detail}


def _raw_noise(cluster: SceneCluster, pair: ScenePair, windows: list[Window]) -> tuple[float, float]:
    """Noise sigmas of the target and of the reference as read, on the sample windows."""
    parts = cluster.map(_raw_window, windows, pair, what="noise sample window")
    width = max(w[3] - w[2] for w in windows)
    try:
        return tuple(noise_sigma(_stack([p[i] for p in parts], width)) for i in (1, 0))
    except InputError:  # no 2 x 2 block of valid pixels: no noise to add, as in memory
        return 0.0, 0.0


def _raw_window(window: Window, pair: ScenePair) -> tuple[np.ndarray, np.ndarray]:
    return pair.reference.read_float(window), pair.target.read_float(window)


def _refined_window(window: Window, pair: ScenePair, q: SceneQuantities) -> tuple[np.ndarray, np.ndarray]:
    return process_window(pair, q, window, until="refine")


def _sharpened_window(window: Window, pair: ScenePair, q: SceneQuantities) -> tuple[np.ndarray, np.ndarray]:
    return process_window(pair, q, window, until="sharpness")


def pair_quantities(
    pair: ScenePair, params: Params, stages: tuple[str, ...], cluster: SceneCluster, progress: Progress
) -> tuple[SceneQuantities, dict[str, Any]]:
    """Every pair-wide quantity of pass 1, and a summary of them.

    Parameters
    ----------
    pair : ScenePair
    params : Params
    stages : tuple of str
        The image stages to run (among :data:`radcons.scene.tiles.TILE_STAGES`).
    cluster : SceneCluster
    progress : callable
        ``progress(step, index, total)`` before each step.
    """
    steps = ["statistics", "sigma_max", "objects", "fits", "sharpness", "noise"]
    progress(steps[0], 0, len(steps))
    histogram = "refine" in stages and params.refine.background in ("histogram", "local")
    stats = tuple(_image_stats(cluster, image, histogram) for image in (pair.reference, pair.target))
    mean = (stats[0].total + stats[1].total) / (stats[0].count + stats[1].count)
    info: dict[str, Any] = {"A": mean}
    lambdas = (1.0, 1.0)
    if "global" in stages:
        progress(steps[1], 1, len(steps))
        sigmas = tuple(_sigma_max(cluster, image, s.mean, params) for image, s in zip((pair.reference, pair.target), stats))
        if not (mean > 0 and min(sigmas) > 0):
            raise InputError(f"the pair mean A ({mean:g}) and sigma_max ({sigmas}) must be positive", pair.reference.path)
        m, n = pair.shape
        lambdas = tuple(mean * math.sqrt(float(m) * float(n)) / s for s in sigmas)
        info.update(sigma_max_reference=sigmas[0], sigma_max_target=sigmas[1],
                    lambda_reference=lambdas[0], lambda_target=lambdas[1])
    progress(steps[2], 2, len(steps))
    factor = decimation_factor(pair.shape)
    # the decimated copy serves the segmentation and the 8-bit stretch of images without
    # grey-value counts
    supplied = params.objects.use_supplied and pair.reference_objects is not None and pair.target_objects is not None
    needed = not supplied or any(s.counts is None for s in stats)
    decimated = decimated_images(pair, factor) if needed else (None, None)
    labels, small, source, method = scene_labels(pair, decimated, factor, params)
    levels = tuple(stretch_levels(s, d) for s, d in zip(stats, decimated))
    matches, *match_labels = scene_matches(
        cluster, pair, labels, levels, params.association, sample_windows(pair.shape, FEATURE_SAMPLE_PIXELS, FEATURE_TILE)
    )
    ids = np.unique(small[0])
    found, left = sift_associations(matches, *match_labels, [int(i) for i in ids[ids > 0]], params.association)
    association = Association(matches, tuple(found), tuple(left))
    del decimated
    if source == "segmented" and params.objects.method != method:
        info.update(objects_note=HEIGHT_NOTE)
    info.update(decimation=factor, objects_source=source, objects_method=method, matches=len(matches),
                reference_objects=int(np.count_nonzero(np.unique(small[0]))),
                target_objects=int(np.count_nonzero(np.unique(small[1]))))
    progress(steps[3], 3, len(steps))
    windows = sample_windows(pair.shape)
    background = None
    if histogram and params.refine.background_noise:
        noise = _raw_noise(cluster, pair, windows)
        background, added = st.noise_aware_lut(stats[1], stats[0], (lambdas[1], lambdas[0]), noise)
        info.update(background_noise_sigma=noise, background_added_sigma=added)
    elif histogram:
        background = st.histogram_lut(stats[1], stats[0], lambdas[0])
    light = None
    if histogram and params.refine.background == "local":
        light, spread = _light(cluster, pair, params, lambdas, stats[0], background)
        info.update(light_spread=spread, light_applied=light is not None)
    fits, applied = ([], {})
    if "refine" in stages or "smoothness" in stages:
        association, fits, applied = _fits(
            cluster, pair, labels, small, association, params, lambdas, stats, factor, background,
            tuple(match_labels), light,
        )
    if "refine" not in stages:
        fits, applied = [], {}
    clip = (stats[0].low * lambdas[0], stats[0].high * lambdas[0]) if "refine" in stages and params.refine.clip_to_reference else None
    q = SceneQuantities(
        params, lambdas, labels, applied, background, clip, (0.0, "none"), None, association,
        ((stats[0].low, stats[0].high), (stats[1].low, stats[1].high)), stages, light=light,
    )
    if "sharpness" in stages:
        progress(steps[4], 4, len(steps))
        sigma, which, estimate = _relative_blur(cluster, pair, q, windows)
        q = replace(q, blur=(sigma, which))
        info.update(relative_blur=estimate, blurred=which, blur_sigma=sigma)
        if params.sharpness.noise == "cleaner":
            denoise, gap = _noise_matching(cluster, pair, q, windows)
            q = replace(q, denoise=denoise)
            info.update(gap, denoise=denoise)
    if "smoothness" in stages:
        progress(steps[5], 5, len(steps))
        parts = cluster.map(_sharpened_window, windows, pair, cluster.scatter(q), what="noise sample window")
        width = max(w[3] - w[2] for w in windows)
        noise = tuple(noise_sigma(_stack([p[i] for p in parts], width)) for i in (0, 1))
        q = replace(q, noise=noise)
        info["noise_sigma"] = noise
    info["sample_windows"] = len(windows)
    return q, {"info": info, "fits": fits, "association": association}

