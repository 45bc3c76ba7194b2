"""The inspector on a raw real pair, through its page: a Pleiades pre/post-event pair that
radcons rectifies with the images' RPC models.

The Disparity tab must search the disparities the rectification found (widened by 10 % of
their span and 4 px), not a range spread by the mismatches of two dates, and report the
share of the reference it matched; the View tab shows the pair's anaglyphs. The viewport
draws the pictures large (the grid of reference, target and disparity map fills the
canvas), the epipolar frame's corners without data in a dim grey, and the objects'
outlines wide enough to be seen on the canvas. Skipped where the real data
(``../shared/data``) is absent. Waits on state (the session, the page's text), never on
fixed sleeps.
"""

from __future__ import annotations

import re

import cv2
import numpy as np
import pytest
import scipy.ndimage
from conftest import wait_for_run, wait_until

pytestmark = [pytest.mark.realdata, pytest.mark.browser]

FOLDER, REFERENCE, TARGET = "pleiades_kahramanmaras_prepost", "pre_event_img1.tif", "post_event_img2.tif"

#: How the Disparity tab writes the range it searched.
RANGE_TEXT = re.compile(r"disparities (-?\d+) \.\. (-?\d+) px")


def test_disparity_tab_searches_the_rectifications_range_and_reports_the_matched_share(shared_data, browser, tmp_path):
    from inspector.app import InspectorApp

    files = [shared_data / FOLDER / name for name in (REFERENCE, TARGET)]
    if not all(path.is_file() for path in files):
        pytest.skip(f"{FOLDER} is not in {shared_data}")
    app = InspectorApp(pairs=files, port=0, record_dir=tmp_path / "recordings").start()
    try:
        page = browser()
        page.goto(app.url)
        run = wait_for_run(app, 600)
        rectification = run.rectification
        assert rectification is not None and rectification.method == "rpc", "the raw pair was not rectified by RPC"

        def reviewed():
            review = app.session.review
            return review is not None and review.stage == app.session.view and review.consistency and review

        review = wait_until(reviewed, 600, what="the review of the shown stage")
        page.get_by_role("tab", name="Disparity").click()
        paragraph = page.get_by_text(RANGE_TEXT).first
        paragraph.wait_for(timeout=60_000)
        low, high = (int(value) for value in RANGE_TEXT.search(paragraph.inner_text()).groups())

        # the rectification's range, widened by 10 % of its span and 4 px on each side
        rect_low, rect_high = rectification.disparity_range
        margin = 0.1 * (rect_high - rect_low) + 4.0
        assert rect_low - margin - 0.5 <= low <= rect_low + 0.5
        assert rect_high - 0.5 <= high <= rect_high + margin + 0.5
        assert "rpc rectification's range" in paragraph.inner_text()

        row = page.get_by_role("row").filter(has_text="(shown)").first
        row.wait_for(timeout=60_000)
        cells = [cell.strip() for cell in row.inner_text().split("\t")]
        consistent, matched = float(cells[1]), float(cells[2])
        shares = review.consistency[review.stage]
        assert matched == pytest.approx(shares.matched, abs=5e-4)
        assert consistent == pytest.approx(shares.consistent, abs=5e-4)
        # over -113 .. 726 px (the range of the two dates' raw matches) SGBM matched 5 %
        assert 0.25 < matched <= 1.0 and 0.0 < consistent <= matched

        # the View tab's anaglyphs and differences, of the original pair and the shown stage
        page.get_by_role("tab", name="View").click()
        page.get_by_text("Anaglyphs: red = reference, cyan = target", exact=False).first.wait_for(timeout=60_000)
        assert f"**{review.stage}** (right)" in app.view.before_after_caption.content

        check_viewport(app, page, run)
    finally:
        app.stop()


