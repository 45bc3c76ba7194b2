"""Sunlight on a height field: cast shadows and Lambertian shading.

Radiance of a surface element is ``albedo * (E * max(n . s, 0) * lit + ambient)`` with
``s`` the unit vector towards the sun, ``lit`` the un-shadowed fraction (cast shadows with
a one-pixel penumbra) and a uniform sky term ``ambient``. Radiance is in units where a
white horizontal surface under a zenith sun without sky light gives 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["Sun", "cast_shadows", "shade"]


@dataclass(frozen=True)
class Sun:
    """Sun position and sky light of one acquisition.

    Attributes
    ----------
    elevation : float
        Degrees above the horizon.
    azimuth : float
        Degrees clockwise from north (image up).
    ambient : float
        Sky irradiance relative to the direct beam at normal incidence.
    """

    elevation: float
    azimuth: float
    ambient: float = 0.3

    def vector(self) -> np.ndarray:
        """Unit vector towards the sun in image axes (east, south, up)."""
        e, a = np.radians(self.elevation), np.radians(self.azimuth)
        return np.array([np.cos(e) * np.sin(a), -np.cos(e) * np.cos(a), np.sin(e)])


def cast_shadows(height: np.ndarray, gsd: float, sun: Sun) -> np.ndarray:
    """Fraction of direct sunlight reaching each pixel of a height field.

    The height field is rotated so that rows run away from the sun; along a row a pixel
    at ``u`` is shadowed when some pixel nearer the sun rises above the ray to the sun,
    i.e. when ``max_{u' < u} w(u') > w(u)`` with ``w(u) = h(u) + u g tan(elevation)``
    (a running maximum). The excess height is turned into a soft shadow with a one-pixel
    penumbra and rotated back.

    Parameters
    ----------
    height : ndarray, float32
        Surface height (m).
    gsd : float
        Pixel size (m).
    sun : Sun

    Returns
    -------
    ndarray, float32
        1 in full sun, 0 in full shadow.
    """
    rows, cols = height.shape
    sx, sy, _ = sun.vector()
    horiz = np.hypot(sx, sy)
    dx, dy = -sx / horiz, -sy / horiz  # direction of the shadows
    width = int(np.ceil(abs(dx) * cols + abs(dy) * rows)) + 2
    depth = int(np.ceil(abs(dy) * cols + abs(dx) * rows)) + 2
    centre_in = np.array([(cols - 1) / 2.0, (rows - 1) / 2.0])
    centre_out = np.array([(width - 1) / 2.0, (depth - 1) / 2.0])
    # rotated (u, v) -> input (x, y): u runs along the shadows, v across them
    forward = np.array([[dx, -dy, 0.0], [dy, dx, 0.0]], np.float64)
    forward[:, 2] = centre_in - forward[:, :2] @ centre_out
    floor = float(height.min()) - 1000.0
    rotated = cv2.warpAffine(
        height.astype(np.float32), forward, (width, depth),
        flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
        borderMode=cv2.BORDER_CONSTANT, borderValue=floor,
    )
    step = np.float32(gsd * np.tan(np.radians(sun.elevation)))
    w = rotated + step * np.arange(width, dtype=np.float32)[None, :]
    behind = np.empty_like(w)
    behind[:, 0] = -np.inf
    np.maximum.accumulate(w[:, :-1], axis=1, out=behind[:, 1:])
    lit = np.clip(1.0 - (behind - w) / step, 0.0, 1.0)
    back = cv2.invertAffineTransform(forward)
    return cv2.warpAffine(
        lit, back, (cols, rows),
        flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
        borderMode=cv2.BORDER_CONSTANT, borderValue=1.0,
    )


def shade(albedo: np.ndarray, normal: np.ndarray, lit: np.ndarray, sun: Sun) -> np.ndarray:
    """Lambertian radiance ``albedo * (max(n . s, 0) * lit + ambient)``.

    Parameters
    ----------
    albedo : ndarray
    normal : ndarray, shape (3, rows, cols)
        Unit normals (east, south, up).
    lit : ndarray
        Output of :func:`cast_shadows`.
    sun : Sun

    Returns
    -------
    ndarray, float32
    """
    s = sun.vector().astype(np.float32)
    cosine = np.maximum(normal[0] * s[0] + normal[1] * s[1] + normal[2] * s[2], 0.0)
    return (albedo * (cosine * lit + sun.ambient)).astype(np.float32)
