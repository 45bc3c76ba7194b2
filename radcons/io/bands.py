"""One grey band from a multiband image (RGB, RGBA, multispectral).

The stages work on one band. The rule, in order:

1. ``band`` given (1-based): that band, as it is.
2. An alpha band (PNG grey+alpha or RGBA, TIFF alpha extra sample) is left out, then:
   three bands: the luminance ``Y = 0.299 R + 0.587 G + 0.114 B`` (ITU-R BT.601, the weights
   of OpenCV's ``cvtColor``; pan-sharpened products are display RGB).
3. Any other count (2, 4 multispectral, ... 16): the mean of the bands.

Integer images are rounded back to their own dtype, so a uint8 RGB pair gives a uint8 grey
pair. More than :data:`MAX_BANDS` bands is refused (such a file is a cube, not an image).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from radcons.errors import InputError

__all__ = ["grey_band", "LUMINANCE_WEIGHTS", "MAX_BANDS"]

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
