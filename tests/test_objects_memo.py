"""Results kept while a rule's threshold is tuned (:mod:`radcons.stages.objects.memo`)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pytest

from radcons.stages.objects import run as objects_run
from radcons.stages.objects.matching import match_pair
from radcons.stages.objects.memo import LastResults, content_digest
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


def test_last_results_compute_once_per_content_and_hand_out_copies():
    calls = []

    def doubled(values: np.ndarray, factor: int) -> np.ndarray:
        calls.append(factor)
        return values * factor

    def negated(values: np.ndarray) -> np.ndarray:
        calls.append("negated")
        return -values

    kept = LastResults()
    values = np.ones((4, 4))
    first = kept(doubled, values, 2)
    first[0, 0] = 99.0  # the caller changes its result: the kept one is not
    assert kept(doubled, values.copy(), 2)[0, 0] == 2.0 and calls == [2]
    assert kept(negated, values)[0, 0] == -1.0 and kept(doubled, values, 2)[0, 0] == 2.0  # one per function
    assert calls == [2, "negated"]
    assert kept(doubled, values, 3)[0, 0] == 3.0 and kept(doubled, values, 2)[0, 0] == 2.0  # only the last
    assert calls == [2, "negated", 3, 2]
    assert LastResults()(doubled, values, 2)[0, 0] == 2.0 and calls[-1] == 2  # another keeper starts empty


def test_a_retuned_rule_on_a_kept_matching_gives_the_objects_computed_anew(monkeypatch):
    segmented = []
    original = objects_run.segment_elevated

    def counted(*args, **kwargs):
        segmented.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(objects_run, "segment_elevated", counted)
    reference, target, _, _ = _stereo_scene()
    params = ObjectsParams(method="height", census_side=256)
    tuned = replace(params, tree_texture=params.tree_texture * 1.5, min_match_score=params.min_match_score * 1.2)
    matching = match_pair(reference, target, params)
    height_objects(reference, target, params, matching=matching)
    kept = height_objects(reference, target, tuned, matching=matching)
    assert len(segmented) == 1  # the tuned run took the regions kept with the matching
    fresh = height_objects(reference, target, tuned)  # a matching of its own: nothing kept
    assert len(segmented) == 2
    assert kept.reference.max() > 0
    assert np.array_equal(kept.reference, fresh.reference) and np.array_equal(kept.target, fresh.target)
    assert kept.modal_disparity == fresh.modal_disparity and kept.match_score == fresh.match_score
    assert np.array_equal(kept.left_out, fresh.left_out)
