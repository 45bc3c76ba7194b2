"""SIFT matches between the two images of a pair.

Keypoints and descriptors are OpenCV's SIFT (Lowe 2004, "Distinctive image features from
scale-invariant keypoints", IJCV 60(2)) on an 8-bit copy of each image stretched between
its own robust percentiles. Each reference descriptor's two nearest target descriptors are
found by an exhaustive search, or by FLANN's randomised k-d trees
(:func:`radcons.numerics.nearest.approximate_matcher`), and a match is kept by Lowe's
ratio test (nearest distance below ``ratio`` times the second nearest); duplicates are
removed.

The approximate search serves callers that keep only the matches sharing a row: a query
whose true nearest neighbour is missed usually fails the ratio test or lands off the rows,
so those callers keep as many matches in a fraction of the time (``docs/geometry.md``).
Callers that fit a geometry on every match (the affine epipolar fit, the row levelling)
search exhaustively: on a small pair the matches the approximate search misses are the
ones that show relief.
"""

from __future__ import annotations

import cv2
import numpy as np

from radcons.numerics.nearest import approximate_matcher
from radcons.numerics.stretch import robust_range
from radcons.results import Matches
from radcons.stages.rectify.params import RectifyParams

__all__ = ["match_sift"]

#: Keypoints keep this far (px) from invalid pixels, whose fill would make false corners.
_MASK_EROSION = 4


def _stretch_to_uint8(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """8-bit copy for SIFT between the image's own percentiles, and its detection mask."""
    valid = np.isfinite(image)
    lo, hi = robust_range(image[valid])
    spread = hi - lo if hi > lo else 1.0
    filled = np.where(valid, image, np.float32(np.median(image[valid])))
    scaled = np.clip((filled - lo) * (255.0 / spread), 0, 255).astype(np.uint8)
    kernel = np.ones((2 * _MASK_EROSION + 1, 2 * _MASK_EROSION + 1), np.uint8)
    mask = cv2.erode(valid.astype(np.uint8), kernel, borderType=cv2.BORDER_CONSTANT, borderValue=1)
    return scaled, mask


def match_sift(
    reference: np.ndarray, target: np.ndarray, params: RectifyParams, approximate: bool = False
) -> Matches:
    """SIFT matches between two images, Lowe's ratio test, duplicates removed.

    Parameters
    ----------
    reference, target : ndarray
        Single-band float32 images, NaN where invalid (keypoints keep 4 px away from
        invalid pixels).
    params : RectifyParams
        Uses ``ratio`` and ``max_features``.
    approximate : bool
        Search the nearest descriptors with FLANN's k-d trees (module notes) instead of
        exhaustively.

    Returns
    -------
    Matches
        Positions ``(x, y)`` of matched keypoints (OpenCV keypoint centres, i.e. pixel
        centres at integer coordinates).
    """
    sift = cv2.SIFT_create(nfeatures=params.max_features)
    features = []
    for image in (reference, target):
        scaled, mask = _stretch_to_uint8(image)
        keypoints, descriptors = sift.detectAndCompute(scaled, mask)
        features.append((keypoints, descriptors))
    (kp_ref, desc_ref), (kp_tgt, desc_tgt) = features
    if desc_ref is None or desc_tgt is None or len(kp_tgt) < 2:
        return Matches.empty()
    matcher = approximate_matcher() if approximate else cv2.BFMatcher(cv2.NORM_L2)
    pairs = matcher.knnMatch(desc_ref, desc_tgt, k=2)
    good = [p[0] for p in pairs if len(p) == 2 and p[0].distance < params.ratio * p[1].distance]
    if not good:
        return Matches.empty()
    ref_xy = np.array([kp_ref[m.queryIdx].pt for m in good], np.float32)
    tgt_xy = np.array([kp_tgt[m.trainIdx].pt for m in good], np.float32)
    unique = np.unique(np.hstack([ref_xy, tgt_xy]), axis=0)
    return Matches(unique[:, :2].copy(), unique[:, 2:].copy())
