"""The inspector with objects found from height: the height view, the 3D colours, the method's
controls, the status line and the evidence columns of the object table.

The units check the drawing against maps and associations built by hand; the browser test
drives the real page (headless Chromium) on a demo pair with its labels withheld and the
height method chosen in the Tune tab, and checks what the server sent against the height
stage called on the same pair.
"""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from inspector import objects as object_table
from inspector.overlays import (
    EVERY_RULE,
    HEIGHT,
    LEFT_OUT,
    OVERLAYS,
    draw_layers,
    height_legend,
    left_out_choices,
    left_out_legend,
)
from inspector.render import LEFT_OUT_COLOURS
from radcons.io import Pair, Raster
from radcons.results import Association, Matches, ObjectLabels
from radcons.stages.association.height import HeightAssociation
from radcons.stages.objects.ground import HeightMap
from radcons.stages.objects.rules import LEFT_OUT_RULES
from radcons.stages.objects.regions import HeightObjects

ROWS, COLS = 48, 64


def turbo_lut() -> np.ndarray:
    """The 256 RGB colours of OpenCV's turbo map, index 0 (low) first."""
    ramp = np.arange(256, dtype=np.uint8).reshape(-1, 1)
    return cv2.cvtColor(cv2.applyColorMap(ramp, cv2.COLORMAP_TURBO), cv2.COLOR_BGR2RGB).reshape(256, 3).astype(np.int32)


def decode_heights(layer: np.ndarray, value_range: tuple[float, float]) -> np.ndarray:
    """Heights read back from an RGBA layer by the nearest turbo colour (NaN where transparent)."""
    lut = turbo_lut()
    rgb = layer[..., :3].reshape(-1, 1, 3).astype(np.int32)
    index = np.argmin(((rgb - lut[None]) ** 2).sum(-1), axis=1).reshape(layer.shape[:2])
    low, high = value_range
    values = low + index / 255.0 * (high - low)
    return np.where(layer[..., 3] > 0, values, np.nan)


def ramp_objects(unit: str = "m") -> HeightObjects:
    """Objects from height over a height map rising from -2 to 30 left to right, NaN in one corner."""
    height = np.tile(np.linspace(-2.0, 30.0, COLS, dtype=np.float32), (ROWS, 1))
    height[:8, :8] = np.nan
    heights = HeightMap(height + 10, np.full_like(height, 10), height, unit, 1.0, 1, (0.0, 40.0), 0.9)
    labels = np.zeros((ROWS, COLS), np.int32)
    labels[10:20, 10:20], labels[25:40, 30:50] = 1, 2
    return HeightObjects(labels, labels, "segmented", heights, "height", "", {1: 3.0, 2: 12.0}, {}, 2, 1)


def bare_pair() -> Pair:
    image = np.zeros((ROWS, COLS), np.float32)
    return Pair(Raster(image), Raster(image), name="ramp")


# ----------------------------------------------------------------------------- units


def test_height_layer_shows_the_height_map_in_turbo_colours():
    objects = ramp_objects()
    on = {label: False for label in OVERLAYS} | {HEIGHT: True}
    reference, target = draw_layers(on, bare_pair(), objects, None, 1, (ROWS, COLS), None)
    height = objects.height.height
    assert np.array_equal(reference[..., 3] > 0, np.isfinite(height))
    assert not target.any()  # the height is the reference's
    top = float(np.nanpercentile(height, 99.5))
    decoded = decode_heights(reference, (0.0, top))
    expected = np.clip(height, 0.0, top)
    known = np.isfinite(height)
    assert np.abs(decoded[known] - expected[known]).max() <= top / 255 + 1e-6
    assert f"0.0 – {top:.1f} m" in height_legend(objects, (ROWS, COLS))


def test_height_layer_is_off_by_default_and_absent_without_a_height_map():
    assert OVERLAYS[HEIGHT] is False
    labels = ramp_objects().reference
    on = {label: False for label in OVERLAYS} | {HEIGHT: True}
    supplied = ObjectLabels(labels, labels, "user")
    reference, _ = draw_layers(on, bare_pair(), supplied, None, 1, (ROWS, COLS), None)
    assert not reference.any()
    assert "the pair's own labels" in height_legend(supplied, (ROWS, COLS))
    fallback = HeightObjects(labels, labels, "segmented", None, "mbi", "census matching failed: image-only objects (mbi) instead")
    assert "census matching failed" in height_legend(fallback, (ROWS, COLS))