def canvas_rgb(page) -> np.ndarray:
    page.bring_to_front()
    shot = page.locator("canvas").last.screenshot()
    return cv2.cvtColor(cv2.imdecode(np.frombuffer(shot, np.uint8), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB).astype(np.int32)


def border_samples(run, count: int = 10, per_object: int = 24) -> list[tuple[float, float, tuple[int, int, int]]]:
    """Work-pair pixels ``(x, y)`` on the border of the largest associated reference
    objects, with the colour of their pair."""
    from inspector import render

    labels = run.objects.reference
    sizes = scipy.ndimage.sum_labels(np.ones_like(labels), labels, np.arange(labels.max() + 1))
    colours = {obj.ref_id: render.pair_colour(index) for index, obj in enumerate(run.association.objects) if obj.tgt_id > 0}
    samples = []
    for ref_id in sorted(colours, key=lambda i: -sizes[i])[:count]:
        mask = labels == ref_id
        rows, cols = np.nonzero(mask & ~scipy.ndimage.binary_erosion(mask))
        for index in np.linspace(0, rows.size - 1, per_object).astype(int):
            samples.append((cols[index] + 0.5, rows[index] + 0.5, colours[ref_id]))
    return samples


def outline_hits(app, page, client, samples) -> float:
    """Share of the border samples with a pixel of their pair's colour within 2 px on the canvas."""
    pixels = canvas_rgb(page)
    scale = page.locator("canvas").last.bounding_box()["width"] / client.camera.image_width
    hits = 0
    for x, y, colour in samples:
        u, v = (scale * value for value in app.viewport.screen_point(client, "reference", x, y))
        window = pixels[max(0, int(v) - 2) : int(v) + 3, max(0, int(u) - 2) : int(u) + 3]
        hits += bool((np.abs(window - np.array(colour)).sum(axis=2) < 90).any())
    return hits / len(samples)


def check_viewport(app, page, run) -> None:
    """Pictures large, nodata dimmed, outlines drawn (and seen on the canvas) at the canvas's scale."""
    from inspector import render
    from inspector.overlays import OUTLINE_PX

    client = next(iter(app.server.get_clients().values()))
    canvas = page.locator("canvas").last.bounding_box()
    wait_until(lambda: app.viewport.framed(client) and abs(client.camera.aspect - canvas["width"] / canvas["height"]) < 1e-3, 60, what="the camera to fit the canvas")
    assert set(app.viewport.placements) == {"reference", "target", "disparity"}

    # the pictures fill the canvas (not a third of it)
    scale = canvas["width"] / client.camera.image_width
    height, width = run.working_pair.shape
    corners = np.array([
        [scale * v for v in app.viewport.screen_point(client, name, x, y)]
        for name in app.viewport.placements for x, y in ((0, 0), (width, height))
    ])
    span = (corners.max(axis=0) - corners.min(axis=0)) / np.array([canvas["width"], canvas["height"]])
    assert span.max() > 0.9, f"the pictures span only {span} of the canvas"

    # the rectified frame's corners without data are a flat dim grey, the rest is the image
    images, picture = app.displayed.images, app.displayed.pictures[0]
    row0, row1, col0, col1 = render.valid_box(*images)
    factor = render.downsample_factor((row1 - row0, col1 - col0), app.view.display_side)
    shrunk = render.resize_for_display(images[0][row0:row1, col0:col1], factor)
    assert shrunk.shape == picture.shape
    nodata = ~np.isfinite(shrunk)
    assert nodata.mean() > 0.1 and (picture[nodata] == render.NODATA_GREY).all()

    # outlines in the sent layer, OUTLINE_PX canvas px wide (ids off: they are written
    # inside the objects, in the outlines' colours)
    app.view.overlays["Object ids"].value = False
    assert app.wait_idle(60)
    layer = app.viewport.sent_layers["reference"]
    on_canvas = (app.viewport.screen_point(client, "reference", width, 0)[0] - app.viewport.screen_point(client, "reference", 0, 0)[0]) * scale
    expected = render.outline_thickness(picture.shape[1] / on_canvas, OUTLINE_PX)
    assert expected >= 3, "a shrunk picture needs outlines several picture pixels wide"
    labels = render.resize_for_display(run.objects.reference[row0:row1, col0:col1], factor, labels=True)
    largest = np.bincount(labels.ravel())[1:].argmax() + 1
    inside = scipy.ndimage.distance_transform_cdt(labels == largest, metric="chessboard")
    band = (layer[..., 3] > 0) & (labels == largest)
    assert abs(int(inside[band].max()) - expected) <= 1 and (inside[band] <= expected + 1).all()

    # ... and seen on the canvas where the objects' borders are; gone with the outlines off
    samples = border_samples(run)
    page.evaluate("document.querySelectorAll('.mantine-Notification-closeButton').forEach((b) => b.click())")
    assert app.wait_idle(60)
    drawn = wait_until(lambda: (share := outline_hits(app, page, client, samples)) > 0.7 and share, 30, what="outlines on the canvas")
    app.view.overlays["Object outlines"].value = False
    assert app.wait_idle(60)
    bare = wait_until(lambda: (share := outline_hits(app, page, client, samples)) < 0.25 and share + 1e-9, 30, what="the outlines gone")
    assert drawn > bare + 0.5
