"""Section 3's SIFT matches of a whole scene at full resolution, tile by tile on the cluster.

The in-memory stage (:func:`radcons.stages.association.run.match_features`) stretches each
image to 8 bits between its 0.5th and 99.5th percentiles, keeps its ``max_features``
strongest SIFT keypoints and matches them along the rows. Scene mode does the same
without holding an image:

* the percentiles come from the scene's grey-value counts (:mod:`radcons.scene.stats`),
  or from the decimated copy where there are none;
* keypoints are detected on tiles of :data:`FEATURE_TILE` px read with a
  :data:`FEATURE_MARGIN` px margin (keypoints within 5 px per octave of an image's edge
  are dropped and descriptors reach some 14 px per octave; tile origins stay multiples of
  64, so the octaves' sampling grids are the whole image's), each keypoint kept by the
  tile whose core holds it;
* the strongest keypoints at the density of an in-memory run of a 4096 px image: the
  response of the ``max_features``-th strongest keypoint of a sample of tiles
  (:func:`radcons.scene.pass1.sample_windows`, 16 Mpx: the whole of a scene up to that
  size, whose keypoints are then the stage's) is the threshold, and keypoints under it
  are dropped (each tile keeps at most its ``max_features`` strongest, a superset of
  those). A larger scene thus keeps ``max_features`` per 16 Mpx, not over the scene: on
  the 16384 px demo mosaic, 8000 keypoints over the scene left no match at all;
* the stage's row-constrained matching (ratio test, mutual check), strip by strip of
  :data:`FEATURE_TILE` rows on the workers: a keypoint's matches depend only on the
  keypoints within :func:`strip_margin` rows of it, so each strip is matched with its
  neighbours' keypoints and the result is the whole scene's. The keypoints stay on the
  workers (only their responses come to this process, for the threshold), and each match
  carries the object labels under its two points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from radcons.numerics.stretch import stretch_to_uint8
from radcons.results import Matches
from radcons.scene.source import SceneImage, Window
from radcons.scene.stats import percentile_of_counts

__all__ = ["FEATURE_TILE", "FEATURE_MARGIN", "Keypoints", "stretch_levels", "detect_tile", "strip_margin", "scene_matches"]

#: Tile side, px, of keypoint detection.
FEATURE_TILE = 1024
#: Margin, px, read around each tile for detection (a multiple of 64).
FEATURE_MARGIN = 64


@dataclass(frozen=True)
class Keypoints:
    """Keypoints of one image (or one tile): scene positions ``(x, y)``, responses,
    descriptors and the object label under each."""

    xy: np.ndarray
    response: np.ndarray
    descriptors: np.ndarray
    labels: np.ndarray

    def __len__(self) -> int:
        return len(self.xy)

    def select(self, keep: np.ndarray) -> "Keypoints":
        """The keypoints where ``keep`` is True (or at the indices ``keep``)."""
        return Keypoints(self.xy[keep], self.response[keep], self.descriptors[keep], self.labels[keep])

    @staticmethod
    def join(parts: list["Keypoints"]) -> "Keypoints":
        """All keypoints of ``parts``, in order."""
        if not parts:
            return Keypoints(np.zeros((0, 2), np.float32), np.zeros(0, np.float32), np.zeros((0, 128), np.float32),
                             np.zeros(0, np.int32))
        return Keypoints(*(np.concatenate([getattr(p, f) for p in parts]) for f in ("xy", "response", "descriptors", "labels")))


def stretch_levels(stats: Any, decimated: np.ndarray) -> tuple[float, float]:
    """The 0.5th and 99.5th percentiles of an image's valid pixels (the stage's 8-bit stretch).

    From the scene's grey-value counts (``stats.grid``, ``stats.counts``) where it has
    them, else from the decimated copy.
    """
    if stats.counts is not None and stats.counts.sum() > 0:
        return percentile_of_counts(stats.grid, stats.counts, 0.5), percentile_of_counts(stats.grid, stats.counts, 99.5)
    values = decimated[np.isfinite(decimated)]
    low, high = np.percentile(values, [0.5, 99.5]) if values.size else (0.0, 0.0)
    return float(low), float(high)


def detect_tile(window: Window, image: SceneImage, labels: Any, which: str, levels: tuple[float, float],
                params: Any, threshold: float = -math.inf) -> Keypoints:
    """SIFT keypoints of one tile: those in its core with a response of at least ``threshold``.

    Parameters
    ----------
    window : Window
        The tile's core.
    image : SceneImage
    labels : SceneLabels
        Object labels (``which``: ``"reference"`` or ``"target"``), read under each keypoint.
    levels : (float, float)
        The image's stretch to 8 bits (:func:`stretch_levels`).
    params : AssociationParams
    threshold : float
        Lowest response kept.
    """
    rows, columns = image.shape
    r0, r1, c0, c1 = window
    padded = (max(r0 - FEATURE_MARGIN, 0), min(r1 + FEATURE_MARGIN, rows),
              max(c0 - FEATURE_MARGIN, 0), min(c1 + FEATURE_MARGIN, columns))
    u8, mask = stretch_to_uint8(image.read_float(padded), levels, params.border)
    sift = cv2.SIFT_create(nfeatures=params.max_features, contrastThreshold=params.contrast_threshold)
    found, descriptors = sift.detectAndCompute(u8, mask)
    if descriptors is None or not found:
        return Keypoints.join([])
    xy = np.array([kp.pt for kp in found], np.float32) + np.array([padded[2], padded[0]], np.float32)
    response = np.array([kp.response for kp in found], np.float32)
    keep = (xy[:, 0] >= c0) & (xy[:, 0] < c1) & (xy[:, 1] >= r0) & (xy[:, 1] < r1) & (response >= threshold)
    xy, response, descriptors = xy[keep], response[keep], descriptors[keep].astype(np.float32)
    tile_labels = labels.window(which, window)
    at = (np.clip(np.rint(xy[:, 1]).astype(np.int64) - r0, 0, r1 - r0 - 1),
          np.clip(np.rint(xy[:, 0]).astype(np.int64) - c0, 0, c1 - c0 - 1))
    return Keypoints(xy, response, descriptors, tile_labels[at].astype(np.int32))


def _responses(item: tuple[Window, Keypoints]) -> np.ndarray:
    return item[1].response


def _above(item: tuple[Window, Keypoints], threshold: float) -> Keypoints:
    return item[1].select(item[1].response >= threshold)


def _strongest(cluster: Any, image: SceneImage, labels: Any, which: str, levels: tuple[float, float],
               params: Any, tiles: list[Window], sample: list[Window]) -> list[Any]:
    """The strongest keypoints of each of ``tiles`` (in order), left on the cluster
    (futures), ``max_features`` per ``sample`` (see the module notes)."""
    what = f"keypoints of {image.path.name}"
    detected = cluster.submit(detect_tile, sample, image, labels, which, levels, params)
    responses = np.sort(np.concatenate(cluster.map(_responses, list(zip(sample, detected)), what=what)))[::-1]
    rank = params.max_features
    threshold = float(responses[rank - 1]) if 0 < rank <= responses.size else -math.inf
    kept = dict(zip(sample, cluster.submit(_above, list(zip(sample, detected)), threshold)))
    rest = [w for w in tiles if w not in kept]
    kept.update(zip(rest, cluster.submit(detect_tile, rest, image, labels, which, levels, params, threshold)))
    return [kept[w] for w in tiles]


def strip_margin(params: Any) -> int:
    """Rows around a strip whose keypoints its matches depend on.

    The ratio test looks ``max(ratio_rows, row_tolerance)`` rows away and the mutual check
    ``2 * row_tolerance``, with queries taken in bands of 16 rows
    (:func:`radcons.stages.association.run._nearest_in_rows`).
    """
    return 2 * math.ceil(max(params.ratio_rows, params.row_tolerance)) + 32


def _match_strip(job: tuple[int, int, list, list], params: Any) -> tuple[np.ndarray, ...]:
    """The matches of the reference keypoints in rows ``start .. stop`` of the scene.

    ``job`` is ``(start, stop, reference tiles, target tiles)``, each tile ``(index,
    Keypoints)`` of the tiles within :func:`strip_margin` rows. Returns the tile index and
    index in its tile of each matched reference keypoint (the order of the whole scene's
    matches), both points and the labels under them.
    """
    from radcons.stages.association.run import (
        _match_rows,  # the stage's matching, not a copy of it
    )

    start, stop, ref_tiles, tgt_tiles = job
    ref = Keypoints.join([k for _, k in ref_tiles])
    tgt = Keypoints.join([k for _, k in tgt_tiles])
    tile = np.concatenate([np.full(len(k), i, np.int64) for i, k in ref_tiles] or [np.zeros(0, np.int64)])
    within = np.concatenate([np.arange(len(k)) for _, k in ref_tiles] or [np.zeros(0, np.int64)])
    queries = np.flatnonzero((ref.xy[:, 1] >= start) & (ref.xy[:, 1] < stop))
    ref_idx, tgt_idx = _match_rows(ref.xy, ref.descriptors, tgt.xy, tgt.descriptors, params, queries)
    return tile[ref_idx], within[ref_idx], ref.xy[ref_idx], tgt.xy[tgt_idx], ref.labels[ref_idx], tgt.labels[tgt_idx]


def scene_matches(cluster: Any, pair: Any, labels: Any, levels: tuple[tuple[float, float], tuple[float, float]],
                  params: Any, sample: list[Window]) -> tuple[Matches, np.ndarray, np.ndarray]:
    """Full-resolution SIFT matches of the scene, and the reference and target labels at them.

    ``sample`` are tiles of :data:`FEATURE_TILE` px of the scene's grid (the response
    threshold's sample).
    """
    from radcons.scene.tiles import tile_grid

    tiles = tile_grid(pair.shape, FEATURE_TILE)
    labels = cluster.scatter(labels)  # once, not with every task (a segmentation's labels are arrays)
    ref = _strongest(cluster, pair.reference, labels, "reference", levels[0], params, tiles, sample)
    tgt = _strongest(cluster, pair.target, labels, "target", levels[1], params, tiles, sample)
    margin = strip_margin(params)
    jobs = []
    for start in range(0, pair.shape[0], FEATURE_TILE):
        stop = min(start + FEATURE_TILE, pair.shape[0])
        near = [i for i, w in enumerate(tiles) if w[0] < stop + margin and w[1] > start - margin]
        jobs.append((start, stop, [(i, ref[i]) for i in near], [(i, tgt[i]) for i in near]))
    parts = cluster.map(_match_strip, jobs, params, what="keypoint matching of")
    tile, within, ref_xy, tgt_xy, ref_labels, tgt_labels = (np.concatenate(column) for column in zip(*parts))
    order = np.lexsort((within, tile))
    return Matches(ref_xy[order], tgt_xy[order]), ref_labels[order], tgt_labels[order]