def test_left_out_layer_shows_each_region_in_its_rules_colour():
    objects = ramp_objects()
    codes = np.zeros((ROWS, COLS), np.uint8)
    codes[2:8, 40:60] = 1  # a grove left out as a tree
    codes[30:44, 2:12] = 5  # a patch without an edge along its outline
    codes[42:46, 20:24] = 5  # ... and a second one
    objects = replace(objects, left_out=codes)
    assert OVERLAYS[LEFT_OUT] is False
    on = {label: False for label in OVERLAYS} | {LEFT_OUT: True}
    reference, target = draw_layers(on, bare_pair(), objects, None, 1, (ROWS, COLS), None)
    assert np.array_equal(reference[..., 3] > 0, codes > 0) and not target.any()
    for code in (1, 5):
        inside = codes == code
        assert (reference[inside][:, :3] == LEFT_OUT_COLOURS[code][0]).all()
        assert (reference[inside][:, 3] == 255).any() and (reference[inside][:, 3] < 255).any()  # outline and fill
    legend = left_out_legend(objects)
    assert f"{LEFT_OUT_COLOURS[1][1]} 1 × {LEFT_OUT_RULES[1]}" in legend
    assert f"{LEFT_OUT_COLOURS[5][1]} 2 × {LEFT_OUT_RULES[5]}" in legend
    assert LEFT_OUT_RULES[2] not in legend  # no region left out as too low
    both = on | {HEIGHT: True}  # over the height map, which shows where no region was left out
    reference, _ = draw_layers(both, bare_pair(), objects, None, 1, (ROWS, COLS), None)
    assert (reference[codes == 5][:, :3] == LEFT_OUT_COLOURS[5][0]).all()
    assert np.array_equal(reference[..., 3] > 0, np.isfinite(objects.height.height) | (codes > 0))
    assert left_out_legend(ObjectLabels(codes, codes, "user")) == ""  # image objects have none
    from radcons.stages.objects.run import ObjectsParams

    valued = left_out_legend(objects, ObjectsParams(method="height", outline_edge=2.25))
    assert (
        "(tree_texture = 1.3, tree_rectangularity = 0.6, tree_alignment = 0.15, spilled_roof_texture = 0.5, "
        "tall_roof_height_m = 20)" in valued
    )
    assert "(outline_edge = 2.25)" in valued


def height_run() -> SimpleNamespace:
    """A run whose three objects were found from height: one agreeing, one contradicted, one without matches (a clipped roof)."""
    objects = ramp_objects()
    objects = HeightObjects(
        objects.reference.copy(), objects.target, "segmented", objects.height, "height", "", {}, {}, 2, 1, (4,), None, (3,)
    )
    objects.reference[42:46, 2:8] = 3
    objects.reference[42:46, 52:60] = 4  # not associated: its copy did not match back
    matches = Matches.empty()
    empty = np.zeros(0, np.int64)
    association = Association(
        matches,
        (
            HeightAssociation(1, 1, "height", 3.0, empty, empty, 0.9, "agrees"),
            HeightAssociation(2, 2, "height", 12.0, empty, empty, 0.8, "contradicts"),
            HeightAssociation(3, 3, "height", 5.0, empty, empty, 0.7, "few matches"),
        ),
    )
    return SimpleNamespace(objects=objects, association=association, fits=())


def test_object_table_shows_evidence_and_flags_the_contradicted_object():
    rows = object_table.object_rows(height_run())
    table = object_table.table_markdown(rows, None, False, False)
    header = table.splitlines()[0]
    assert "evidence" in header and "flag" in header
    lines = {line.split("|")[1].strip(): line for line in table.splitlines()[2:5]}
    assert "agrees" in lines["1"] and "⚑" not in lines["1"]
    assert "contradicts" in lines["2"] and "⚑" in lines["2"]
    assert "few matches" in lines["3"] and "⚑" not in lines["3"]
    assert "D̄m from its outline" in lines["3"] and "outline" not in lines["1"] + lines["2"]  # a clipped roof
    row = next(line for line in table.splitlines() if line.split("|")[1].strip() == "4")
    assert "not matched back" in row and "⚑" not in row


