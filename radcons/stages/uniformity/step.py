"""The uniformity stage's step: relative-gradient attenuation of each image (eq 1-3)."""

from __future__ import annotations

from radcons.results import StageImages
from radcons.stages import StageInputs

__all__ = ["compute"]


def compute(inputs: StageInputs) -> StageImages:
    """Each image made uniform in illumination on its own (:func:`radcons.stages.uniformity.run.illumination_uniformity`)."""
    from radcons.stages.uniformity.run import illumination_uniformity

    params = inputs.params.stage("uniformity")
    reference, target = inputs.previous_images("uniformity")
    return StageImages(illumination_uniformity(reference, params), illumination_uniformity(target, params), {})
