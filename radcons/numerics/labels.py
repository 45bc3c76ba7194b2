"""Renumbering of label rasters: the kept objects numbered 1..K in order, the others 0."""

from __future__ import annotations

import numpy as np

__all__ = ["new_ids", "relabel"]


def new_ids(keep: np.ndarray) -> np.ndarray:
    """Old id -> new id: the ids with ``keep[id]`` true numbered 1..K in their order, the others (and 0) 0."""
    keep = keep.copy()
    keep[0] = False
    return (np.cumsum(keep) * keep).astype(np.int32)


def relabel(labels: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """Map the kept ids of ``labels`` to 1..K in increasing order, the rest to 0."""
    return new_ids(keep)[labels]