def test_object_table_of_image_objects_has_no_evidence_column():
    run = height_run()
    labels = run.objects.reference
    plain = SimpleNamespace(objects=ObjectLabels(labels, labels, "user"), association=None, fits=())
    assert "evidence" not in object_table.table_markdown(object_table.object_rows(plain), None, False, False).splitlines()[0]


def test_status_names_the_method_trees_mismatched_and_the_note():
    line = object_table.objects_status(height_run())
    assert "**height**" in line and "4 objects" in line and "heights in m" in line
    assert "2 tree-like, 1 mismatched or shadows" in line and "1 flagged" in line
    assert "1 not associated (their copy in the target does not match back)" in line
    assert "1 clipped in one image, placed by their outline" in line
    from radcons.params import Params

    run = height_run()
    run.params = Params.from_preset("radcons").with_stage("objects", method="height", min_height_m=3.5)
    assert "elevated above 3.5 m" in object_table.objects_status(run)
    heights = run.objects.height  # one census step: factor full-image px of disparity, in metres
    assert f"a census step {heights.factor / heights.px_per_unit:.2g} m" in object_table.objects_status(run)
    labels = np.zeros((ROWS, COLS), np.int32)
    note = "no pixel stands 2.5 m above the ground: a flat scene, no objects"
    flat = SimpleNamespace(objects=HeightObjects(labels, labels, "segmented", ramp_objects().height, "height", note), association=None)
    assert note in object_table.objects_status(flat) and "0 objects" in object_table.objects_status(flat)
    user = SimpleNamespace(objects=ObjectLabels(height_run().objects.reference, labels, "user"), association=None)
    assert "own labels" in object_table.objects_status(user)
    assert object_table.objects_status(None) == ""


# ----------------------------------------------------------------------------- browser


