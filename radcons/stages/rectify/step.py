"""The rectify stage's step: the epipolar resampling of a pair that is not rectified."""

from __future__ import annotations

from typing import Any

from radcons.errors import StageError
from radcons.stages import StageInputs

__all__ = ["compute"]


def compute(inputs: StageInputs) -> Any:
    """Epipolar resampling of an unrectified pair; None when there is nothing to do.

    From the images' RPC models when both carry models that fit, else from the images
    (:func:`radcons.stages.rectify.run.rectify_pair`). Switched off, a pair whose images
    differ in size is refused: nothing downstream can pair its pixels.
    """
    pair, params = inputs.pair, inputs.params
    if pair.rectified:
        return None
    if not params.enabled("rectify"):
        if pair.reference.data.shape != pair.target.data.shape:
            raise StageError(
                f"the pair is not rectified and its images differ in size ({pair.reference.data.shape} vs "
                f"{pair.target.data.shape}); switch the rectify stage on"
            )
        return None
    from radcons.rpc import pair_rpcs
    from radcons.stages.rectify.run import rectify_pair

    reference, target = pair.reference.as_float32(), pair.target.as_float32()
    rpcs, no_rpcs = pair_rpcs(pair.reference, pair.target)
    return rectify_pair(reference, target, params.rectify, rpcs, no_rpcs)
