"""Parameters of the epipolar rectification, and the thresholds its modules share.

:mod:`radcons.stages.rectify.run` runs the stage; :mod:`radcons.stages.rectify.epipolar`
(affine geometry), :mod:`radcons.stages.rectify.rpc` (RPC models) and
:mod:`radcons.stages.rectify.row_levelling` take these from here, below all of them.
Each parameter is declared once (:func:`radcons.param_spec.param`): its default, range or
choices, unit and help.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2

from radcons.param_spec import check_declared, param

__all__ = ["RectifyParams", "INTERPOLATIONS", "UNRECTIFIED_PARALLAX_PX", "DISPARITY_PERCENTILES"]

#: OpenCV interpolation of each ``interpolation`` name.
INTERPOLATIONS = {
    "nearest": cv2.INTER_NEAREST,
    "linear": cv2.INTER_LINEAR,
    "cubic": cv2.INTER_CUBIC,
    "lanczos": cv2.INTER_LANCZOS4,
}
#: Median vertical parallax of SIFT matches above which a pair is taken as unrectified.
UNRECTIFIED_PARALLAX_PX = 8.0
#: Percentiles of the rectified matches' disparities that give a pair's disparity range.
DISPARITY_PERCENTILES = (0.5, 99.5)
_OUTPUT_SIZES = ("reference", "union", "intersection")
_METHODS = ("auto", "rpc", "affine")
_ORIENTS = ("relief", "rotation")


@dataclass(frozen=True)
class RectifyParams:
    """Parameters of the epipolar rectification of an unrectified pair (one declaration each)."""

    ratio: float = param(
        0.8,
        "Lowe's ratio test: a match is kept when its nearest descriptor distance is below this "
        "times the second nearest (Lowe 2004 uses 0.8).",
        range=(0.01, 1.0),
        step=0.01,
    )
    max_features: int = param(
        20000,
        "Most SIFT keypoints kept per image, the strongest first; 0 keeps all.",
        range=(0, 1_000_000),
        step=1000,
    )
    ransac_threshold: float = param(
        1.0,
        "Largest rectified vertical parallax of a match that RANSAC counts as an inlier.",
        unit="px",
        range=(0.01, None),
    )
    ransac_trials: int = param(
        2000,
        "Most random 4-match samples drawn by RANSAC.",
        range=(1, 1_000_000),
    )
    min_matches: int = param(
        20,
        "Fewest matches each check accepts (ratio test, RANSAC inliers, inliers showing relief, "
        "matches sharing the RPC route's rows); 4 fix the affine model.",
        range=(5, None),
    )
    min_relief: float = param(
        2.0,
        "Disparity off the best disparity plane beyond which an inlier match shows relief; "
        "min_matches of them fix the epipolar direction.",
        unit="px",
        range=(0.01, None),
    )
    output_size: str = param(
        "reference",
        "Rectified frame: the bounding box of the rectified reference, the union of both images, "
        "or the intersection of their bounding boxes.",
        choices=_OUTPUT_SIZES,
        basic=True,
    )
    interpolation: str = param(
        "cubic",
        "Interpolation of the resampled images.",
        choices=tuple(INTERPOLATIONS),
    )
    orient: str = param(
        "relief",
        "Which way up the affine route turns the pair: by the rotation rule, then by 180 deg when "
        "its relief leans downward (relief), or by the rotation rule alone (rotation).",
        choices=_ORIENTS,
    )
    flip: bool = param(
        False,
        "Turn both rectified images by a further 180 deg, negating every disparity (affine route "
        "only): for elevated objects that still come out with negative disparity.",
        basic=True,
    )
    seed: int = param(
        0,
        "Seed of the RANSAC sampling, so that results are reproducible.",
        range=(0, None),
    )
    method: str = param(
        "auto",
        "Rectify from the RPC models (rpc), from the images (affine), or from the models when "
        "both images carry models that fit and from the images otherwise (auto).",
        choices=_METHODS,
        basic=True,
    )
    rpc_grid_step: int = param(
        30,
        "Spacing of the nodes of the RPC epipolar grids; positions are interpolated bilinearly "
        "between them.",
        unit="px",
        range=(4, 1000),
        step=1,
    )

    def __post_init__(self) -> None:
        check_declared(self, "rectify")