@pytest.mark.browser
def test_height_view_status_and_table_in_the_page(browser, tmp_path):
    from test_inspector_browser import open_page, open_stage, wait_until

    from inspector.app import InspectorApp
    from radcons.stages.objects.run import height_objects

    app = InspectorApp(port=0, demo_size=256, preset="radcons", record_dir=tmp_path / "recordings").start()
    try:
        page, _ = open_page(browser, app)
        page.get_by_role("tab", name="Tune").click()
        open_stage(page, "objects", "use_supplied")
        page.get_by_label("use_supplied", exact=True).uncheck()
        wait_until(lambda: not app.session.params.objects.use_supplied, what="use_supplied off")
        page.get_by_label("method", exact=True).locator("visible=true").click()
        page.get_by_role("option", name="height", exact=True).click()
        wait_until(lambda: getattr(app.session.run, "objects", None) is not None
                   and getattr(app.session.run.objects, "height", None) is not None, what="objects from height")
        assert app.wait_idle(120)
        run = app.session.run
        assert run.params.objects.method == "height" and run.objects.method == "height"

        # the status line and the Objects tab name the method, what was left out, the evidence
        page.get_by_text("tree-like", exact=False).first.wait_for(timeout=30_000)
        assert f"{run.objects.trees} tree-like, {run.objects.mismatched} mismatched or shadows" in app.context.status.content
        page.get_by_role("tab", name="Objects").click()
        page.get_by_role("columnheader", name="evidence").first.wait_for(timeout=30_000)
        assert page.get_by_role("columnheader", name="flag").first.is_visible()
        evidence = {obj.evidence for obj in run.association.objects}
        assert page.get_by_role("cell", name=sorted(evidence)[0], exact=True).first.is_visible()

        # the height overlay, alone, against the stage called on the same pair
        pair = app.session.work.pair
        meta = pair.metadata
        stage = height_objects(
            pair.reference.as_float32(), pair.target.as_float32(), run.params.objects,
            gsd_m=meta["gsd_m"], base_to_height=meta["base_to_height"],
        )
        expected = stage.height.full(pair.shape, "height")
        top = float(np.nanpercentile(expected, 99.5))
        page.get_by_role("tab", name="View").click()
        for label in ("Object outlines", "Object ids"):
            page.get_by_label(label, exact=True).uncheck()
        page.get_by_label(HEIGHT, exact=True).check()
        sent = wait_until(
            lambda: (layer := app.viewport.sent_layers.get("reference")) is not None and layer[..., 3].any() and layer,
            what="the height layer to be sent",
        )
        assert sent.shape[:2] == pair.shape  # a 256 px pair is shown at full resolution
        known = np.isfinite(expected)
        assert np.array_equal(sent[..., 3] > 0, known)
        decoded = decode_heights(sent, (0.0, top))
        error = np.abs(decoded[known] - np.clip(expected[known], 0.0, top))
        assert np.median(error) <= top / 255 + 1e-6 and np.percentile(error, 99) <= 3 * top / 255
        page.get_by_text(f"0.0 – {top:.1f} {run.objects.height.unit}", exact=False).first.wait_for(timeout=30_000)

        # the regions the rules left out, each in its rule's colour, against the same stage call
        codes = stage.left_out
        assert codes is not None and (codes == 1).any()  # the demo pair has groves
        page.get_by_label(HEIGHT, exact=True).uncheck()
        page.get_by_label(LEFT_OUT, exact=True).check()
        sent = wait_until(
            lambda: (layer := app.viewport.sent_layers.get("reference")) is not None
            and np.array_equal(layer[..., 3] > 0, codes > 0) and layer,
            what="the left-out layer to be sent",
        )
        for code, (colour, _) in LEFT_OUT_COLOURS.items():
            assert (sent[codes == code][:, :3] == colour).all()
        page.get_by_text(f"tree_texture = {run.params.objects.tree_texture:g}", exact=False).first.wait_for(timeout=30_000)
        page.get_by_label(LEFT_OUT, exact=True).uncheck()

        # the 3D scene coloured by height
        page.get_by_label("3D colours", exact=True).click()
        page.get_by_role("option", name="height above ground").click()
        page.get_by_label("Compare", exact=True).click()
        page.get_by_role("option", name="3D scene").click()
        lut = turbo_lut()
        rows, cols = pair.shape
        scale = top / 255.0

        def coloured_by_height():
            cloud = app.viewport.cloud
            if cloud is None or app.session.review is None:
                return False
            points, colours = cloud
            col = np.clip(np.rint(points[:, 0] * max(rows, cols) + cols / 2), 0, cols - 1).astype(int)
            row = np.clip(np.rint(points[:, 1] * max(rows, cols) + rows / 2), 0, rows - 1).astype(int)
            values = expected[row, col]
            index = np.clip(np.rint(np.nan_to_num(values, nan=0.0) / scale), 0, 255).astype(int)
            wanted = np.where(np.isfinite(values)[:, None], lut[index], 0)
            return bool((np.abs(colours.astype(np.int32) - wanted).max(axis=1) <= 8).mean() > 0.98)

        wait_until(coloured_by_height, timeout=180, what="the 3D points coloured by height")
    finally:
        app.stop()


def test_one_left_out_rule_can_be_shown_alone():
    """An analyst picks one rule (``left_out_rule``): only its regions are drawn."""
    codes = np.zeros((ROWS, COLS), np.uint8)
    codes[2:8, 40:60] = 1
    codes[30:44, 2:12] = 5
    codes[42:46, 20:24] = 5
    objects = replace(ramp_objects(), left_out=codes)
    choices = left_out_choices(objects)
    assert choices == {EVERY_RULE: None, "1: tree (1)": 1, "5: no image edge along its outline (2)": 5}
    on = {label: False for label in OVERLAYS} | {LEFT_OUT: True}
    for code in (1, 5):
        reference, _ = draw_layers(on, bare_pair(), objects, None, 1, (ROWS, COLS), None, left_out_rule=code)
        assert np.array_equal(reference[..., 3] > 0, codes == code)
        assert (reference[codes == code][:, :3] == LEFT_OUT_COLOURS[code][0]).all()
    every, _ = draw_layers(on, bare_pair(), objects, None, 1, (ROWS, COLS), None, left_out_rule=None)
    assert np.array_equal(every[..., 3] > 0, codes > 0)
    assert left_out_choices(ObjectLabels(codes, codes, "user")) == {EVERY_RULE: None}

