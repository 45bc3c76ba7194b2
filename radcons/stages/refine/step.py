"""The refine stage's step: per-object weighted least squares on invariant points (eq 7-12)."""

from __future__ import annotations

from radcons.results import StageImages
from radcons.stages import StageInputs

__all__ = ["compute"]


def compute(inputs: StageInputs) -> StageImages:
    """The target mapped object by object onto the reference; the fits and what was done
    outside the objects (:func:`radcons.stages.refine.run.background_mapping`) go to the info.

    Pixels clipped in the original images are not taken as invariant points.
    """
    from radcons.numerics.valid_pixels import clipped_mask
    from radcons.stages.refine.run import background_mapping, refine_target

    params = inputs.params.stage("refine")
    reference, target = inputs.previous_images("refine")
    clipped = tuple(clipped_mask(image) for image in inputs.images("original"))
    objects = inputs.results["objects"]
    background, done = background_mapping(reference, target, params)
    association = inputs.results["association"]
    new_tgt, fits = refine_target(reference, target, objects.target, association, params, clipped, background)
    return StageImages(reference, new_tgt, {"fits": fits, **done})
