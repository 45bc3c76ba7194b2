"""Parameters of the global stage: the largest singular value behind eq 5.

Eq 4-6 have no parameter of their own: ``lambda = A sqrt(m n) / sigma_max`` follows from
the pair. :class:`GlobalParams` declares (:func:`radcons.param_spec.param`) how
``sigma_max`` is computed: the power iteration's stopping rule and its iteration budget
before ARPACK takes over (:func:`radcons.stages.global_norm.run.largest_singular_value`).
"""

from __future__ import annotations

from dataclasses import dataclass

from radcons.param_spec import check_declared, param


@dataclass(frozen=True)
class GlobalParams:
    """Parameters of the largest-singular-value computation (eq 5)."""

    tolerance: float = param(
        1e-7,
        "The power iteration stops when the singular value changes by less than this relative amount "
        "between two iterations.",
        range=(1e-12, 0.5), basic=True,
    )
    max_iterations: int = param(
        100,
        "Power iterations before ARPACK's Lanczos method takes over.",
        range=(1, 100_000), step=1,
    )

    def __post_init__(self) -> None:
        check_declared(self, "global")
