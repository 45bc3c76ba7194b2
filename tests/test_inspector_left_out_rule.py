"""The View tab's left-out rule choice: one rule's regions drawn alone, on the real page's
server (the inspector on the demo pair, its own labels set aside so that objects are found
from height and some elevated regions are left out by the rules)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import wait_for_run, wait_until

from inspector.overlays import EVERY_RULE, LEFT_OUT
from inspector.render import LEFT_OUT_COLOURS


def _has_colour(layer: np.ndarray, rgb: tuple[int, int, int]) -> bool:
    return bool(((layer[..., :3] == rgb).all(axis=-1) & (layer[..., 3] > 0)).any())


def test_choosing_a_rule_draws_only_its_regions(tmp_path):
    from inspector.app import InspectorApp

    app = InspectorApp(port=0, demo_size=256, record_dir=tmp_path / "recordings").start()
    try:
        wait_for_run(app, 300)
        app.tuning.on_param_change("objects", {"use_supplied": False}, None)
        wait_until(lambda: getattr(app.session.run.objects, "left_out", None) is not None, 300,
                   what="objects found from height")
        view, viewport = app.view, app.context.viewport
        options = wait_until(lambda: len(view.left_out_rule.options) > 1 and tuple(view.left_out_rule.options), 120,
                             what="the left-out rules of the demo pair's objects")
        rules = {label: int(label.split(":")[0]) for label in options if label != EVERY_RULE}
        label, code = next(iter(rules.items()))
        assert not view.overlays[LEFT_OUT].value  # off by default
        view.left_out_rule.value = label
        layer = wait_until(
            lambda: view.overlays[LEFT_OUT].value and _has_colour(viewport.sent_layers["reference"], LEFT_OUT_COLOURS[code][0])
            and viewport.sent_layers["reference"],
            60, what=f"the regions of rule {label}",
        )
        others = [c for c in rules.values() if c != code]
        assert not any(_has_colour(layer, LEFT_OUT_COLOURS[c][0]) for c in others)
        if not others:
            pytest.skip("the demo pair's objects leave regions out by one rule only")
        view.left_out_rule.value = EVERY_RULE
        wait_until(
            lambda: all(_has_colour(viewport.sent_layers["reference"], LEFT_OUT_COLOURS[c][0]) for c in rules.values()),
            60, what="every rule's regions again",
        )
    finally:
        app.stop()
