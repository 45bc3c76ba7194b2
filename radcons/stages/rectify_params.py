"""Parameters of the epipolar rectification, and the thresholds its modules share.

:mod:`radcons.stages.rectify` runs the stage; :mod:`radcons.stages.rectify_epipolar`
(affine geometry), :mod:`radcons.stages.rectify_rpc` (RPC models) and
:mod:`radcons.stages.row_levelling` take these from here, below all of them.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2

from radcons.errors import ParamsError
from radcons.validate import check_fields, check_int_range

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
    """Parameters of the epipolar rectification of an unrectified pair.

    Attributes
    ----------
    ratio : float
        Lowe's ratio test: a match is kept when its nearest descriptor distance is below
        ``ratio`` times the second nearest (Lowe 2004 uses 0.8).
    max_features : int
        Most SIFT keypoints kept per image (the strongest); 0 keeps all.
    ransac_threshold : float
        Largest rectified vertical parallax, px, of an inlier match.
    ransac_trials : int
        Random 4-match samples drawn by RANSAC.
    min_matches : int
        Fewest ratio-test matches, and fewest RANSAC inliers, accepted; below it the images
        are taken not to overlap.
    min_relief : float
        Rectified disparity, px, beyond which an inlier match shows relief (the disparity
        is measured after the best disparity plane is removed). At least ``min_matches``
        inliers must show relief, or the epipolar direction is undetermined (flat scene).
    output_size : str
        Rectified frame: ``"reference"`` (bounding box of the rectified reference),
        ``"union"`` (of both images) or ``"intersection"`` (of their bounding boxes).
    interpolation : str
        ``"nearest"``, ``"linear"``, ``"cubic"`` or ``"lanczos"``.
    orient : str
        Which way up the affine route turns the pair (the RPC route orients it so that
        higher points have larger disparity). ``"relief"`` (default): the rotation rule,
        then turned by 180 deg when the pair's relief leans downward, its census disparity
        having a long lower tail around its local median
        (:mod:`radcons.stages.rectify_orientation`); ``"rotation"``: the rotation rule
        alone (the reference is turned by less than 90 deg).
    flip : bool
        Turn both rectified images by a further 180 deg, which negates every disparity:
        set it when elevated objects still come out with negative disparity. Affine
        method only.
    seed : int
        Seed of the RANSAC sampling (results are reproducible).
    method : str
        ``"auto"`` (RPC models when both images carry models that fit, else affine),
        ``"rpc"`` or ``"affine"``.
    rpc_grid_step : int
        Spacing, px, of the nodes of the RPC epipolar grids (positions are interpolated
        bilinearly between them).
    """

    ratio: float = 0.8
    max_features: int = 20000
    ransac_threshold: float = 1.0
    ransac_trials: int = 2000
    min_matches: int = 20
    min_relief: float = 2.0
    output_size: str = "reference"
    interpolation: str = "cubic"
    orient: str = "relief"
    flip: bool = False
    seed: int = 0
    method: str = "auto"
    rpc_grid_step: int = 30

    def __post_init__(self) -> None:
        check_fields(self, "rectify")
        check_int_range(self.ransac_trials, 1, 1_000_000, "rectify ransac_trials")
        check_int_range(self.max_features, 0, 1_000_000, "rectify max_features")
        if not 0.0 < self.ratio <= 1.0:
            raise ParamsError(f"rectify ratio must be in (0, 1], got {self.ratio}")
        if self.max_features < 0:
            raise ParamsError(f"rectify max_features must be >= 0, got {self.max_features}")
        if not self.ransac_threshold > 0:
            raise ParamsError(f"rectify ransac_threshold must be positive, got {self.ransac_threshold}")
        if self.ransac_trials < 1:
            raise ParamsError(f"rectify ransac_trials must be >= 1, got {self.ransac_trials}")
        if self.min_matches < 5:
            raise ParamsError(f"rectify min_matches must be >= 5 (4 fix the model), got {self.min_matches}")
        if not self.min_relief > 0:
            raise ParamsError(f"rectify min_relief must be positive, got {self.min_relief}")
        if self.output_size not in _OUTPUT_SIZES:
            raise ParamsError(f"rectify output_size must be one of {_OUTPUT_SIZES}, got {self.output_size!r}")
        if self.method not in _METHODS:
            raise ParamsError(f"rectify method must be one of {_METHODS}, got {self.method!r}")
        if self.orient not in _ORIENTS:
            raise ParamsError(f"rectify orient must be one of {_ORIENTS}, got {self.orient!r}")
        check_int_range(self.rpc_grid_step, 4, 1000, "rectify rpc_grid_step")
        if self.interpolation not in INTERPOLATIONS:
            raise ParamsError(
                f"rectify interpolation must be one of {tuple(INTERPOLATIONS)}, got {self.interpolation!r}"
            )
