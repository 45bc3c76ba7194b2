"""The smoothness stage's step: union group sparse denoising of both images at once (eq 13-19)."""

from __future__ import annotations

from radcons.results import StageImages
from radcons.stages import StageInputs

__all__ = ["compute"]


def compute(inputs: StageInputs) -> StageImages:
    """Both images denoised together (:func:`radcons.stages.smoothness.run.smoothness_consistency`)."""
    from radcons.stages.smoothness.run import smoothness_consistency

    reference, target = inputs.previous_images("smoothness")
    objects = inputs.results["objects"]
    return smoothness_consistency(
        reference, target, objects.reference, objects.target, inputs.results["association"],
        inputs.params.stage("smoothness"),
    )
