"""The matcher's invalid pixels by cause in the inspector: the review keeps the causes of
the shown stage's match and, without ground truth, the left-right consistent share per
object; the Disparity tab's checkboxes paint each cause on the disparity picture.

The viewer test starts the inspector on its demo pair (its default without files) and
waits on state: the session's review and the picture sent for the disparity map.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import wait_for_run, wait_until
from scipy import ndimage

from inspector import render
from inspector.review import causes_markdown, review_run
from inspector.validity_layers import LAYER_COLOURS
from radcons.evaluate.matching import left_right_shares, matcher_params
from radcons.evaluate.validity import CAUSES, MATCHED, NO_MATCH
from radcons.io import Pair, Raster
from radcons.params import Params
from radcons.pipeline import Run
from radcons.results import (
    Association,
    Matches,
    ObjectAssociation,
    ObjectLabels,
    StageImages,
)

ROWS, COLS, SHIFT = 80, 200, 5


def run_without_truth() -> Run:
    """A textured pair moved by SHIFT px, no ground truth, two associated objects; object 2
    is a flat patch of the target, where nothing can be matched."""
    wide = ndimage.gaussian_filter(np.random.default_rng(3).normal(size=(ROWS, COLS + SHIFT)), 1.3)
    wide = (100.0 + 800.0 * (wide - wide.min()) / (wide.max() - wide.min())).astype(np.float32)
    reference, target = wide[:, :COLS], wide[:, SHIFT:].copy()
    target[45:75, 100:160] = 500.0
    labels = np.zeros((ROWS, COLS), np.int32)
    labels[10:40, 40:100] = 1
    labels[50:70, 110:150] = 2
    matches = Matches(np.array([[50.0, 20.0], [120.0, 60.0]], np.float32), np.array([[45.0, 20.0], [115.0, 60.0]], np.float32))
    objects = tuple(ObjectAssociation(i, i, "test", float(SHIFT), np.zeros(0, int), np.zeros(0, int)) for i in (1, 2))
    pair = Pair(Raster(reference), Raster(target), name="no truth")
    results = {
        "original": StageImages(reference, target, {}),
        "objects": ObjectLabels(labels, labels, "user"),
        "association": Association(matches, objects),
        "global": StageImages(reference, target, {}),
    }
    return Run(pair=pair, params=Params(), working_pair=pair, results=results, timings={}, cached={})


@pytest.mark.parametrize("matcher", ["sgbm", "census"])
def test_the_review_keeps_the_causes_and_the_consistent_share_per_object(matcher):
    run = run_without_truth()
    review = review_run(run, "global", {}, (), matcher=matcher)
    reference, target = run.images("global")
    params = matcher_params(matcher)
    codes = review.causes.codes
    assert codes.shape == reference.shape and set(np.unique(codes)) <= set(range(len(CAUSES)))
    assert np.array_equal(codes == NO_MATCH, np.isfinite(reference) & ~np.isfinite(review.current.disparity))
    # the shares the tab compares methods on are those of the left-right check
    matched, consistent = left_right_shares(reference, target, review.current.disparity, params, review.disparity_range)
    assert review.consistency["global"].consistent == pytest.approx(consistent)
    assert review.consistency["global"].matched == pytest.approx(matched)
    # per object: the textured one is consistent, the flat one is not
    shares = review.object_consistency
    assert set(shares) == {(1, 1), (2, 2)}
    assert shares[(1, 1)] > 0.9 and shares[(2, 2)] < 0.5
    labels = run.objects.reference
    assert shares[(1, 1)] == pytest.approx(review.causes.consistent[labels == 1].mean())
    text = causes_markdown(review)
    assert "| 2 → 2 |" in text.split("| 1 → 1 |")[0]  # least consistent first
    assert all(f"| {name} |" in text for name in CAUSES)


def cause_shares(table: str) -> dict[str, float]:
    """The shares of the Disparity tab's table of pixels by cause."""
    rows = [line.strip("| ").split(" | ") for line in table.splitlines() if line.startswith("| ")]
    return {cells[0]: float(cells[1]) for cells in rows if cells[0] in CAUSES}


@pytest.mark.browser
def test_each_cause_is_a_toggled_layer_of_the_disparity_picture(tmp_path):
    from inspector.app import InspectorApp

    app = InspectorApp(port=0, demo_size=192, record_dir=tmp_path / "recordings").start()
    try:
        wait_for_run(app)
        wait_until(lambda: app.session.review, 300, what="the review of the demo pair")
        viewport = app.viewport

        def drawn() -> bool:
            shown = app.displayed
            return (
                app.session.review is not None
                and viewport.sent_picture("disparity") is not None
                and shown is not None
                and shown.view == app.session.review.stage
                and app.wait_idle(1)
            )

        wait_until(drawn, 300, what="the disparity picture of the review")
        review = app.session.review
        frame = render.display_frame(app.displayed.images, app.view.display_side)
        codes = frame.apply(review.causes.codes, labels=True)
        plain = viewport.sent_picture("disparity").copy()
        assert plain.shape[:2] == codes.shape
        shares = cause_shares(app.disparity.table.content)
        assert set(shares) == set(CAUSES) and sum(shares.values()) == pytest.approx(1.0, abs=0.005)
        assert shares["matched"] == pytest.approx(float((review.causes.codes == MATCHED).mean()), abs=5e-4)
        present = [name for name in LAYER_COLOURS if (codes == CAUSES.index(name)).any()]
        assert {"no match", "nodata"} <= set(present) or len(present) >= 2
        for name in present:
            box = app.disparity.layers[name]
            box.value = True
            painted = wait_until(
                lambda: not np.array_equal(viewport.sent_picture("disparity"), plain) and viewport.sent_picture("disparity"),
                30, what=f"the {name} layer",
            )
            cause = codes == CAUSES.index(name)
            assert np.all(painted[cause] == LAYER_COLOURS[name])
            assert np.array_equal(painted[~cause], plain[~cause])  # only that cause's pixels
            box.value = False
            wait_until(lambda: np.array_equal(viewport.sent_picture("disparity"), plain), 30, what=f"the {name} layer off")
    finally:
        app.stop()
