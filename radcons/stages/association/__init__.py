"""The association stage: SIFT matches, object pairs, D̄m and invariant points (Su et al. 2018, eq 12).

Its modules, in the order they run:

- :mod:`~radcons.stages.association.params`: :class:`AssociationParams`.
- :mod:`~radcons.stages.association.step`: what the pipeline calls; it picks the
  association by the objects' method.
- :mod:`~radcons.stages.association.run`: SIFT matching of the pair
  (:func:`~radcons.stages.association.run.match_features`, which the pipeline runs beside
  the objects stage), then each reference object paired by its matches or, failing them,
  by template matching (:func:`~radcons.stages.association.run.associate_objects`).
- :mod:`~radcons.stages.association.height`: objects of the height method, paired by
  construction, with the SIFT matches as evidence
  (:func:`~radcons.stages.association.height.associate_by_height`).
"""

from radcons.stages.association.params import AssociationParams

__all__ = ["AssociationParams"]
