"""Approximate nearest descriptors: FLANN's randomised k-d trees, the same on every call.

Lowe (2004, "Distinctive image features from scale-invariant keypoints", IJCV 60(2))
matches SIFT descriptors by an approximate nearest-neighbour search; FLANN's randomised
k-d trees (Muja and Lowe 2009, "Fast approximate nearest neighbors with automatic
algorithm configuration", VISAPP) are OpenCV's form of it. The trees split on dimensions
drawn from OpenCV's random generator, so the matches of one pair depend on the
generator's state; :func:`approximate_matcher` seeds it first, so a pair gives the same
matches every time.
"""

from __future__ import annotations

import cv2

__all__ = ["approximate_matcher", "KD_TREES", "CHECKS"]

#: Randomised k-d trees, and the leaves each query visits (about 5 times faster than the
#: exhaustive search on 15 000 SIFT descriptors, with the same matches on common rows;
#: ``docs/geometry.md``).
KD_TREES = 4
CHECKS = 64


def approximate_matcher() -> cv2.FlannBasedMatcher:
    """A FLANN matcher of :data:`KD_TREES` trees and :data:`CHECKS` checks, OpenCV's
    random generator (of the calling thread) seeded so that its trees are reproducible."""
    cv2.setRNGSeed(0)
    return cv2.FlannBasedMatcher({"algorithm": 1, "trees": KD_TREES}, {"checks": CHECKS})
