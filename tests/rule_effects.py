"""What a height-method rule removes from a demo pair's objects, judged against the generator's buildings."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from radcons.stages.objects.run import ObjectsParams, height_objects
from radcons.stages.objects.regions import HeightObjects


@dataclass(frozen=True)
class RuleEffect:
    """The objects without and with a rule, and the best IoU with a true building of each object it removed."""

    without: HeightObjects
    with_rule: HeightObjects
    removed: dict[int, float]  # object id in ``without`` -> IoU with the building under most of it (0: none)


def rule_effect(pair, without: ObjectsParams, with_rule: ObjectsParams) -> RuleEffect:
    """Height objects of ``pair`` under both parameter sets; an object is removed when less than 20 % of it stays."""
    reference, target = pair.reference.as_float32(), pair.target.as_float32()
    geometry = {"gsd_m": pair.metadata["gsd_m"], "base_to_height": pair.metadata["base_to_height"]}
    before = height_objects(reference, target, without, **geometry)
    after = height_objects(reference, target, with_rule, **geometry)
    truth = pair.reference_objects
    removed = {}
    for ident in range(1, int(before.reference.max()) + 1):
        mask = before.reference == ident
        if np.mean(after.reference[mask] > 0) >= 0.2:
            continue
        building = np.bincount(truth[mask]).argmax()
        removed[ident] = float((mask & (truth == building)).sum() / (mask | (truth == building)).sum()) if building else 0.0
    return RuleEffect(before, after, removed)
