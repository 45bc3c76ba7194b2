"""The refine stage: refined object-oriented normalisation of the target, object by object.

Su et al. (2018), section 4.2.2, eq 7-12: inside each object associated between the two
images, the invariant points (eq 12: matches whose disparity agrees with the object's
modal disparity D̄m) pair target and reference grey values assumed linearly related
(eq 7-8); the line is fitted by least squares (eq 9) weighted by the standardised
differences of the points (eq 10-11), and the target's object is mapped through it. Only
the target changes; the reference is the radiometric standard.

Modules:

- :mod:`~radcons.stages.refine.params`: :class:`RefineParams` (points, line, background
  and the safeguards of the fits);
- :mod:`~radcons.stages.refine.run`: the points of each object, the fits, the choice of
  one fit per target object, the feathered blend
  (:func:`~radcons.stages.refine.run.refine_target`);
- :mod:`~radcons.stages.refine.line_fits`: the weighted least squares of eq 9-11 and the
  moments line;
- :mod:`~radcons.stages.refine.background`: the grey-level mappings of the target outside
  the objects (whole-image, noise-aware and tile-wise histogram matching);
- :mod:`~radcons.stages.refine.step`: the pipeline's call.

Reference: Su, Yan, Zhao, Wang (2018), Remote Sensing 10(2):336, section 4.2.2.
"""

from radcons.stages.refine.params import RefineParams

__all__ = ["RefineParams"]
