"""Results kept while a rule's threshold is tuned (:mod:`radcons.stages.objects.memo`)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pytest

from radcons.stages.objects import run as objects_run
from radcons.stages.objects.memo import content_digest, remember_last
from radcons.stages.objects.params import ObjectsParams
from radcons.stages.objects.run import height_objects
from test_objects_height import _stereo_scene


@dataclass(frozen=True)
class Box:
    values: np.ndarray
    scale: float


def test_the_digest_reads_content_not_identity():
    values = np.arange(12, dtype=np.float32).reshape(3, 4)
    assert content_digest(values, 1.0) == content_digest(values.copy(), 1.0)
    changed = values.copy()
    changed[2, 3] += 1e-3
    assert content_digest(values) != content_digest(changed)
    assert content_digest(values) != content_digest(values.astype(np.float64))
    assert content_digest(values) != content_digest(values.reshape(4, 3))
    assert content_digest(Box(values, 1.0)) == content_digest(Box(values.copy(), 1.0))
    assert content_digest(Box(values, 1.0)) != content_digest(Box(values, 2.0))
    assert content_digest((1, 2)) != content_digest([1, 2]) != content_digest((2, 1))
    with pytest.raises(TypeError, match="cannot digest a object"):
        content_digest(object())


def test_a_remembered_function_computes_once_per_content_and_hands_out_copies():
    calls = []

    def doubled(values: np.ndarray, factor: int) -> np.ndarray:
        calls.append(factor)
        return values * factor

    remembered = remember_last(doubled)
    values = np.ones((4, 4))
    first = remembered(values, 2)
    first[0, 0] = 99.0  # the caller changes its result: the kept one is not
    again = remembered(values.copy(), 2)
    assert calls == [2] and again[0, 0] == 2.0
    assert remembered(values, 3)[0, 0] == 3.0 and calls == [2, 3]
    assert remembered(values, 2)[0, 0] == 2.0 and calls == [2, 3, 2]  # only the last is kept
    remembered.cache_clear()
    remembered(values, 2)
    assert calls == [2, 3, 2, 2]


def test_a_retuned_rule_gives_the_objects_computed_from_scratch():
    reference, target, _, _ = _stereo_scene()
    params = ObjectsParams(method="height", census_side=256)
    tuned = replace(params, tree_texture=params.tree_texture * 1.5, min_match_score=params.min_match_score * 1.2)
    height_objects(reference, target, params)  # keeps its regions and disparities
    kept = height_objects(reference, target, tuned)
    objects_run._SEGMENTED.cache_clear()
    objects_run._DISPARITIES.cache_clear()
    fresh = height_objects(reference, target, tuned)
    assert kept.reference.max() > 0
    assert np.array_equal(kept.reference, fresh.reference) and np.array_equal(kept.target, fresh.target)
    assert kept.modal_disparity == fresh.modal_disparity and kept.match_score == fresh.match_score
    assert np.array_equal(kept.left_out, fresh.left_out)
