"""The uniformity stage: illumination uniformity of each image by relative-gradient attenuation.

Su et al. (2018), section 4.1, eq 1-3: every gradient of an image is multiplied by a factor
Theta (eq 1) that falls with its relative gradient, the gradient over the local brightness
(eq 2), so that strong brightness steps are compressed and faint ones stretched (eq 3);
the image is rebuilt from the modified gradient field by a Poisson solve. Each image of the
pair is processed on its own; the stage runs on the rectified pair, before the global
normalisation.

Modules:

- :mod:`~radcons.stages.uniformity.params`: :class:`UniformityParams` (``mu``, ``zeta``
  of eq 3; ``sigma``, ``f`` of eq 2; the reconstruction's ``epsilon`` and
  ``range_mapping``);
- :mod:`~radcons.stages.uniformity.run`: the relative gradient, the factor Theta and
  :func:`~radcons.stages.uniformity.run.illumination_uniformity`;
- :mod:`~radcons.stages.uniformity.step`: the pipeline's call, both images in turn.

Reference: Su, Yan, Zhao, Wang (2018), "Object-Oriented Hierarchy Radiation Consistency
for Different Temporal and Different Sensor Images", Remote Sensing 10(2):336; Fattal,
Lischinski, Werman (2002), "Gradient domain high dynamic range compression".
"""

from radcons.stages.uniformity.params import UniformityParams

__all__ = ["UniformityParams"]
