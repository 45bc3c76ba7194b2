"""The Objects tab: how the objects were found, the object table (offsets in the reference's
grey levels), the regions the height method's rules left out by rule with their counts
(:func:`inspector.overlays.left_out_legend`), the object choice and the selected object's
drill-down.

An object is selected here, by a click in the images or from Python
(:meth:`ObjectsPanel.select`); its crops, histograms, fit plot and metrics
(:func:`inspector.objects.object_details`) are drawn on the render worker.
"""

from __future__ import annotations

from typing import Any

from inspector import objects as object_table
from inspector.layout import BLANK
from inspector.overlays import left_out_legend
from inspector.panels.base import Panel
from inspector.review import resolve_view, view_images

__all__ = ["ObjectsPanel"]

_HINT = "Click an object in the images, or choose it above."


class ObjectsPanel(Panel):
    """The object table and the drill-down of the selected object."""

    def build(self, gui: Any) -> None:
        """Add the objects' summary, the object choice, the details and the table."""
        self.summary = gui.add_markdown("")
        self.choice = gui.add_dropdown("Object", ("none",), initial_value="none")
        self.choice.on_update(self.on_choice)
        self.metrics = gui.add_markdown(_HINT)
        self.crops = gui.add_image(BLANK, label="reference | target (current stage)", format="jpeg", visible=False)
        self.histograms = gui.add_image(BLANK, label="grey-value histograms", format="png", visible=False)
        self.fit = gui.add_image(BLANK, label="invariant points and fitted line (eq 8)", format="png", visible=False)
        self.table = gui.add_markdown("")

    @staticmethod
    def _table(run: Any, rows: list[object_table.ObjectRow], selected: int | None, reviewed: bool) -> str:
        """The object table, offsets to the decimals of the original reference's range,
        and the regions left out by rule (objects found from height)."""
        if run is None:
            return ""
        has_truth = run.working_pair.disparity is not None
        decimals = object_table.grey_decimals(run.images("original")[0])
        table = object_table.table_markdown(rows, selected, has_truth, reviewed, decimals)
        params = getattr(getattr(run, "params", None), "objects", None)
        left_out = left_out_legend(run.objects, params)
        return f"{table}\n\n{left_out}" if left_out else table

    def on_choice(self, event: Any) -> None:
        """An object was chosen in the dropdown."""
        if self.quiet:
            return
        value = self.choice.value
        self.select(None if value == "none" else int(value))

    def select(self, ref_id: int | None) -> None:
        """Select a reference object (None: no selection) and show its details.

        The details and the overlays (:attr:`Context.selection_drawn`) are drawn on the
        render worker.
        """
        session = self.context.session
        with session.lock:
            session.selected = ref_id
        self.set_quietly(self.choice, "none" if ref_id is None else str(ref_id))

        def draw(job: Any) -> None:
            self.refresh()
            self.context.selection_drawn.emit()

        self.context.render.submit(draw, fail=self.context.display_failed, label="select")

    def refresh(self) -> None:
        """Redraw the object table, the object choice and the selected object's details."""
        session = self.context.session
        with session.lock:
            run, review, selected, cache, view = session.run, session.review, session.selected, session.cache, session.view
        rows = object_table.object_rows(run, review)
        options = ("none", *(str(row.ref_id) for row in rows))
        if selected is not None and str(selected) not in options:
            selected = None
            with session.lock:
                session.selected = None
        if tuple(self.choice.options) != options:
            with self.quietly():
                self.choice.options = options
        self.set_quietly(self.choice, "none" if selected is None else str(selected))
        table = self._table(run, rows, selected, review is not None)
        summary = object_table.objects_status(run)
        if self.summary.content != summary:
            self.summary.content = summary
        pictures = (self.crops, self.histograms, self.fit)
        if run is None or selected is None:
            with self.context.server.atomic():
                self.metrics.content = _HINT
                self.table.content = table
                for picture in pictures:
                    picture.visible = False
            return
        shown = resolve_view(run, view)
        details = object_table.object_details(run, selected, shown, view_images(run, shown, cache), review)
        # The heading and metrics first, on their own: the page shows them before it has
        # re-rendered the table and decoded the pictures.
        self.metrics.content = details.metrics
        self.table.content = table
        with self.context.server.atomic():
            for picture, image in zip(pictures, (details.crops, details.histograms, details.fit)):
                picture.image = image
                picture.visible = True
