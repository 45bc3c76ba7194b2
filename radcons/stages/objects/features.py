"""What the height method measures of an object: texture, brightness, shape, edges, height.

:func:`object_features` gives each object of a label image the measures the rules of
:mod:`radcons.stages.objects.rules` judge (trees, shadows, mismatches, crowns) and the
searches of :mod:`radcons.stages.objects.searches.missed` and :mod:`radcons.stages.objects.searches.parts`
use to tell a roof: texture, brightness, rectangularity, hull rectangularity, the
alignment of its edges, the roughness and median of its height, and how strong an image
edge bounds it. :class:`ImageScales` holds what they are measured against, computed once
per image.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import scipy.ndimage

from radcons.stages.objects.ground import HeightMap

__all__ = ["ImageScales", "object_features", "smoothed", "OUTLINE_REACH"]


#: An object's outline may lie this many px off the image edge that bounds it (the
#: outline is snapped to the reference's edges to about a pixel).
OUTLINE_REACH = 2


@dataclass(frozen=True)
class ImageScales:
    """What :func:`object_features` measures objects against, computed once per image.

    Attributes
    ----------
    sigma : float
        Smoothing of the gradient, px.
    gradient : ndarray
        Gradient magnitude of the reference smoothed by ``sigma``.
    texture : float
        Median of ``gradient`` over the valid image.
    level : float
        Median grey level of the valid image.
    orientation : ndarray of complex64
        ``|g|^2 exp(4 i theta)`` of the same gradient ``g`` at angle ``theta``: edges along
        two perpendicular directions add up, edges in every direction cancel.
    smooth : ndarray of float32
        The reference smoothed by ``sigma``, invalid pixels as its mean.
    ridge : ndarray of float32
        The largest ``gradient`` within :data:`OUTLINE_REACH` px of each pixel.
    """

    sigma: float
    gradient: np.ndarray
    texture: float
    level: float
    orientation: np.ndarray
    smooth: np.ndarray
    ridge: np.ndarray

    @classmethod
    def of(cls, reference: np.ndarray, sigma: float = 1.0) -> "ImageScales":
        """The scales of ``reference`` (NaN where invalid) at smoothing ``sigma``."""
        valid = np.isfinite(reference)
        smooth = smoothed(reference, sigma)
        gx, gy = cv2.Sobel(smooth, cv2.CV_32F, 1, 0), cv2.Sobel(smooth, cv2.CV_32F, 0, 1)
        gradient = np.hypot(gx, gy)
        power = np.maximum(gradient * gradient, np.float32(1e-12))
        double_cos, double_sin = gx * gx - gy * gy, 2.0 * gx * gy  # |g|^2 exp(2 i theta)
        orientation = np.empty(reference.shape, np.complex64)  # (|g|^2 exp(2 i theta))^2 / |g|^2
        orientation.real = (double_cos * double_cos - double_sin * double_sin) / power
        orientation.imag = 2.0 * double_cos * double_sin / power
        ridge = cv2.dilate(gradient, np.ones((2 * OUTLINE_REACH + 1,) * 2, np.uint8))
        return cls(
            sigma, gradient, float(np.median(gradient[valid])) or 1.0, float(np.median(reference[valid])) or 1.0,
            orientation, smooth, ridge,
        )


def object_features(
    reference: np.ndarray, labels: np.ndarray, height: HeightMap, sigma: float = 1.0, scales: ImageScales | None = None
) -> dict[int, dict[str, float]]:
    """Texture, rectangularity, height roughness and median height of each object.

    ``texture``: median gradient magnitude (Sobel of the reference smoothed with
    ``sigma`` px; the caller makes it 0.5 m so that the measure does not depend on the
    resolution) inside the object eroded by ``2 + sigma`` px (the edge at its rim,
    spread by the smoothing, stays out: with a fixed 2 px, small roofs at fine resolution
    read as textured), over the median over the whole valid image;
    ``brightness``: the median of its pixels over the median of the valid image;
    ``rectangularity``: area over the area of the smallest rotated rectangle enclosing
    it; ``hull_rectangularity``: its convex hull's area over that rectangle's (pixel
    centres); ``roughness``: RMS residual of a least-squares plane through its census-grid
    heights, in the height map's unit; ``height``: the median of those heights;
    ``alignment``: how well the edges in and around it (the object grown by ``2 sigma``
    px, 1 m, so that its outline's edge counts) follow two perpendicular directions,
    ``|sum |g|^2 exp(4 i theta)| / sum |g|^2`` over the gradients ``g`` at angle
    ``theta`` (1: every edge along one of two perpendicular directions, about 0: edges
    in every direction; NaN without any gradient). Quadrupling the angle makes the
    two directions of an edge and the two perpendicular to it one; weighting by
    ``|g|^2`` lets the strong edges of an outline outweigh a roof's fine texture, whose
    area grows faster than its outline (weighted by ``|g|``, large textured roofs read as
    unaligned); ``outline``: how strong an image edge bounds it, the median over
    its outline pixels of the largest gradient within :data:`OUTLINE_REACH` px, over
    the image's median gradient
    (:func:`radcons.stages.objects.rules.is_edgeless`). ``scales``, when given (its
    ``sigma`` must be ``sigma``), saves computing the image's gradient and medians
    again for another set of objects.
    """
    if scales is None or scales.sigma != sigma:
        scales = ImageScales.of(reference, sigma)
    gradient, scale, level = scales.gradient, scales.texture, scales.level
    rim = 2 + int(round(sigma))
    outline = 2 * int(round(sigma))
    inner = cv2.erode((labels > 0).astype(np.uint8), np.ones((2 * rim + 1, 2 * rim + 1), np.uint8)) > 0
    coarse_labels = labels[:: height.factor, :: height.factor][: height.height.shape[0], : height.height.shape[1]]
    features: dict[int, dict[str, float]] = {}
    for index, box in enumerate(scipy.ndimage.find_objects(labels), start=1):
        if box is None:
            continue
        mask = labels[box] == index
        core = mask & inner[box]
        wide = tuple(slice(max(part.start - outline, 0), part.stop + outline) for part in box)
        band = cv2.dilate((labels[wide] == index).astype(np.uint8), np.ones((2 * outline + 1,) * 2, np.uint8)) > 0
        weight = float(np.square(gradient[wide][band], dtype=np.float64).sum())
        alignment = float(abs(scales.orientation[wide][band].sum())) / weight if weight > 0 else float("nan")
        values = gradient[box][core if core.sum() >= 10 else mask]
        rim_pixels = mask & ~(cv2.erode(np.pad(mask, 1).astype(np.uint8), np.ones((3, 3), np.uint8))[1:-1, 1:-1] > 0)
        grey = reference[box][mask]
        grey = grey[np.isfinite(grey)]
        hull = _hull(mask)
        (_, _), (w, h), _ = cv2.minAreaRect(hull)
        rows, cols = _coarse_pixels(coarse_labels, index, box, height.factor)
        heights = height.height[rows, cols]
        finite = np.isfinite(heights)
        roughness = float("nan")
        if finite.sum() >= 4:
            design = np.column_stack([rows[finite], cols[finite], np.ones(int(finite.sum()))]).astype(np.float64)
            coef, *_ = np.linalg.lstsq(design, heights[finite].astype(np.float64), rcond=None)
            roughness = float(np.sqrt(np.mean((design @ coef - heights[finite]) ** 2)))
        features[index] = {
            "texture": float(np.median(values)) / scale,
            "brightness": float(np.median(grey)) / level if grey.size else float("nan"),
            "rectangularity": float(mask.sum()) / max(float(w * h), 1.0),
            "hull_rectangularity": float(cv2.contourArea(hull)) / max(float(w * h), 1.0),
            "alignment": alignment,
            "roughness": roughness,
            "height": float(np.median(heights[finite])) if finite.any() else float("nan"),
            "outline": float(np.median(scales.ridge[box][rim_pixels])) / scale,
        }
    return features


def _hull(mask: np.ndarray) -> np.ndarray:
    """Convex hull of a mask's pixel centres, from its outer contours (the hull of all its pixels)."""
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    return cv2.convexHull(np.concatenate(contours))


def _coarse_pixels(
    coarse_labels: np.ndarray, index: int, box: tuple[slice, slice], factor: int
) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns of the census-grid cells of object ``index``, searched within its full-resolution ``box``.

    Cell ``(r, c)`` samples the full-resolution pixel ``(r * factor, c * factor)``.
    """
    first = [-(-part.start // factor) for part in box]
    last = [(part.stop - 1) // factor + 1 for part in box]
    rows, cols = np.nonzero(coarse_labels[first[0] : last[0], first[1] : last[1]] == index)
    return rows + first[0], cols + first[1]


def smoothed(image: np.ndarray, sigma: float) -> np.ndarray:
    """The image, invalid pixels as its mean, smoothed by a Gaussian of ``sigma`` px (float32)."""
    filled = np.where(np.isfinite(image), image, np.nanmean(image)).astype(np.float32)
    return cv2.GaussianBlur(filled, (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
