"""Cast shadows cut off the objects that spilled onto them.

The height method's regions (:func:`radcons.stages.objects_height.segment_elevated`) come
from a census disparity on a reduced grid whose semi-global smoothing carries a roof's
disparity onto the ground beside it, and a cast shadow there has too little texture to
pull it back: the region, and the image segments it is snapped to, spill from the roof
onto its shadow. Matching cannot take the spill off again: on the demo pairs (512 px,
seeds 0-4, labels withheld), of the object pixels within 3 m of an outline that are no
building, 16 % match better at the ground's disparity than at the object's (census,
7 x 7 window), and as many building pixels do. Their grey level can: 15 % of those
pixels are darker than half the object's median grey level, against 0.5 % of the
building pixels there.

So each object loses its pixels darker than ``ratio`` times its own median (the
reference smoothed over 0.5 m), and keeps the largest 4-connected part of the rest with
the holes that part encloses (dark roof furniture, a courtyard's shade inside the roof
stay). A roof whose dark part is half of it or more (one slope of a gable in the shade,
a dark roof with a bright wing) is left whole: the median would be the dark part's.

Measured on the demo pairs (``benchmarks/bench_objects.py --only demo``, labels
withheld): see :attr:`ObjectsParams.shadow_trim <radcons.stages.objects.ObjectsParams>`.
"""

from __future__ import annotations

import numpy as np
import scipy.ndimage

__all__ = ["trim_shadows", "MIN_KEPT"]

#: An object keeps at least this share of its pixels, or is left whole.
MIN_KEPT = 0.5


def trim_shadows(labels: np.ndarray, smooth: np.ndarray, ratio: float) -> np.ndarray:
    """Each object without its dark pixels: the largest part of the rest, holes filled.

    Parameters
    ----------
    labels : ndarray of int
        Objects 1..K of the reference (0 = background).
    smooth : ndarray
        The reference smoothed (NaN-free, e.g. :attr:`radcons.stages.objects_height.
        ImageScales.smooth`), same shape.
    ratio : float
        Pixels darker than ``ratio`` times the object's median grey level are cut
        (0: nothing is).

    Returns
    -------
    ndarray of int32
        The objects, ids unchanged; an object whose kept part would be less than
        :data:`MIN_KEPT` of it is left whole.
    """
    if labels.shape != smooth.shape:
        raise ValueError(f"labels {labels.shape} and image {smooth.shape} differ in shape")
    out = labels.astype(np.int32, copy=True)
    if ratio <= 0:
        return out
    for index, box in enumerate(scipy.ndimage.find_objects(out), start=1):
        if box is None:
            continue
        mask = labels[box] == index
        grey = smooth[box]
        dark = mask & (grey < ratio * float(np.median(grey[mask])))
        if not dark.any():
            continue
        parts, count = scipy.ndimage.label(mask & ~dark)
        if count == 0:
            continue
        sizes = np.bincount(parts.ravel())
        sizes[0] = 0
        kept = scipy.ndimage.binary_fill_holes(parts == sizes.argmax()) & mask
        if kept.sum() < MIN_KEPT * mask.sum():
            continue
        out[box][mask & ~kept] = 0
    return out
