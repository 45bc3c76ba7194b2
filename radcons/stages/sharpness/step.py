"""The sharpness stage's step: one point spread and noise level for both images (not the paper's)."""

from __future__ import annotations

from radcons.results import StageImages
from radcons.stages import StageInputs

__all__ = ["compute"]


def compute(inputs: StageInputs) -> StageImages:
    """The sharper image blurred to the other's point spread (:func:`radcons.stages.sharpness.run.sharpness_consistency`)."""
    from radcons.stages.sharpness.run import sharpness_consistency

    reference, target = inputs.previous_images("sharpness")
    return sharpness_consistency(reference, target, inputs.params.stage("sharpness"))
