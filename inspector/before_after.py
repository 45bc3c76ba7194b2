"""Before/after pictures of the View tab: anaglyphs and absolute differences of two pairs.

An anaglyph puts the reference in the red channel and the target in green and blue
(cyan), both mapped to 8 bits with one grey-value range (:func:`render.display_range`):
where the two images agree in brightness the picture is grey, where the reference is
brighter it is red, where the target is, cyan. The pair as read (the original stage) is
shown next to the stage on screen, so a normalisation that works turns a tinted anaglyph
grey. The absolute difference ``|reference - target|`` of both pairs is drawn on one
colour scale, that of the original pair, so that what the stage removed shows as a darker
picture. All pictures are shrunk to at most :data:`SIDE` pixels first; nothing here
computes a result of the method.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from inspector import render
from inspector.objects import fixed_text, grey_decimals

__all__ = ["SIDE", "DIFFERENCE_PERCENTILE", "BeforeAfter", "anaglyph", "difference_picture", "before_after"]

#: Longest side of the before/after pictures.
SIDE = 512

#: Percentile of the original pair's absolute difference that the colour scale ends at.
DIFFERENCE_PERCENTILE = 99.0

#: Gap, px, between the two differences drawn side by side.
_GAP = 6


@dataclass(frozen=True)
class BeforeAfter:
    """The View tab's before/after pictures and their caption.

    Attributes
    ----------
    original, shown : ndarray of uint8, (H, W, 3)
        Anaglyphs of the original pair and of the shown stage.
    difference : ndarray of uint8, (H, 2 W + gap, 3)
        ``|reference - target|`` of the original pair (left) and of the shown stage
        (right), on one colour scale.
    caption : str
        Markdown: the colour scale and the mean absolute difference of both pairs.
    """

    original: np.ndarray
    shown: np.ndarray
    difference: np.ndarray
    caption: str


def anaglyph(reference: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Red = reference, cyan = target, both mapped with their common display range.

    Parameters
    ----------
    reference, target : ndarray
        Float images of one shape, NaN where invalid (drawn black).

    Returns
    -------
    ndarray of uint8, (H, W, 3)
        RGB.

    Raises
    ------
    ValueError
        Images of different shapes.
    """
    if reference.shape != target.shape:
        raise ValueError(f"an anaglyph needs two images of one shape, got {reference.shape} and {target.shape}")
    value_range = render.display_range(reference, target)
    red, cyan = render.to_display(reference, value_range), render.to_display(target, value_range)
    return np.dstack([red, cyan, cyan])


def difference_picture(reference: np.ndarray, target: np.ndarray, scale: float) -> np.ndarray:
    """``|reference - target|`` coloured (inferno) from 0 to ``scale``; black where either is invalid."""
    return render.colourise(np.abs(reference - target), (0.0, scale), cv2.COLORMAP_INFERNO)


def before_after(original: tuple[np.ndarray, np.ndarray], shown: tuple[np.ndarray, np.ndarray], stage: str) -> BeforeAfter:
    """Anaglyphs and differences of the original pair and of the shown stage's pair.

    Parameters
    ----------
    original, shown : (ndarray, ndarray)
        ``(reference, target)`` float images of the original stage and of the shown view,
        all of one shape.
    stage : str
        The shown view's name, for the caption.

    Returns
    -------
    BeforeAfter

    Raises
    ------
    ValueError
        Images of different shapes.
    """
    if not original[0].shape == original[1].shape == shown[0].shape == shown[1].shape:
        raise ValueError("the original and shown pairs must have images of one shape")
    factor = render.downsample_factor(original[0].shape, SIDE)
    small_original = [render.resize_for_display(np.asarray(image, np.float32), factor) for image in original]
    small_shown = [render.resize_for_display(np.asarray(image, np.float32), factor) for image in shown]
    before = np.abs(small_original[0] - small_original[1])
    after = np.abs(small_shown[0] - small_shown[1])
    finite = before[np.isfinite(before)]
    scale = float(np.percentile(finite, DIFFERENCE_PERCENTILE)) if finite.size else 1.0
    scale = scale if scale > 0 else 1.0
    gap = np.full((before.shape[0], _GAP, 3), 255, np.uint8)
    difference = np.concatenate(
        [difference_picture(*small_original, scale), gap, difference_picture(*small_shown, scale)], axis=1
    )
    decimals = grey_decimals(small_original[0])
    means = [fixed_text(float(np.nanmean(d)) if np.isfinite(d).any() else None, decimals) for d in (before, after)]
    caption = (
        f"Anaglyphs: red = reference, cyan = target (grey where they agree). |reference − target|: "
        f"original (left) | **{stage}** (right), black 0 to yellow {fixed_text(scale, decimals)} grey levels; "
        f"mean {means[0]} → {means[1]}."
    )
    return BeforeAfter(anaglyph(*small_original), anaglyph(*small_shown), difference, caption)
