"""Validation of the images a stage receives, shared by the stages.

Each stage states its own smallest useful size; the checks and their messages are the same
everywhere: a single-band 2-D array of real numbers, large enough, with at least one valid
(finite) pixel.
"""

from __future__ import annotations

import numpy as np

from radcons.errors import InputError

__all__ = ["single_band_image"]


def single_band_image(image: np.ndarray, name: str, min_side: int, too_small: str) -> np.ndarray:
    """Return ``image`` as float32 (no copy when it already is), after checking it.

    Parameters
    ----------
    image : array_like
        The image, NaN where invalid.
    name : str
        What the image is, for the messages (e.g. ``"reference"``).
    min_side : int
        Fewest pixels along each side.
    too_small : str
        The end of the message for a smaller image, after ``"{name} of shape {shape} "``
        (e.g. ``"is too small for a power spectrum (16 px)"``).

    Returns
    -------
    ndarray, float32

    Raises
    ------
    InputError
        Not 2-D, smaller than ``min_side`` px along a side, not real numbers, or without a
        single finite pixel.
    """
    image = np.asarray(image)
    if image.ndim != 2:
        raise InputError(f"{name} must be a single-band 2-D image, got shape {image.shape}")
    if min(image.shape) < min_side:
        raise InputError(f"{name} of shape {image.shape} {too_small}")
    if image.dtype.kind not in "uif":
        raise InputError(f"{name} must hold real numbers, got dtype {image.dtype}")
    image = image.astype(np.float32, copy=False)
    if not np.isfinite(image).any():
        raise InputError(f"every pixel of the {name} is NaN (no valid pixel)")
    return image
