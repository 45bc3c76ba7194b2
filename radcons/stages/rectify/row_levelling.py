"""Residual vertical parallax of a pair delivered as rectified, taken out of its target.

A pair delivered as epipolar-rectified may keep a vertical offset between its images: the
relative pointing error of the camera models it was rectified with (pairs published as
rectified, such as the US3D tiles, may keep a few pixels). Dense matchers search along
rows only, so an offset of a pixel or two costs many correct matches.

The correction is s2p's pointing correction (de Franchis et al. 2014, "Automatic sensor
orientation refinement of Pleiades stereo images", IGARSS), as the RPC route of
:mod:`radcons.stages.rectify.rpc` applies it: a plane of vertical offset
``dy = a x + b y + c`` (reference coordinates, ``dy = y_ref - y_tgt``) is fitted by least
squares to the SIFT matches within ``2 threshold`` px of their median offset, then again
to those within ``threshold`` px of the plane (:func:`vertical_offset_plane`); the target
is resampled so that ``target'(x, y) = target(x, y - dy(x, y))``
(:func:`level_target`). Columns, and so disparities and a reference-frame ground truth,
are untouched.

A plane whose median offset at the matches stays within :data:`ROW_TOLERANCE_PX` is not
applied: resampling blurs the target a little, and a pair whose rows already correspond to
a fraction of a pixel (the demo generator's) has nothing to gain. The median is taken
where the matches are, not at the image's corners, where a plane fitted on a few matches
extrapolates its slopes.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from radcons.results import Matches
from radcons.stages.rectify.params import UNRECTIFIED_PARALLAX_PX, RectifyParams

__all__ = [
    "ROW_TOLERANCE_PX", "RowOffset", "vertical_offset_plane", "measure_row_offset", "row_matches", "fit_row_offset",
    "level_target",
]

#: A fitted plane whose median offset at the matches is below this many px is left
#: unapplied.
ROW_TOLERANCE_PX = 0.5
#: Fewest matches that must agree on the plane for it to be applied.
MIN_INLIERS = 20
#: Matches within this many px of the plane are its inliers (twice that around the median
#: offset for the first fit).
INLIER_PX = 1.0
#: Images are matched at most this many px on a side (the step is undone on the matches).
MATCH_SIDE = 1024


@dataclass(frozen=True)
class RowOffset:
    """The vertical offset of a rectified pair's target, as fitted on SIFT matches.

    Attributes
    ----------
    plane : (float, float, float)
        ``(a, b, c)`` of ``dy = y_ref - y_tgt = a x + b y + c``, reference pixels.
    matches, inliers : int
        SIFT matches after the ratio test, and those within :data:`INLIER_PX` of the plane.
    typical, largest : float
        Median ``|dy|`` of the plane at the inliers, and its largest over the image (at one
        of its corners), px.
    before, after : float
        Median ``|dy|`` of the inliers before levelling and their median residual from the
        plane (what levelling leaves), px.
    applied : bool
        Whether the target should be levelled: ``typical`` above :data:`ROW_TOLERANCE_PX`,
        at least :data:`MIN_INLIERS` inliers, and ``largest`` within
        :data:`radcons.stages.rectify.params.UNRECTIFIED_PARALLAX_PX` (beyond, the rows do
        not correspond and levelling is not the cure).
    unrectified : bool
        Whether the rows do not correspond at all: at least :data:`MIN_INLIERS` inliers
        and ``largest`` beyond :data:`~radcons.stages.rectify.params.UNRECTIFIED_PARALLAX_PX`
        (:func:`radcons.geometry.settle_geometry` then takes a pair of equal sizes as
        unrectified, even when the median offset of its matches stays below that).
    """

    plane: tuple[float, float, float]
    matches: int
    inliers: int
    typical: float
    largest: float
    before: float
    after: float
    applied: bool

    @property
    def unrectified(self) -> bool:
        """Whether the plane shows rows that do not correspond (see the class notes)."""
        return self.inliers >= MIN_INLIERS and self.largest > UNRECTIFIED_PARALLAX_PX

    def describe(self) -> str:
        """One line for the pair's metadata and the summary."""
        if self.matches == 0:
            return "rows not levelled: no SIFT match between the images to measure their vertical offset"
        fit = (
            f"vertical offset of the target {self.typical:.2f} px (a plane fitted on {self.inliers} of "
            f"{self.matches} SIFT matches; at most {self.largest:.2f} px over the image)"
        )
        if self.applied:
            return f"target rows levelled: {fit}; {self.after:.2f} px left"
        if self.inliers < MIN_INLIERS:
            return f"rows not levelled: only {self.inliers} matches agree on an offset (at least {MIN_INLIERS} needed)"
        if self.typical > ROW_TOLERANCE_PX:
            return (
                f"rows not levelled: the target's vertical offset reaches {self.largest:.1f} px, beyond "
                f"{UNRECTIFIED_PARALLAX_PX:g} px (is the pair rectified?)"
            )
        return f"rows not levelled: {fit}, within {ROW_TOLERANCE_PX:g} px"


