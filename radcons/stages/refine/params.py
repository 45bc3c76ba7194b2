"""Parameters of the refine stage: per-object lines of eq 7-12 and what lies between them.

:class:`RefineParams` declares each parameter once (:func:`radcons.param_spec.param`). The
paper's method is the default: invariant points of eq 12 (``points = "matches"``), the
weighted least squares of eq 9-11 (``fit = "wls"``) and the global stage's result outside
the objects (``background = "global"``). The other choices (dense points, the moments
line, histogram backgrounds, the agreement gate, clipping) are described in
:mod:`radcons.stages.refine.run` and :mod:`radcons.stages.refine.background`.
"""

from __future__ import annotations

from dataclasses import dataclass

from radcons.errors import ParamsError
from radcons.param_spec import check_declared, param


@dataclass(frozen=True)
class RefineParams:
    """Parameters of the refined object-oriented normalisation (eq 7-12)."""

    min_points: int = param(
        3,
        "Fewest points for an object's line to be applied: a line needs 2, and a third lets eq 11 down-weight "
        "one bad point.",
        range=(2, None), step=1,
    )
    blend_width: float = param(
        4.0,
        "Width of the band inside each object's border over which its line is blended into the background "
        "(0: applied hard).",
        unit="px", range=(0.0, None), step=0.5, basic=True,
    )
    gain_range: tuple[float, float] = param(
        (0.25, 4.0),
        "Lines whose gain falls outside these bounds are not applied, a safeguard against fits on a few points "
        "of nearly equal grey value.",
        range=(0.0, None),
    )
    points: str = param(
        "matches",
        "Where an object's points come from: matches takes the invariant points of eq 12, dense its target "
        "pixels paired with the reference pixels D̄m to their right.",
        choices=("matches", "dense"), basic=True,
    )
    dense_max_points: int = param(
        2000,
        "With dense points, at most this many pixels of an object (a regular subsample).",
        range=(2, 10_000_000), step=100,
    )
    fit: str = param(
        "wls",
        "The line of each object: wls is the weighted least squares of eq 9-11, moments the line matching the "
        "points' means and standard deviations.",
        choices=("wls", "moments"), basic=True,
    )
    background: str = param(
        "global",
        "What the target takes outside the applied objects: global keeps the global stage's result, histogram "
        "its whole-image histogram matching onto the reference, local that matching then a gain and offset per "
        "tile for light that varies across the scene.",
        choices=("global", "histogram", "local"), basic=True,
    )
    local_tiles: int = param(
        6,
        "With the local background, tiles per side of the grid of gains and offsets.",
        range=(1, 64), step=1,
    )
    local_min_light: float = param(
        0.04,
        "With the local background, the tile correction is applied only when it moves the target this much "
        "(standard deviation, as a share of the reference's 1..99 percentile range): smaller, the tiles differ "
        "by content, not light.",
        range=(0.0, 1.0), step=0.005,
    )
    background_smoothing: float = param(
        0.0,
        "With the histogram background, the mapping is fitted on both images smoothed by a Gaussian of this "
        "width (0: as they are).",
        unit="px", range=(0.0, 10.0), step=0.1,
    )
    background_noise: bool = param(
        False,
        "With the histogram background, fit the mapping as if the target carried the noise that brings it to "
        "the reference's level.",
    )
    agreement_gate: bool = param(
        False,
        "Apply an object's line only where it lowers the object's mean difference to the reference pixels D̄m "
        "to its right.",
    )
    clip_to_reference: bool = param(
        False,
        "Clip the refined target to the smallest and largest valid grey value of the reference.",
    )
    max_clipped: float = param(
        0.3,
        "Largest share of an object's points on clipped pixels for which its line is fitted on the others; "
        "above it the object gets an offset only.",
        range=(0.0, 1.0), step=0.05,
    )

    def __post_init__(self) -> None:
        check_declared(self, "refine")
        low, high = self.gain_range
        if not 0 < low <= 1 <= high:
            raise ParamsError(f"[refine] gain_range must satisfy 0 < low <= 1 <= high, got {self.gain_range}")
        if self.background_noise and (self.background not in ("histogram", "local") or self.background_smoothing > 0):
            raise ParamsError(
                "[refine] background_noise needs background = \"histogram\" or \"local\" and "
                "background_smoothing = 0, got "
                f"background = {self.background!r}, background_smoothing = {self.background_smoothing:g}"
            )
