"""Parameters of feature matching and object association (Su et al. 2018, section 3 and eq 12).

:mod:`radcons.stages.association.run` (SIFT matching, association by matches or template)
and :mod:`radcons.stages.association.height` (objects of the height method) read them.
Each parameter is declared once (:func:`radcons.param_spec.param`): its default, range,
unit and help; the paper's values are the defaults where it gives one.
"""

from __future__ import annotations

from dataclasses import dataclass

from radcons.param_spec import check_declared, param

__all__ = ["AssociationParams"]


@dataclass(frozen=True)
class AssociationParams:
    """Parameters of feature matching and object association (one declaration each)."""

    min_matches: int = param(
        2,
        "Objects linked by more than this many SIFT matches, that many of them agreeing with D̄m "
        "(eq 12), are associated by their matches (paper: 2).",
        range=(0, None),
        basic=True,
    )
    ratio: float = param(
        0.8,
        "Lowe's ratio test: a match is kept when its descriptor distance is below this times that "
        "of the second-nearest candidate.",
        range=(0.01, 1.0),
        step=0.01,
        basic=True,
    )
    row_tolerance: float = param(
        1.5,
        "Largest vertical offset |y_ref - y_tgt| of a match in a rectified pair.",
        unit="px",
        range=(0.0, None),
    )
    ratio_rows: float = param(
        32.0,
        "Rectified pairs: the ratio test's second-nearest descriptor is sought among the target "
        "keypoints within this many rows.",
        unit="px",
        range=(0.0, None),
    )
    invariant_threshold: float = param(
        2.0,
        "Largest distance of a match's disparity from its object's D̄m for it to be an invariant "
        "point, l of eq 12 (paper: 2).",
        unit="px",
        range=(0.01, None),
        basic=True,
    )
    max_features: int = param(
        8000,
        "Most SIFT keypoints kept per image, the strongest first; 0 keeps all.",
        range=(0, 1_000_000),
        step=1000,
    )
    contrast_threshold: float = param(
        0.04,
        "SIFT contrast threshold (OpenCV's default 0.04); lower finds more keypoints in flat areas.",
        range=(0.001, None),
    )
    border: int = param(
        4,
        "Keypoints closer than this to an invalid pixel are not detected.",
        unit="px",
        range=(0, None),
    )
    max_disparity: float = param(
        128.0,
        "Half-width of the template search's disparity range when there are no matches.",
        unit="px",
        range=(0.0, None),
    )
    search_margin: float = param(
        8.0,
        "Widening of the matches' disparity range for the template search, and the widest gap "
        "between two disparities of that range.",
        unit="px",
        range=(0.0, None),
    )
    range_share: float = param(
        0.05,
        "A disparity counts in the template search's range when its 3 px bin holds at least this "
        "share of the fullest bin's matches (and more than min_matches).",
        range=(0.0, 1.0),
        step=0.01,
    )
    template_min_overlap: float = param(
        0.2,
        "Share of the shifted object that a target object must cover to be its template partner.",
        range=(0.0, 1.0),
        step=0.01,
    )
    template_min_score: float = param(
        0.2,
        "Lowest normalised cross-correlation of a template association; below it the object "
        "stays unassociated.",
        range=(-1.0, 1.0),
        step=0.01,
    )

    def __post_init__(self) -> None:
        check_declared(self, "association")
