"""The Disparity tab: dense matching of the shown stage, next to the original pair and the
baselines (:func:`inspector.review.review_run`), with the matcher chosen in a dropdown
(OpenCV SGBM or census + SGM by CNES Pandora), over the pair's own disparity range, which
the tab names (:func:`inspector.review.search_range`); a second table puts the figures of
every matcher reviewed so far side by side (correct-matching rates, or without ground
truth the left-right consistent shares). A third table sorts the shown stage's reference
pixels by cause (matched, left-right rejected, at the range's edge, no match, nodata) and,
without ground truth, gives the left-right consistent share of each associated object
(:func:`inspector.review.causes_markdown`); a checkbox per invalid cause paints its
pixels on the disparity picture of the viewport (:mod:`inspector.validity_layers`),
redrawing only that picture.

A review runs on the review worker after each finished run (when "Match after each run"
is ticked or the 3D scene is shown) or when asked for. It waits until tuning has paused
for :data:`REVIEW_DELAY` seconds and stops between two methods when a run starts, then
waits again: dense matching would slow a slider down.
"""

from __future__ import annotations

import time
from typing import Any

from inspector import render
from inspector.context import failure_reason
from inspector.layout import BLANK
from inspector.panels.base import Panel
from inspector.review import (
    MATCHER_TITLES,
    Review,
    causes_markdown,
    matchers_markdown,
    review_markdown,
    review_run,
)
from inspector.validity_layers import LAYER_COLOURS, layers_legend
from inspector.worker import Job

__all__ = ["DisparityPanel", "REVIEW_DELAY"]

#: Seconds without a new run before dense matching starts (it would slow a slider down).
REVIEW_DELAY = 0.3


class DisparityPanel(Panel):
    """Reviews the shown run and shows its disparity maps and matching rates."""

    def build(self, gui: Any) -> None:
        """Add the review switch and button, the table and the disparity pictures."""
        from radcons.baselines import BASELINES
        from radcons.evaluate.matching import MATCHERS

        self._baselines = tuple(BASELINES)
        self.matcher = gui.add_dropdown(
            "Matcher",
            tuple(MATCHERS),
            initial_value="sgbm",
            hint="Dense matcher: " + ", ".join(f"{name} = {MATCHER_TITLES[name]}" for name in MATCHERS),
        )
        self.matcher.on_update(lambda event: self.request())
        self.auto_review = gui.add_checkbox(
            "Match after each run", True, hint="Dense matching of the shown stage after every run, by the matcher above"
        )
        self.auto_review.on_update(lambda event: self.request() if self.auto_review.value else None)
        self.match_now = gui.add_button("Match now")
        self.match_now.on_click(lambda event: self.request())
        self.table = gui.add_markdown("")
        self.layers_legend = gui.add_markdown(layers_legend())
        self.layers: dict[str, Any] = {}
        for name in LAYER_COLOURS:  # every layer off at start
            self.layers[name] = gui.add_checkbox(name, False, hint=f"Paint the {name} pixels on the disparity picture")
            self.layers[name].on_update(lambda event: self.show_layers())
        self.disparity_image = gui.add_image(BLANK, label="disparity (shown stage)", format="jpeg")
        self.truth_image = gui.add_image(BLANK, label="ground truth", format="jpeg")
        self.error_image = gui.add_image(BLANK, label="error: green < 1 px, red wrong, blue failed", format="png")

    def chosen_layers(self) -> tuple[str, ...]:
        """The causes whose checkbox is ticked."""
        return tuple(name for name, box in self.layers.items() if box.value)

    def show_layers(self) -> None:
        """Paint the ticked causes on the disparity picture (only that picture is redrawn)."""
        self.context.viewport.show_validity_layers(self.chosen_layers())

    def _wanted(self) -> bool:
        """A review follows every run: asked for, or needed by the 3D scene."""
        return bool(self.auto_review.value) or self.context.viewport.mode == "3D scene"

    def on_published(self, run: Any, final: bool, step: int | None) -> None:
        """Review a finished run if wanted."""
        if final and self._wanted():
            self.request()

    def on_view_chosen(self) -> None:
        """Review the newly chosen view if wanted."""
        if self._wanted():
            self.request()

    def request(self) -> None:
        """Review the shown run on the review worker."""
        self.context.review.submit(self._measure, self._deliver, self._failed, label="review")

    def _measure(self, job: Job) -> tuple[Any, Review] | None:
        """Measure the shown run (:func:`review_run`), giving way to tuning.

        It starts once the compute worker has been idle for :data:`REVIEW_DELAY` seconds
        (a run announces its result before its job ends, so a review asked for by that
        announcement waits for the job) and goes back to waiting when a run starts in the
        middle of it. It gives up only when a newer review is asked for.
        """
        reviews = self.context.review
        while reviews.is_current(job):
            if not self._wait_for_quiet(job):
                return None
            session = self.context.session
            with session.lock:
                run, cache, view = session.run, session.cache, session.view
            if run is None:
                return None
            matcher = str(self.matcher.value)
            self.table.content = f"_Matching ({matcher})…_"
            stop = lambda: self.context.compute.busy or not reviews.is_current(job)  # noqa: E731
            review = review_run(run, view, cache, self._baselines, stop, matcher)
            if review is not None:
                return run, review
        return None

    def _wait_for_quiet(self, job: Job) -> bool:
        """Wait until no run has been asked for or has run for :data:`REVIEW_DELAY`
        seconds; False when a newer review was asked for meanwhile."""
        compute, reviews = self.context.compute, self.context.review
        quiet_since, generation = None, compute.generation
        while reviews.is_current(job):
            if compute.busy or compute.generation != generation:
                quiet_since, generation = None, compute.generation
            elif quiet_since is None:
                quiet_since = time.monotonic()
            elif time.monotonic() - quiet_since >= REVIEW_DELAY:
                return True
            time.sleep(0.02)
        return False

    def _deliver(self, job: Job, result: tuple[Any, Review] | None) -> None:
        if result is None:
            return
        run, review = result
        session = self.context.session
        with session.lock:
            if session.run is not run:
                return
            session.review = review
            cache = session.cache
        self._show(review, matchers_markdown(run, review, cache, self._baselines))
        self.context.review_ready.emit()

    def _failed(self, job: Job, exc: BaseException) -> None:
        self.table.content = f"_Dense matching failed: {failure_reason(exc, print_trace=True)}_"

    def _show(self, review: Review, matchers_table: str = "") -> None:
        """Show the review's tables, its disparity map and (with ground truth) the error map."""
        has_truth = review.truth is not None
        factor = render.downsample_factor(review.current.disparity.shape, 1024)
        disparity = render.resize_for_display(review.current.disparity, factor, labels=True)
        with self.context.server.atomic():
            tables = (review_markdown(review), causes_markdown(review), matchers_table)
            self.table.content = "\n\n".join(table for table in tables if table)
            self.disparity_image.image = render.colourise(disparity, review.disparity_range)
            if has_truth:
                truth = render.resize_for_display(review.truth, factor, labels=True)
                self.truth_image.image = render.colourise(truth, review.disparity_range)
                self.error_image.image = render.error_map(disparity, truth)
            self.truth_image.visible = has_truth
            self.error_image.visible = has_truth
