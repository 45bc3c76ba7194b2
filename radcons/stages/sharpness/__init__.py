"""The sharpness stage: one point spread, and optionally one noise level, for both images.

Not in the paper. Its section 5 brings the pair to one smoothness level by denoising
(eq 13-19, the smoothness stage), which leaves the point spreads (MTF) of two sensors as
they are: a blurrier target stays blurrier, and the matching cost compares a sharp edge
with a soft one. This stage estimates the pair's relative Gaussian blur from the ratio of
the images' noise-free power spectra and blurs the sharper image by it. With
``noise = "cleaner"`` it also smooths the noisier image to the cleaner one's noise level
where the gap between them is large and reliable.

Modules:

- :mod:`~radcons.stages.sharpness.params`: :class:`SharpnessParams`;
- :mod:`~radcons.stages.sharpness.run`: Welch power spectra, the relative blur and
  :func:`~radcons.stages.sharpness.run.sharpness_consistency`;
- :mod:`~radcons.stages.sharpness.noise_match`: the noise gap (Donoho's estimator, its
  per-block median, flat blocks and JPEG grids) and the smoothing that closes it;
- :mod:`~radcons.stages.sharpness.step`: the pipeline's call.

References: Su, Yan, Zhao, Wang (2018), Remote Sensing 10(2):336, section 5; Donoho and
Johnstone (1994), "Ideal spatial adaptation by wavelet shrinkage", Biometrika 81(3), for
the noise estimator.
"""

from radcons.stages.sharpness.params import SharpnessParams

__all__ = ["SharpnessParams"]
