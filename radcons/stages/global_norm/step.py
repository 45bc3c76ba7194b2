"""The global stage's step: singular value equalisation of the pair towards its mean (eq 4-6)."""

from __future__ import annotations

from radcons.results import StageImages
from radcons.stages import StageInputs

__all__ = ["compute"]


def compute(inputs: StageInputs) -> StageImages:
    """Both images scaled to the pair mean A by their largest singular values.

    The info holds A, each image's sigma_max and its lambda.
    """
    from radcons.stages.global_norm.run import (
        global_normalisation,
        largest_singular_value,
        pair_mean,
    )

    params = inputs.params.stage("global")
    reference, target = inputs.previous_images("global")
    mean = pair_mean(reference, target)
    sigma_ref, sigma_tgt = largest_singular_value(reference, params), largest_singular_value(target, params)
    new_ref, lambda_ref = global_normalisation(reference, mean, sigma_ref)
    new_tgt, lambda_tgt = global_normalisation(target, mean, sigma_tgt)
    info = {
        "A": mean,
        "sigma_max_reference": sigma_ref,
        "sigma_max_target": sigma_tgt,
        "lambda_reference": lambda_ref,
        "lambda_target": lambda_tgt,
    }
    return StageImages(new_ref, new_tgt, info)
