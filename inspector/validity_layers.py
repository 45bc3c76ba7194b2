"""The matcher's invalid pixels by cause, drawn over the disparity picture as toggled layers.

The causes are those of :mod:`radcons.evaluate.validity`; each but ``matched`` has a
colour (:data:`LAYER_COLOURS`) chosen apart from the turbo colours of the disparity and
from its black (no disparity) and dim grey (no data): the Disparity tab has a checkbox
per cause, and the viewport paints the chosen ones (:func:`paint_causes`).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from radcons.evaluate.validity import CAUSES

__all__ = ["LAYER_COLOURS", "check_layers", "layers_legend", "paint_causes"]

#: Cause name -> RGB colour of its layer (every cause but ``matched``).
LAYER_COLOURS: dict[str, tuple[int, int, int]] = {
    "left-right rejected": (255, 0, 255),
    "at the range's edge": (255, 140, 0),
    "no match": (255, 255, 255),
    "nodata": (150, 150, 150),
}

#: Colour names used in the legend.
_COLOUR_NAMES = {"left-right rejected": "magenta", "at the range's edge": "orange", "no match": "white", "nodata": "light grey"}


def check_layers(layers: Iterable[str]) -> tuple[str, ...]:
    """The layer names, refused if one is not a key of :data:`LAYER_COLOURS`.

    Raises
    ------
    ValueError
        An unknown layer.
    """
    chosen = tuple(layers)
    unknown = [name for name in chosen if name not in LAYER_COLOURS]
    if unknown:
        raise ValueError(f"no layer for {unknown}: choose among {list(LAYER_COLOURS)}")
    return chosen


def paint_causes(picture: np.ndarray, codes: np.ndarray | None, layers: Iterable[str]) -> np.ndarray:
    """The RGB disparity ``picture`` with the pixels of each cause in ``layers`` in its colour.

    Parameters
    ----------
    picture : ndarray of uint8, shape (h, w, 3)
        The disparity picture as drawn.
    codes : ndarray of int, shape (h, w), or None
        The cause code (index into :data:`radcons.evaluate.validity.CAUSES`) of each
        picture pixel, in the picture's frame; None leaves the picture as it is.
    layers : iterable of str
        Names of the causes to paint (keys of :data:`LAYER_COLOURS`).

    Returns
    -------
    ndarray of uint8
        A painted copy (``picture`` itself when nothing is painted).

    Raises
    ------
    ValueError
        ``codes`` of another size than the picture, or an unknown layer.
    """
    chosen = check_layers(layers)
    if codes is None or not chosen:
        return picture
    if codes.shape != picture.shape[:2]:
        raise ValueError(f"cause codes of shape {codes.shape} for a picture of shape {picture.shape[:2]}")
    out = picture.copy()
    for name in chosen:
        out[codes == CAUSES.index(name)] = LAYER_COLOURS[name]
    return out


def layers_legend() -> str:
    """One line naming the colour of each layer (markdown)."""
    parts = [f"{_COLOUR_NAMES[name]} = {name}" for name in LAYER_COLOURS]
    return "Invalid pixels on the disparity picture: " + ", ".join(parts) + "."
