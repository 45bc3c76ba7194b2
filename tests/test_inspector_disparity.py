"""The inspector's Disparity tab: the matcher dropdown and the tables of methods per matcher."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from scipy import ndimage

from conftest import wait_until

from inspector.panels.disparity import REVIEW_DELAY, DisparityPanel
from inspector.review import matchers_markdown, review_markdown, review_run
from radcons.errors import ParamsError
from radcons.evaluate.matching import MATCHERS
from radcons.io import Pair, Raster
from radcons.params import Params
from radcons.pipeline import Run
from radcons.results import ObjectLabels, StageImages

ROWS, COLS, SHIFT = 96, 160, 5


def known_run() -> Run:
    """Stages of a textured pair moved by SHIFT px: ``reference(x, y) = target(x - SHIFT, y)``.

    ``global``: the target's grey levels squeezed into half a grey value (an increasing map,
    as a low-contrast image), which leaves the order of grey levels, and so census,
    unchanged, while SGBM's common 8-bit range leaves the target nearly flat.
    """
    rng = np.random.default_rng(4)
    wide = ndimage.gaussian_filter(rng.normal(size=(ROWS, COLS + SHIFT)), 1.3)
    wide = (wide - wide.min()) / (wide.max() - wide.min())
    reference = (100.0 + 800.0 * wide[:, :COLS]).astype(np.float32)
    target = (100.0 + 800.0 * wide[:, SHIFT:]).astype(np.float32)
    curved = (500.0 + 0.5 * wide[:, SHIFT:] ** 2).astype(np.float32)
    truth = np.full((ROWS, COLS), SHIFT, np.float32)
    truth[:, :SHIFT] = np.nan
    labels = np.zeros((ROWS, COLS), np.int32)
    labels[10:50, 20:80] = 1
    labels[55:90, 90:150] = 2
    pair = Pair(Raster(reference), Raster(target), disparity=truth, name="known")
    results = {
        "original": StageImages(reference, target, {}),
        "objects": ObjectLabels(labels, labels, "user"),
        "global": StageImages(reference, curved, {}),
    }
    return Run(pair=pair, params=Params(), working_pair=pair, results=results, timings={}, cached={})


def truth_rate(disparity: np.ndarray) -> float:
    truth = np.full(disparity.shape, SHIFT, np.float32)
    truth[:, :SHIFT] = np.nan
    known = np.isfinite(truth)
    return float((np.abs(disparity - truth)[known] < 1).sum() / known.sum())


@pytest.fixture(scope="module")
def reviewed() -> tuple[Run, dict, dict]:
    """The ``global`` stage reviewed with each matcher, one cache for both."""
    run, cache = known_run(), {}
    reviews = {matcher: review_run(run, "global", cache, (), matcher=matcher) for matcher in MATCHERS}
    return run, cache, reviews


def test_the_chosen_matcher_measures_against_the_known_shift(reviewed):
    _, _, reviews = reviewed
    for matcher, review in reviews.items():
        assert review.matcher == matcher and review.stage == "global"
        assert review.original.correct_rate == pytest.approx(truth_rate(review.original.disparity), abs=1e-9)
        assert review.original.correct_rate > 0.85  # both matchers find the shift of the plain pair
    # the squeezed grey levels leave census' disparity right and spoil SGBM's
    census, sgbm = reviews["census"].current, reviews["sgbm"].current
    assert truth_rate(census.disparity) > 0.85
    assert truth_rate(sgbm.disparity) < truth_rate(census.disparity) - 0.1
    assert census.correct_rate == pytest.approx(truth_rate(census.disparity), abs=1e-9)


def test_each_matcher_is_cached_apart(reviewed):
    run, cache, reviews = reviewed
    before = dict(cache)
    again = review_run(run, "global", cache, (), matcher="census")
    assert again.original is reviews["census"].original  # from the cache, not matched again
    assert again.original is not reviews["sgbm"].original
    assert set(cache) == set(before)


def test_tables_name_the_matcher_and_put_matchers_side_by_side(reviewed):
    run, cache, reviews = reviewed
    assert "census + SGM, CNES Pandora" in review_markdown(reviews["census"])
    assert "OpenCV SGBM" in review_markdown(reviews["sgbm"])
    table = matchers_markdown(run, reviews["census"], cache)
    assert "sgbm: all / objects" in table and "census: all / objects" in table
    row = next(line for line in table.splitlines() if line.startswith("| **global**"))
    cells = [cell.strip() for cell in row.strip("|").split("|")][1:]
    sgbm_all, census_all = (float(cell.split("/")[0]) for cell in cells)
    assert census_all == pytest.approx(reviews["census"].current.correct_rate, abs=0.001)
    assert sgbm_all == pytest.approx(reviews["sgbm"].current.correct_rate, abs=0.001)


def test_a_matcher_not_reviewed_yet_shows_a_dash():
    run, cache = known_run(), {}
    review = review_run(run, "original", cache, (), matcher="sgbm")
    row = next(line for line in matchers_markdown(run, review, cache).splitlines() if line.startswith("| **original**"))
    assert row.rstrip(" |").endswith("-")


def test_unknown_matcher_is_refused():
    with pytest.raises(ParamsError, match="unknown matcher"):
        review_run(known_run(), "original", {}, (), matcher="mc-cnn")


class _Control:
    def __init__(self, value: Any = None, options: Any = None) -> None:
        self.value, self.options, self.callbacks = value, options, []

    def on_update(self, callback):
        self.callbacks.append(callback)

    on_click = on_update


class _Gui:
    def __init__(self) -> None:
        self.controls: dict[str, _Control] = {}

    def add_dropdown(self, label, options, *, initial_value=None, hint=None):
        self.controls[label] = _Control(initial_value, tuple(options))
        return self.controls[label]

    def add_checkbox(self, label, value, hint=None):
        self.controls[label] = _Control(value)
        return self.controls[label]

    def add_button(self, label):
        self.controls[label] = _Control()
        return self.controls[label]

    def add_markdown(self, content):
        return _Control(content)

    def add_image(self, image, label=None, format=None):
        return _Control(image)


def test_dropdown_offers_every_matcher_and_a_choice_starts_a_review():
    gui = _Gui()
    panel = DisparityPanel(context=None)
    panel.build(gui)
    dropdown = gui.controls["Matcher"]
    assert dropdown.options == tuple(MATCHERS) and dropdown.value == "sgbm"
    asked = []
    panel.request = lambda: asked.append(True)
    dropdown.value = "census"
    for callback in dropdown.callbacks:
        callback(None)
    assert asked == [True]


def test_a_review_asked_for_while_the_run_announces_itself_waits_for_the_run():
    """A run announces its result (and so asks for a review) before its job ends; that
    review must wait for the job instead of giving up, and must be measured once it ends."""
    import contextlib
    import threading
    from types import SimpleNamespace

    from inspector.worker import LatestWorker

    compute, reviews = LatestWorker("compute"), LatestWorker("review")
    session = SimpleNamespace(lock=threading.Lock(), run=None, cache={}, view="global", review=None)
    ready = threading.Event()
    context = SimpleNamespace(
        compute=compute,
        review=reviews,
        session=session,
        server=SimpleNamespace(atomic=contextlib.nullcontext),
        review_ready=SimpleNamespace(emit=ready.set),
        viewport=SimpleNamespace(mode="images"),
    )
    panel = DisparityPanel(context=context)
    panel.build(_Gui())
    release = threading.Event()

    def run_job(job):
        session.run = known_run()
        panel.on_published(session.run, True, 0)  # announced from inside the running job
        release.wait(10.0)  # the rest of the job: recording, redrawing

    try:
        compute.submit(run_job)
        wait_until(lambda: reviews.busy, 10.0, what="the review asked for by the run")
        assert not release.wait(3 * REVIEW_DELAY)  # the run's job goes on past the review's delay
        assert session.review is None
        release.set()
        assert ready.wait(60.0), "the review asked for during the run was never measured"
        assert session.review.stage == "global" and session.review.current.name == "global"
    finally:
        release.set()
        compute.stop()
        reviews.stop()
