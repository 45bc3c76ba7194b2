"""The association stage's step: object pairs, D̄m and invariant points from the SIFT matches."""

from __future__ import annotations

from radcons.results import Association, ObjectLabels
from radcons.stages import StageInputs

__all__ = ["compute"]


def compute(inputs: StageInputs) -> Association:
    """Associate the objects of both images through the pair's SIFT matches.

    Objects of the height method already carry their disparity and their target copy, so
    their association reads them (:func:`radcons.stages.association.height.associate_by_height`);
    other objects are paired by the matches that fall in them
    (:func:`radcons.stages.association.run.associate_objects`).
    """
    params = inputs.params.stage("association")
    objects: ObjectLabels = inputs.results["objects"]
    matches = inputs.matches()
    if getattr(objects, "method", "") == "height":
        from radcons.stages.association.height import associate_by_height

        return associate_by_height(
            objects.reference, objects.target, objects.modal_disparity, matches, params, objects.match_score
        )
    from radcons.stages.association.run import associate_objects

    reference, target = inputs.images("original")
    return associate_objects(reference, target, objects.reference, objects.target, matches, params)
