"""Parameters of the sharpness stage: one point spread and one noise level for the pair.

The stage is not in the paper (its section 5 evens out noise only). :class:`SharpnessParams`
declares each parameter once (:func:`radcons.param_spec.param`): the relative-blur
estimate (``tile``, ``f_low``, ``f_high``, ``snr``), the blur applied (``min_sigma``,
``max_sigma``, ``strength``, ``sigma``) and, with ``noise = "cleaner"``, the noise
matching of :mod:`radcons.stages.sharpness.noise_match` (the ``noise_*`` parameters and
``denoise``). ``sigma`` and ``denoise`` carry a scene's pair-wide values to its tiles.
"""

from __future__ import annotations

from dataclasses import dataclass

from radcons.errors import ParamsError
from radcons.param_spec import check_declared, param


@dataclass(frozen=True)
class SharpnessParams:
    """Parameters of the sharpness consistency stage."""

    tile: int = param(
        128,
        "Side of the Welch tiles of the power spectra (even); an image smaller than a tile uses its largest "
        "even square.",
        unit="px", range=(16, None), step=2,
    )
    f_low: float = param(
        0.03,
        "Lowest frequency of the band the relative blur is fitted on.",
        unit="cycles/px", range=(0.0, 0.5), step=0.01,
    )
    f_high: float = param(
        0.4,
        "Highest frequency of the band the relative blur is fitted on.",
        unit="cycles/px", range=(0.0, 0.5), step=0.01,
    )
    snr: float = param(
        5.0,
        "A frequency ring counts when both images' noise-free power exceeds this many times their noise power.",
        range=(0.01, None), step=0.5,
    )
    min_sigma: float = param(
        0.5,
        "Relative blurs below this count as equal point spreads: no blur.",
        unit="px", range=(0.0, None), step=0.05, basic=True,
    )
    max_sigma: float = param(
        3.0,
        "Largest Gaussian ever applied to either image.",
        unit="px", range=(0.0, None), step=0.1, basic=True,
    )
    strength: float = param(
        1.0,
        "Fraction of the estimated relative blur applied; 1 equalises the point spreads.",
        range=(0.01, 1.0), step=0.01, basic=True,
    )
    sigma: float | None = param(
        None,
        "Signed relative blur to apply instead of estimating it (positive: the target is blurrier, the "
        "reference gets blurred); empty estimates it from the pair.",
        unit="px",
    )
    noise: str = param(
        "keep",
        "What happens to the noise levels: keep leaves them as they are, cleaner smooths the noisier image to "
        "the cleaner one's level where the gap is large and reliable.",
        choices=("keep", "cleaner"), basic=True,
    )
    noise_tolerance: float = param(
        1.15,
        "With noise = cleaner, noise ratios up to this are left as they are, and the smoothing stops once "
        "the ratio is within it.",
        range=(1.0, None), step=0.05,
    )
    noise_gate: float = param(
        2.0,
        "With noise = cleaner, smallest noise ratio, of both estimates, taken as a real gap rather than a "
        "difference of texture or contrast.",
        range=(1.0, None), step=0.1,
    )
    noise_coded_gate: float = param(
        1.3,
        "With noise = cleaner, the gate where the cleaner image carries a JPEG code grid, whose finest detail was "
        "coded away.",
        range=(1.0, None), step=0.1,
    )
    noise_flat_margin: float = param(
        0.05,
        "With noise = cleaner, a gap is refused when the cleaner image's share of flat blocks exceeds the noisier "
        "one's by this, unless it carries a JPEG grid (above 1: never refused).",
        range=(0.0, None), step=0.01,
    )
    noise_blockiness_margin: float = param(
        0.1,
        "With noise = cleaner, the cleaner image carries a JPEG code grid when its blockiness exceeds the noisier "
        "one's by this.",
        range=(0.0, None), step=0.05,
    )
    noise_max_sigma: float = param(
        0.6,
        "With noise = cleaner, largest Gaussian the noisier image is smoothed by (at most max_sigma); a wider one "
        "blurs edges more than it helps the matching.",
        unit="px", range=(0.05, None), step=0.05,
    )
    denoise: float | None = param(
        None,
        "With noise = cleaner, signed Gaussian to smooth by instead of measuring the gap (positive: the target, "
        "negative: the reference, 0: neither); empty measures it from the pair.",
        unit="px",
    )

    def __post_init__(self) -> None:
        check_declared(self, "sharpness")
        if self.tile % 2:
            raise ParamsError(f"[sharpness] tile must be even, got {self.tile}")
        if not self.f_low < self.f_high:
            raise ParamsError(f"[sharpness] needs f_low < f_high, got {self.f_low}, {self.f_high}")
        if not self.min_sigma <= self.max_sigma:
            raise ParamsError(f"[sharpness] needs min_sigma <= max_sigma, got {self.min_sigma}, {self.max_sigma}")
        if not self.noise_max_sigma <= self.max_sigma:
            raise ParamsError(
                f"[sharpness] needs 0 < noise_max_sigma <= max_sigma, got {self.noise_max_sigma}, {self.max_sigma}"
            )
        if self.denoise is not None and not abs(self.denoise) <= self.max_sigma:
            raise ParamsError(f"[sharpness] needs |denoise| <= max_sigma, got {self.denoise}, {self.max_sigma}")
