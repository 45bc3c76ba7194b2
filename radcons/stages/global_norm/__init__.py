"""The global stage: initial illumination normalisation by singular value equalisation.

Su et al. (2018), section 4.2.1, eq 4-6: each image's singular values (eq 4) are scaled
by the ratio of the largest singular value of the constant image of the pair's mean grey
level to the image's own (eq 5), and the image is rebuilt from them (eq 6). Scaling every
singular value by one scalar scales the image by it, so the stage needs only each image's
largest singular value, and tiles of a scene can be normalised with the scene's values.

Modules:

- :mod:`~radcons.stages.global_norm.params`: :class:`GlobalParams` (the power iteration
  that finds the largest singular value);
- :mod:`~radcons.stages.global_norm.run`: the pair mean ``A``,
  :func:`~radcons.stages.global_norm.run.largest_singular_value` and
  :func:`~radcons.stages.global_norm.run.global_normalisation`;
- :mod:`~radcons.stages.global_norm.step`: the pipeline's call on both images.

References: Su, Yan, Zhao, Wang (2018), Remote Sensing 10(2):336, section 4.2.1; Demirel,
Anbarjafari, Jahromi (2008), "Image equalization based on singular value decomposition",
ISCIS.
"""

from radcons.stages.global_norm.params import GlobalParams

__all__ = ["GlobalParams"]
