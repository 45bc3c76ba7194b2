"""Parameters of the uniformity stage: relative-gradient attenuation of eq 1-3.

:class:`UniformityParams` declares each parameter once (:func:`radcons.param_spec.param`):
its default (the paper's ``mu`` 0.1 and ``zeta`` 0.8), range or choices, unit and help.
``mu`` and ``zeta`` are the paper's (eq 3); ``sigma`` and ``f`` make eq 2's Gaussian ``g``
and function ``f`` concrete, which the paper leaves open; ``epsilon`` and ``range_mapping``
belong to the reconstruction (:mod:`radcons.stages.uniformity.run`).
"""

from __future__ import annotations

from dataclasses import dataclass

from radcons.param_spec import check_declared, param


@dataclass(frozen=True)
class UniformityParams:
    """Parameters of the illumination uniformity stage (eq 1-3)."""

    mu: float = param(
        0.1,
        "Gradient threshold of eq 3 as a fraction of the mean relative gradient; it scales every factor alike, "
        "so the range mapping undoes it.",
        range=(0.01, 1.0), step=0.01, basic=True,
    )
    zeta: float = param(
        0.8,
        "Attenuation exponent of eq 3: lower compresses strong relative gradients more, 1 leaves the image "
        "unchanged.",
        range=(0.0, 1.0), step=0.01, basic=True,
    )
    sigma: float = param(
        3.0,
        "Standard deviation of the Gaussian g of eq 2 that gives each pixel its local brightness.",
        unit="px", range=(0.1, None), step=0.5, basic=True,
    )
    f: str = param(
        "local_mean",
        "The function f of eq 2: local_mean divides the gradient by the local brightness, one leaves it as it is.",
        choices=("local_mean", "one"),
    )
    epsilon: float = param(
        0.01,
        "Brightness added to f, as a fraction of the image's mean, so that the relative gradient stays finite "
        "in black areas.",
        range=(0.001, 0.2), step=0.001,
    )
    range_mapping: str = param(
        "mean_std",
        "How the rebuilt image returns to the input's grey levels: its mean and standard deviation, "
        "or its 1st and 99th percentiles.",
        choices=("mean_std", "percentile"),
    )

    def __post_init__(self) -> None:
        check_declared(self, "uniformity")
