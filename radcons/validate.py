"""Validation shared by the stages and the command line: images, parameters, sizes.

Each stage states its own smallest useful size; the image checks and their messages are
the same everywhere: a single-band 2-D array of real numbers, large enough, with at least
one valid (finite) pixel. Parameter dataclasses check their own ranges; the checks every
one of them needs (finite numbers, lists of the right length, bounds that depend on the
image) live here, so that a bad value is refused before any compute, whatever it is.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from typing import Any

import numpy as np

from radcons.errors import InputError, ParamsError

__all__ = ["single_band_image", "check_fields", "check_int_range", "check_params_for_shape", "MAX_ABS_VALUE"]

#: Largest magnitude of a pixel value radcons computes with. Sums of squares of larger
#: float32 values overflow (3e38 is float32's limit), which would turn into wrong answers
#: far from the cause; radiances, reflectances and digital numbers are far below it.
MAX_ABS_VALUE = 1e12


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


def check_fields(params: Any, stage: str) -> None:
    """Refuse non-finite numbers and lists of the wrong length in a params dataclass.

    Called first in every stage's ``__post_init__``: NaN compares false with everything,
    so without it a NaN would pass each range check after it.

    Parameters
    ----------
    params : dataclass instance
        A stage's frozen params.
    stage : str
        The stage's name, for the message (``[stage] name ...``).

    Raises
    ------
    ParamsError
        A float (or a number in a tuple) that is NaN or infinite, a bool or string where a
        number belongs, or a tuple whose length differs from its default's.
    """
    for spec in dataclasses.fields(params):
        value = getattr(params, spec.name)
        default = spec.default if spec.default is not dataclasses.MISSING else None
        where = f"[{stage}] {spec.name}"
        if isinstance(default, tuple):
            if not isinstance(value, tuple) or len(value) != len(default):
                raise ParamsError(f"{where} must be a list of {len(default)} numbers, got {value!r}")
            for item in value:
                _check_number(item, where)
        elif isinstance(default, (int, float)) and not isinstance(default, bool):
            _check_number(value, where)
            if isinstance(default, int) and not isinstance(value, numbers.Integral):
                raise ParamsError(f"{where} must be an integer, got {value!r}")
        elif isinstance(value, float):
            _check_number(value, where)


def _check_number(value: Any, where: str) -> None:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ParamsError(f"{where} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise ParamsError(f"{where} must be a finite number, got {value}")


def check_int_range(value: int, low: int, high: int, where: str) -> None:
    """Raise :class:`ParamsError` unless ``low <= value <= high``."""
    if not low <= value <= high:
        raise ParamsError(f"{where} must be in {low}..{high}, got {value}")


def _default(params: Any, name: str) -> Any:
    return next(f.default for f in dataclasses.fields(params) if f.name == name)


def check_params_for_shape(params: Any, shape: tuple[int, int]) -> None:
    """Refuse parameters that cannot apply to an image of ``shape`` (before any compute).

    Lengths in pixels (structuring elements, patches, search windows, tiles, Gaussian
    widths) longer than the image's smaller side (or than their default, on images smaller than it) would
    allocate more than the image itself or mean nothing.

    Parameters
    ----------
    params : radcons.params.Params
    shape : tuple of int
        ``(rows, columns)`` of the working pair.

    Raises
    ------
    ParamsError
        Naming the parameter, its value and the largest value the image allows.
    """
    side = int(min(shape))
    for stage, name in (
        ("objects", "max_size"),
        ("objects", "min_size"),
        ("smoothness", "patch_size"),
        ("smoothness", "search_window"),
        ("smoothness", "step"),
        ("sharpness", "tile"),
        ("uniformity", "sigma"),
        ("objects", "smooth_sigma"),
        ("refine", "blend_width"),
        ("sharpness", "max_sigma"),
        ("sharpness", "sigma"),
    ):
        stage_params = params.stage(stage)
        value = getattr(stage_params, name)
        if value is None:  # chosen from the image
            continue
        # A default longer than a small image is harmless (it stays small); the bound is
        # there for values that would allocate more than the image.
        default = _default(stage_params, name)
        limit = side if default is None else max(side, default)
        if value > limit:
            raise ParamsError(
                f"[{stage}] {name} = {value} px is longer than the image's smaller side ({side} px)"
            )
    background = params.smoothness.background_disparity
    if background is not None and abs(background) > shape[1]:
        raise ParamsError(
            f"[smoothness] background_disparity = {background:g} px is beyond the image's width ({shape[1]} px)"
        )
    area = int(shape[0]) * int(shape[1])
    if params.objects.min_area > area:
        raise ParamsError(f"[objects] min_area = {params.objects.min_area} px exceeds the image ({area} px)")
