"""The inspector on a raw real pair, through its page: a Pleiades pre/post-event pair that
radcons rectifies with the images' RPC models.

The Disparity tab must search the disparities the rectification found (widened by 10 % of
their span and 4 px), not a range spread by the mismatches of two dates, and report the
share of the reference it matched; the View tab shows the pair's anaglyphs. Skipped where
the real data (``../shared/data``) is absent. Waits on state (the session, the page's
text), never on fixed sleeps.
"""

from __future__ import annotations

import re

import pytest
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
    finally:
        app.stop()
