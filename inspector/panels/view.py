"""The View tab and the viewport: which stage is shown, how the two images are compared,
the overlays, clicks in the images and the 3D scene.

Both images of a view are mapped to 8 bits with one grey-value range
(:func:`render.display_range`), cropped to the box of their valid pixels with what is
left without data in a dim flat grey (:func:`render.display_frame`), shrunk to at most
``display_side`` and sent as JPEG; the overlays (:class:`~inspector.overlays.OverlayLayers`)
as PNG, only when they changed, drawn for the pictures' scale on the canvas. The
disparity map of the Disparity tab's review is drawn beside them in the same frame, with
the matcher's invalid pixels of the causes ticked in that tab painted over it
(:mod:`inspector.validity_layers`); it stays (captioned as the previous run's) while the
next review is measured, so that the pictures do not move at every run.
For objects found from height, the height above ground is an overlay (with its legend and
colour bar here) and a colouring of the 3D scene. "Before / after" shows anaglyphs (red =
reference, cyan = target) of the original pair and of the shown stage, and their absolute
differences on one scale (:mod:`inspector.before_after`). Redraws asked for by a control
run on the render worker.
"""

from __future__ import annotations

import collections
import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from inspector import render
from inspector.before_after import before_after
from inspector.context import Context
from inspector.layout import BLANK
from inspector.objects import reference_id_at
from inspector.overlays import (
    EVERY_RULE,
    LEFT_OUT,
    OVERLAYS,
    OverlayLayers,
    height_legend,
    height_of,
    left_out_choices,
    left_out_legend,
)
from inspector.panels.base import Panel
from inspector.review import resolve_view, view_images
from inspector.state import WorkPair
from inspector.viewport import COMPARE_MODES

__all__ = ["ViewPanel", "Displayed", "CLOUD_COLOURS"]

#: How the points of the 3D scene are coloured.
CLOUD_COLOURS: tuple[str, ...] = ("image", "height above ground")


@dataclass(frozen=True)
class Displayed:
    """What the viewport shows now (for tests and benchmarks).

    Attributes
    ----------
    generation : int
        Compute request whose run is shown (0 before the first run).
    params : radcons.params.Params or None
        Parameters of the run shown.
    view : str
        Stage or baseline shown.
    images : (ndarray, ndarray)
        The float ``(reference, target)`` images of that view.
    pictures : (ndarray, ndarray)
        The 8-bit grey pictures sent to the browser (one grey-value range for both).
    final : bool
        True when the whole pipeline had run (not only up to the shown stage).
    shown_at : float
        ``time.perf_counter()`` after the pictures were queued for the browsers.
    """

    generation: int
    params: Any
    view: str
    images: tuple[np.ndarray, np.ndarray]
    pictures: tuple[np.ndarray, np.ndarray]
    final: bool
    shown_at: float