def vertical_offset_plane(
    ref_xy: np.ndarray, dy: np.ndarray, offset: float, threshold: float
) -> tuple[np.ndarray, np.ndarray]:
    """Plane ``dy = a x + b y + c`` of the matches' vertical offsets, and its inliers.

    Least squares on the matches within ``2 threshold`` px of ``offset``, then on those
    within ``threshold`` px of that plane (s2p's pointing correction, module notes).

    Parameters
    ----------
    ref_xy : ndarray, shape (N, 2)
        Matches' ``(x, y)`` in the reference.
    dy : ndarray, shape (N,)
        Their vertical offsets ``y_ref - y_tgt``, px.
    offset : float
        The offset most matches share (their median or mode), px.
    threshold : float
        Inlier distance to the plane, px.

    Returns
    -------
    plane : ndarray, shape (3,)
        ``(a, b, c)``; ``(0, 0, offset)`` when fewer than 3 matches are near ``offset``.
    inliers : ndarray of bool, shape (N,)
    """
    ref_xy = np.asarray(ref_xy, np.float64)
    dy = np.asarray(dy, np.float64)
    design = np.column_stack([ref_xy, np.ones(len(dy))])
    inliers = np.abs(dy - offset) <= 2 * threshold
    plane = np.array([0.0, 0.0, float(offset)])
    for _ in range(2):
        if inliers.sum() >= 3:
            plane = np.linalg.lstsq(design[inliers], dy[inliers], rcond=None)[0]
        inliers = np.abs(dy - design @ plane) <= threshold
    return plane, inliers


def measure_row_offset(reference: np.ndarray, target: np.ndarray) -> RowOffset:
    """Fit the vertical offset of a rectified pair's target (module notes).

    Parameters
    ----------
    reference, target : ndarray
        Single-band float32 images of one shape, NaN where invalid.

    Returns
    -------
    RowOffset
        ``applied`` says whether :func:`level_target` should be run with its ``plane``.
    """
    step = max(1, int(np.ceil(max(reference.shape) / MATCH_SIDE)))
    ref_xy, dy = row_matches(reference[::step, ::step], target[::step, ::step])
    return fit_row_offset(ref_xy * step, dy * step, reference.shape, INLIER_PX * step)


def row_matches(reference: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """SIFT matches' reference ``(x, y)`` and vertical offsets ``y_ref - y_tgt`` (float64; Lowe ratio 0.7)."""
    from radcons.stages.rectify.features import match_sift

    found: Matches = match_sift(reference, target, RectifyParams(max_features=4000, ratio=0.7))
    ref_xy = found.ref_xy.astype(np.float64).reshape(-1, 2)
    return ref_xy, ref_xy[:, 1] - found.tgt_xy.astype(np.float64).reshape(-1, 2)[:, 1]


def fit_row_offset(ref_xy: np.ndarray, dy: np.ndarray, shape: tuple[int, int], threshold: float = INLIER_PX) -> RowOffset:
    """The plane of :func:`vertical_offset_plane` on matches of an image of ``shape``, and whether to apply it.

    Parameters
    ----------
    ref_xy : ndarray, shape (N, 2)
        Matches' ``(x, y)`` in the reference, px of the whole image.
    dy : ndarray, shape (N,)
        Their vertical offsets ``y_ref - y_tgt``, px.
    shape : (int, int)
        The image's rows and columns (the plane's largest offset is at a corner).
    threshold : float
        Inlier distance to the plane, px.
    """
    if len(dy) == 0:
        return RowOffset((0.0, 0.0, 0.0), 0, 0, 0.0, 0.0, 0.0, 0.0, False)
    plane, inliers = vertical_offset_plane(ref_xy, dy, float(np.median(dy)), threshold)
    rows, cols = shape
    corners = np.array([[0, 0, 1], [cols - 1, 0, 1], [0, rows - 1, 1], [cols - 1, rows - 1, 1]], np.float64)
    largest = float(np.abs(corners @ plane).max())
    count = int(inliers.sum())
    if not count:
        return RowOffset(tuple(float(v) for v in plane), len(dy), 0, 0.0, largest, 0.0, 0.0, False)
    fitted = np.column_stack([ref_xy[inliers], np.ones(count)]) @ plane
    typical = float(np.median(np.abs(fitted)))
    before = float(np.median(np.abs(dy[inliers])))
    after = float(np.median(np.abs(dy[inliers] - fitted)))
    applied = count >= MIN_INLIERS and typical > ROW_TOLERANCE_PX and largest <= UNRECTIFIED_PARALLAX_PX
    return RowOffset(tuple(float(v) for v in plane), len(dy), count, typical, largest, before, after, applied)


def level_target(
    image: np.ndarray, plane: tuple[float, float, float], valid: np.ndarray | None = None, nearest: bool = False
) -> np.ndarray:
    """Resample the target so that ``target'(x, y) = target(x, y - dy(x, y))`` (bicubic).

    Parameters
    ----------
    image : ndarray
        The target, float32.
    plane : (float, float, float)
        ``(a, b, c)`` of :class:`RowOffset`.
    valid : ndarray of bool, optional
        The target's valid pixels. When all are valid (or None), rows beyond the image's
        edge repeat its first or last row; otherwise a pixel whose bicubic footprint
        touches an invalid pixel or leaves the image is NaN.
    nearest : bool
        Nearest-neighbour instead of bicubic (label rasters).

    Returns
    -------
    ndarray, float32, the image's shape.
    """
    from radcons.stages.rectify.epipolar import resample_nan

    a, b, c = plane
    inverse = np.array([[1.0, 0.0, 0.0], [-a, 1.0 - b, -c]], np.float64)
    size = (image.shape[1], image.shape[0])
    flags = cv2.WARP_INVERSE_MAP
    if valid is None or valid.all():
        method = cv2.INTER_NEAREST if nearest else cv2.INTER_CUBIC
        source = np.asarray(image, np.float32)
        return cv2.warpAffine(source, inverse, size, flags=flags | method, borderMode=cv2.BORDER_REPLICATE)
    image = np.where(valid, image, np.nan).astype(np.float32)
    return resample_nan(
        image, "nearest" if nearest else "cubic",
        lambda array, method: cv2.warpAffine(array, inverse, size, flags=flags | method, borderMode=cv2.BORDER_CONSTANT, borderValue=0),
    )
