"""One grey band from a multiband image (RGB, RGBA, multispectral).

The stages work on one band. The rule, in order:

1. ``band`` given (1-based): that band, as it is.
2. An alpha band (PNG grey+alpha or RGBA, TIFF alpha extra sample) is left out, then:
   three bands: the luminance ``Y = 0.299 R + 0.587 G + 0.114 B`` (ITU-R BT.601, the weights
   of OpenCV's ``cvtColor``; pan-sharpened products are display RGB).
3. Any other count (2, 4 multispectral, ... 16): the mean of the bands.

Integer images are rounded back to their own dtype, so a uint8 RGB pair gives a uint8 grey
pair. More than :data:`MAX_BANDS` bands is refused (such a file is a cube, not an image).

The colour an RGB image loses in its grey band still tells vegetation from roofs:
:func:`green_leaf_index` keeps it as one number a pixel, for the height method's tree rule.

References
----------
Louhaichi, M., Borman, M. M., Johnson, D. E. (2001). Spatially located platform and aerial
photography for documentation of grazing impacts on wheat. Geocarto International 16(1),
65-70 (the green leaf index).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from radcons.errors import InputError

__all__ = ["grey_band", "green_leaf_index", "LUMINANCE_WEIGHTS", "MAX_BANDS"]

#: ITU-R BT.601 luma weights of R, G, B.
LUMINANCE_WEIGHTS: tuple[float, float, float] = (0.299, 0.587, 0.114)
#: Most bands an image may have.
MAX_BANDS = 16


def grey_band(data: np.ndarray, band: int | None, path: str | Path | None, *, alpha: bool = False) -> tuple[np.ndarray, str]:
    """Return one grey band of a band-last image and a sentence saying how it was made.

    Parameters
    ----------
    data : ndarray, shape (rows, columns, bands)
        Bands last, in the file's order (R, G, B for colour images).
    band : int, optional
        1-based band to take instead of the rule above.
    path : str or Path, optional
        The file, for messages.
    alpha : bool
        The last band is an alpha (opacity) channel, not data.

    Returns
    -------
    grey : ndarray, shape (rows, columns)
        In ``data``'s dtype.
    how : str
        E.g. ``"luminance (ITU-R BT.601) of 3 bands (RGB)"``.

    Raises
    ------
    InputError
        No band, more than :data:`MAX_BANDS`, or ``band`` out of range.
    """
    count = data.shape[-1]
    if not 1 <= count <= MAX_BANDS:
        raise InputError(f"the image has {count} bands; radcons reads 1 to {MAX_BANDS}", path)
    if band is not None:
        if not 1 <= band <= count:
            raise InputError(f"--band {band} is out of range: the image has {count} band(s) (1..{count})", path)
        return data[..., band - 1], f"band {band} of {count}"
    note = ""
    if alpha and count > 1:
        data, count, note = data[..., :-1], count - 1, " (alpha band left out)"
    if count == 1:
        return data[..., 0], "single band" + note
    values = data.astype(np.float32)
    if count == 3:
        grey = values @ np.asarray(LUMINANCE_WEIGHTS, np.float32)
        how = "luminance (ITU-R BT.601) of 3 bands (RGB)" + note
    else:
        grey = values.mean(axis=-1)
        how = f"mean of {count} bands" + note
    if data.dtype.kind in "iu":
        info = np.iinfo(data.dtype)
        grey = np.clip(np.rint(grey), info.min, info.max)
    return grey.astype(data.dtype), how


def green_leaf_index(data: np.ndarray, band: int | None = None, *, alpha: bool = False) -> np.ndarray | None:
    """Green leaf index ``(2 G - R - B) / (2 G + R + B)`` of an RGB image, None for any other.

    Vegetation reflects more green than red and blue (leaves about 0.1 to 0.2 on the US3D
    WorldView-3 tiles); roofs, roads and bare soil are grey or reddish (about 0 or below).

    Parameters
    ----------
    data : ndarray, shape (rows, columns, bands)
        Band-last image.
    band : int, optional
        A band chosen by the user: the image is then read as that band, and None is returned.
    alpha : bool
        The last band is an alpha (opacity) channel, not data.

    Returns
    -------
    ndarray of float32 or None
        In [-1, 1], NaN where ``2 G + R + B`` is not positive; None unless the image has
        three colour bands (after an alpha band is left out) and no band was chosen.
    """
    count = data.shape[-1] - int(alpha and data.shape[-1] > 1)
    if band is not None or data.ndim != 3 or count != 3:
        return None
    red, green, blue = (data[..., i].astype(np.float32) for i in range(3))
    total = 2.0 * green + red + blue
    index = np.full(total.shape, np.nan, np.float32)
    np.divide(2.0 * green - red - blue, total, out=index, where=total > 0)
    return index
