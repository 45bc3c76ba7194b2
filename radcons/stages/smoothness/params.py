"""Parameters of the smoothness stage: union group sparse denoising of eq 13-19.

:class:`SmoothnessParams` declares each parameter once (:func:`radcons.param_spec.param`).
The paper gives the patch size (8 x 8 px), the number of similar patches (30) and ``c``
(``2 sqrt(2)``, after SAIST); ``delta`` and ``gamma`` of eq 18-19 are SAIST's and the
rest make the model concrete where the paper is silent (see
:mod:`radcons.stages.smoothness.run`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from radcons.errors import ParamsError
from radcons.param_spec import check_declared, param


@dataclass(frozen=True)
class SmoothnessParams:
    """Parameters of the smoothness consistency stage (eq 13-19)."""

    patch_size: int = param(
        8,
        "Side of the square patches of a group (the paper's 8, i.e. 64 pixels).",
        unit="px", range=(2, 64), step=1, basic=True,
    )
    n_similar: int = param(
        30,
        "Similar patches found for each centre patch, per image (the paper's 30); a group holds the centre "
        "and its matches.",
        range=(1, 1024), step=1, basic=True,
    )
    search_window: int = param(
        21,
        "Side of the square window the similar patches are searched in (odd).",
        unit="px", range=(1, 255), step=2,
    )
    step: int = param(
        8,
        "Stride between the centre patches of the reference grid.",
        unit="px", range=(1, None), step=1,
    )
    c: float = param(
        2.0 * math.sqrt(2.0),
        "Constant of the thresholds tau_i = c sigma_w^2 / sigma_i of eq 17 (the paper's 2 sqrt 2, after SAIST).",
        range=(0.0, None), step=0.1, basic=True,
    )
    delta: float = param(
        0.23,
        "Weight of the iterative regularisation of eq 19: the share of the removed noise fed back at each "
        "iteration (SAIST's 0.23).",
        range=(0.0, 1.0), step=0.01,
    )
    gamma: float = param(
        1.0,
        "Scale of the noise level update of eq 18.",
        range=(0.01, None), step=0.05, basic=True,
    )
    iterations: int = param(
        5,
        "Shrinkage passes, the iterations of eq 17-19.",
        range=(1, 100), step=1,
    )
    rematch_every: int = param(
        0,
        "Redo the block matching on the current estimate every this many iterations (0: keep the groups "
        "found on the input).",
        range=(0, None), step=1,
    )
    union_sigma: str = param(
        "max",
        "The union's noise level sigma_0: max takes the noisier image's, rms the root mean square of the two.",
        choices=("max", "rms"),
    )
    feedback: str = param(
        "equal",
        "Weight of eq 19 for the noisier image: equal scales delta so that both images get the same noise "
        "level back, same uses delta itself.",
        choices=("equal", "same"),
    )
    background_disparity: float | None = param(
        None,
        "Disparity that pairs the background patches of the two images; empty takes the median D̄m of the "
        "objects.",
        unit="px",
    )

    def __post_init__(self) -> None:
        check_declared(self, "smoothness")
        if self.search_window % 2 == 0:
            raise ParamsError(f"[smoothness] search_window must be odd, got {self.search_window}")
        if self.n_similar >= self.search_window**2:
            # The window holds search_window**2 patch positions, the centre's among them.
            raise ParamsError(
                f"[smoothness] n_similar ({self.n_similar}) must be below the {self.search_window**2} patch "
                f"positions of the {self.search_window} px search_window"
            )