class ViewPanel(Panel):
    """Draws the shown run into the viewport and handles the View tab and scene clicks.

    Parameters
    ----------
    context : Context
    display_side : int
        Longest side of the pictures sent to the browser.

    Attributes
    ----------
    displayed : Displayed or None
        What the viewport shows now.
    shown_log : deque of Displayed
        The last 200 views shown.
    """

    def __init__(self, context: Context, display_side: int) -> None:
        super().__init__(context)
        self.display_side = display_side
        self.displayed: Displayed | None = None
        self.shown_log: collections.deque[Displayed] = collections.deque(maxlen=200)
        self._lock = threading.RLock()
        self._geometry: tuple[render.DisplayFrame, tuple[int, int]] | None = None
        self._last_disparity: tuple[render.DisplayFrame, np.ndarray, str, np.ndarray | None] | None = None
        self._final = True
        self._overlays = OverlayLayers()
        self._legend_of: tuple[Any, str] | None = None
        self._left_out_choices: dict[str, int | None] = {EVERY_RULE: None}

    def build(self, gui: Any) -> None:
        """Add the stage, compare, swipe, overlay and 3D controls; listen to scene clicks."""
        from radcons.baselines import BASELINES
        from radcons.pipeline import IMAGE_STAGES

        views = (*IMAGE_STAGES, *(f"baseline:{name}" for name in BASELINES))
        self.stage = gui.add_dropdown("Stage", views, initial_value=self.context.session.view)
        self.stage.on_update(self.on_stage)
        self.compare = gui.add_dropdown("Compare", COMPARE_MODES, initial_value=COMPARE_MODES[0])
        self.compare.on_update(self.on_compare)
        self.swipe = gui.add_slider("Swipe", min=0.0, max=1.0, step=0.01, initial_value=0.5)
        self.swipe.on_update(lambda event: self.request_render())
        self.overlays: dict[str, Any] = {}
        with gui.add_folder("Overlays"):
            for label, default in OVERLAYS.items():
                self.overlays[label] = gui.add_checkbox(label, default)
                self.overlays[label].on_update(lambda event: self.request_overlays())
            self.left_out_rule = gui.add_dropdown(
                "Left-out rule", (EVERY_RULE,), initial_value=EVERY_RULE,
                hint="Show the regions of one rule only (with the left-out overlay), to see where it acts",
            )
            self.left_out_rule.on_update(self.on_left_out_rule)
            self.legend = gui.add_markdown(height_legend(None, (1, 1)))
            self.colour_bar = gui.add_image(render.colour_bar(), label="height colours: ground → top", format="png", visible=False)
        self.cloud_colours = gui.add_dropdown(
            "3D colours", CLOUD_COLOURS, initial_value=CLOUD_COLOURS[0],
            hint="Colour the 3D scene by the shown image, or by the height above ground (objects found from height)",
        )
        self.cloud_colours.on_update(lambda event: self.request_review(with_pictures=False))
        self.height_scale = gui.add_slider("3D height scale", min=0.5, max=20.0, step=0.5, initial_value=4.0)
        self.height_scale.on_update(lambda event: self.request_review(with_pictures=False))
        self._build_before_after(gui)
        gui.add_markdown(
            "Images of a pair share one grey-value range, so their radiometric difference stays "
            "visible. Click an object to inspect it."
        )
        self.context.viewport.on_layout = self.request_render  # the overlays' scale changed
        scene = self.context.server.scene
        scene.on_click()(self.on_scene_click)
        scene.on_click(modifier="shift")(self.on_scene_shift_click)

    def _build_before_after(self, gui: Any) -> None:
        """Add the before/after folder: its switch, caption, two anaglyphs and the differences."""
        with gui.add_folder("Before / after"):
            self.before_after = gui.add_checkbox(
                "Anaglyph and difference", True,
                hint="Red = reference, cyan = target, for the original pair and the shown stage; and |reference − target|",
            )
            self.before_after.on_update(lambda event: self.request_render())
            self.before_after_caption = gui.add_markdown("")
            self.anaglyph_original = gui.add_image(BLANK, label="anaglyph · original", format="jpeg")
            self.anaglyph_shown = gui.add_image(BLANK, label="anaglyph · shown stage", format="jpeg")
            self.difference = gui.add_image(BLANK, label="|reference − target| · original | shown stage", format="jpeg")

    # ------------------------------------------------------------------ drawing

    def first_paint(self, work: WorkPair) -> None:
        """Show a pair as it is, before the panels exist.

        The page draws the images while the server imports the stages and builds the
        panels; :meth:`refresh` replaces them once the pair is loaded.
        """
        images = (work.pair.reference.as_float32(), work.pair.target.as_float32())
        frame, pictures, _ = self._pictures(images)
        clear = np.zeros((*pictures[0].shape, 4), np.uint8)
        titles = ("reference · original · computing…", "target · original · computing…")
        self.context.viewport.show(pictures[0], pictures[1], (clear, clear), titles, frame)

    def _pictures(self, images: tuple[np.ndarray, np.ndarray]) -> tuple[render.DisplayFrame, tuple[np.ndarray, np.ndarray], np.ndarray]:
        """The frame (:func:`render.display_frame`) and 8-bit display pictures of two float
        images, mapped with one range, without data in :data:`render.NODATA_GREY`; and
        where the reference's picture has no data."""
        value_range = render.display_range(*images)
        frame = render.display_frame(images, self.display_side)
        shrunk = [frame.apply(image) for image in images]
        invalid = [~np.isfinite(image) for image in shrunk]
        reference, target = (render.mark_nodata(render.to_display(image, value_range), nodata) for image, nodata in zip(shrunk, invalid))
        return frame, (reference, target), invalid[0]

    def _disparity(
        self, frame: render.DisplayFrame, invalid: np.ndarray, shape: tuple[int, int]
    ) -> tuple[tuple[np.ndarray, str], np.ndarray | None] | None:
        """The review's disparity map in the pictures' frame (RGB, turbo over its search
        range, no data where the reference has none) and its caption, with the cause
        code of each of its pixels (None when the review has none); the last one drawn in
        this frame while no review is at hand (a run just replaced it); else None."""
        review = self.context.session.review
        if review is not None and review.current.disparity.shape == shape:
            picture = render.colourise(frame.apply(review.current.disparity, labels=True), review.disparity_range)
            low, high = review.disparity_range
            title = f"disparity · {review.stage} · {review.matcher} · {low:.0f} .. {high:.0f} px"
            causes = None if review.causes is None else frame.apply(review.causes.codes, labels=True)
            self._last_disparity = (frame, render.mark_nodata(picture, invalid), title, causes)
        if self._last_disparity is None or self._last_disparity[0] != frame:
            return None
        _, picture, title, causes = self._last_disparity
        return (picture, title if review is not None else f"{title} · previous run"), causes

    def refresh(self, final: bool | None = None) -> None:
        """Draw the chosen view of the current run (or the bare pair) into the viewport.

        Parameters
        ----------
        final : bool, optional
            False while the run goes on to later stages (said in the titles); None keeps
            what the last call said (a redraw for a new review).
        """
        session = self.context.session
        with self._lock:
            final = self._final if final is None else final
            self._final = final
            with session.lock:
                work, run, selected = session.work, session.run, session.selected
                generation, cache, view = session.run_generation, session.cache, session.view
            if work is None:
                return
            if run is None:
                from radcons.pipeline import pair_images

                images, shown = pair_images(work.pair), "original"
                caption = " · computing…"
            else:
                images = view_images(run, view, cache)
                shown = resolve_view(run, view)
                caption = "" if final else " · running later stages…"
                if shown != view:
                    caption = f" · {view} not run (Tune ▸ {view})" if final else caption
            shape = images[0].shape
            frame, pictures, invalid = self._pictures(images)
            disparity, causes = self._disparity(frame, invalid, shape) or (None, None)
            self._geometry = (frame, pictures[0].shape)
            overlays = self._overlay_layers(run, work, selected)
            self._show_legend(run, shape)
            titles = (f"reference · {shown}{caption}", f"target · {shown}{caption}")
            self.context.viewport.show(
                pictures[0], pictures[1], overlays, titles, frame, float(self.swipe.value), disparity, causes
            )
            self.displayed = Displayed(
                generation, run.params if run is not None else None, shown, images, pictures,
                final and run is not None, time.perf_counter(),
            )
            self.shown_log.append(self.displayed)
            self._show_before_after(run, images, shown)  # after the viewport, which it must not delay

    def _overlay_layers(self, run: Any, work: WorkPair, selected: int | None) -> tuple[np.ndarray, np.ndarray]:
        """The overlay layers for the pictures of :attr:`_geometry`, at the scale the
        viewport draws them on the canvas (outlines stay
        :data:`inspector.overlays.OUTLINE_PX` wide)."""
        frame, shape = self._geometry
        viewport = self.context.viewport
        disparity = self._last_disparity is not None and self._last_disparity[0] == frame
        scale = round(viewport.picture_scale(frame.shape, max(shape), disparity), 1)
        rule = self._left_out_choices.get(str(self.left_out_rule.value))
        choice = self._overlay_choice()
        return self._overlays.layers(choice, run, work, frame.factor, shape, selected, frame.box, scale, rule)

    def _show_before_after(self, run: Any, images: tuple[np.ndarray, np.ndarray], shown: str) -> None:
        """Draw the before/after pictures of the shown view, when asked for and there is a run."""
        on = bool(self.before_after.value) and run is not None
        pictures = (self.before_after_caption, self.anaglyph_original, self.anaglyph_shown, self.difference)
        if on:
            drawn = before_after(run.images("original"), images, shown)
            with self.context.server.atomic():
                self.before_after_caption.content = drawn.caption
                self.anaglyph_original.image = drawn.original
                self.anaglyph_shown.image = drawn.shown
                self.difference.image = drawn.difference
        for picture in pictures:
            if picture.visible != on:
                picture.visible = on

    def refresh_overlays(self) -> None:
        """Redraw only the overlay layers (selection, overlay checkboxes or the canvas changed)."""
        session = self.context.session
        with self._lock:
            with session.lock:
                work, run, selected = session.work, session.run, session.selected
            if work is None or self._geometry is None:
                return
            layers = self._overlay_layers(run, work, selected)
            self.context.viewport.show_overlays(layers, float(self.swipe.value))

    def _show_legend(self, run: Any, shape: tuple[int, int]) -> None:
        """Write the height legend of the run's objects (once per objects result)."""
        objects = run.objects if run is not None else None
        if self._legend_of is not None and self._legend_of[0] is objects:
            return
        params = getattr(getattr(run, "params", None), "objects", None)
        text = "<br>".join(part for part in (height_legend(objects, shape), left_out_legend(objects, params)) if part)
        self._legend_of = (objects, text)
        self.legend.content = text
        self._left_out_choices = left_out_choices(objects)
        options = tuple(self._left_out_choices)
        if tuple(self.left_out_rule.options) != options:
            with self.quietly():
                self.left_out_rule.options = options
                if self.left_out_rule.value not in options:
                    self.left_out_rule.value = EVERY_RULE
        self.colour_bar.visible = getattr(objects, "height", None) is not None

    def on_left_out_rule(self, event: Any) -> None:
        """A left-out rule was chosen: switch the left-out overlay on and draw that rule's regions."""
        if self.quiet:
            return
        if self.left_out_rule.value != EVERY_RULE and not self.overlays[LEFT_OUT].value:
            self.overlays[LEFT_OUT].value = True  # its callback redraws the overlays
            return
        self.request_overlays()

    def _overlay_choice(self) -> dict[str, bool]:
        return {label: box.value for label, box in self.overlays.items()}

    def request_render(self) -> None:
        """Redraw the view on the render worker."""
        self.context.render.submit(lambda job: self.refresh(), fail=self.context.display_failed, label="render")

    def request_overlays(self) -> None:
        """Redraw the overlays on the render worker."""
        self.context.render.submit(lambda job: self.refresh_overlays(), fail=self.context.display_failed, label="overlays")

    def request_review(self, with_pictures: bool = True) -> None:
        """Show the session's review (render worker), if it is of the images shown: its
        disparity map beside them (a redraw of the view, unless ``with_pictures`` is
        False) and its 3D point cloud."""
        review = self.context.session.review
        if review is None:
            return

        def draw(job: Any) -> None:
            if with_pictures:
                self.refresh()
            displayed = self.displayed
            if displayed is None or displayed.images[0].shape != review.current.disparity.shape:
                return
            colours = self._cloud_colours(displayed)
            points, rgb = render.point_cloud(review.current.disparity, colours, height_scale=float(self.height_scale.value))
            self.context.viewport.show_cloud(points, rgb)

        self.context.render.submit(draw, fail=self.context.display_failed, label="cloud")

    def _cloud_colours(self, displayed: Displayed) -> np.ndarray:
        """Colours of the 3D points: the shown reference image in grey, or its height above
        ground in the overlay's colours (grey when the run's objects carry no height)."""
        if self.cloud_colours.value == CLOUD_COLOURS[1]:
            run = self.context.session.run
            found = height_of(run.objects if run is not None else None, displayed.images[0].shape)
            if found is not None:
                return render.colourise(found[0], found[1])
        return render.to_display(displayed.images[0], render.display_range(*displayed.images))

    # ------------------------------------------------------------------ callbacks

    def on_stage(self, event: Any) -> None:
        """Another stage or baseline was chosen."""
        with self.context.session.lock:
            self.context.session.view = self.stage.value
        self.request_render()
        self.context.view_chosen.emit()

    def on_compare(self, event: Any) -> None:
        """Another compare mode was chosen; the 3D scene needs a review of the shown view."""
        mode = self.compare.value
        self.context.viewport.set_mode(mode)
        self.request_render()
        if mode == "3D scene":
            session = self.context.session
            review = session.review
            if review is None or review.stage != session.view:
                self.context.review_asked.emit()
            else:
                self.request_review()

    def on_scene_click(self, event: Any) -> None:
        """A click in the images selects the object under it (none: the background)."""
        hit = self.context.viewport.pick(event.ray_origin, event.ray_direction)
        if hit is None:
            return
        image, x, y = hit
        self.context.object_clicked.emit(reference_id_at(self.context.session.run, image, x, y))

    def on_scene_shift_click(self, event: Any) -> None:
        """Shift+click: tune on a full-resolution region centred where it was clicked."""
        hit = self.context.viewport.pick(event.ray_origin, event.ray_direction)
        work = self.context.session.work
        if hit is None or work is None:
            return
        _, x, y = hit
        if work.mode == "region" and work.region is not None:
            centre = (work.region[0] + x, work.region[1] + y)
        else:
            centre = (x * work.factor, y * work.factor)
        self.context.region_asked.emit(centre, event.client)
