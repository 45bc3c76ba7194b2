"""The overlay layers of the viewport: object outlines and ids, matches, invariant points,
the change mask, and the selected object.

Each associated object pair gets one colour in both images (:func:`render.pair_colour`);
a target object is named by the reference object it is associated with, so that the two
images show the same ids. The layers depend on the objects and the association only, not
on the images: :class:`OverlayLayers` reuses the last ones while those stay the same.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from inspector import render
from inspector.state import WorkPair
from radcons.io import Pair

__all__ = ["OVERLAYS", "draw_layers", "OverlayLayers"]

#: Overlay checkboxes: label -> shown by default.
OVERLAYS: dict[str, bool] = {
    "Object outlines": True,
    "Object ids": True,
    "SIFT matches": False,
    "Invariant points": False,
    "Change mask": False,
}


def draw_layers(
    on: Mapping[str, bool],
    pair: Pair,
    objects: Any,
    association: Any,
    factor: int,
    shape: tuple[int, int],
    selected: int | None,
) -> tuple[np.ndarray, np.ndarray]:
    """Draw the RGBA overlay layers of the reference and the target image.

    Parameters
    ----------
    on : mapping
        :data:`OVERLAYS` label -> drawn.
    pair : Pair
        The pair the objects were found on (its change mask is drawn).
    objects : radcons.results.ObjectLabels or None
    association : radcons.results.Association or None
    factor : int
        Downsampling factor from the pair to the displayed pictures.
    shape : (int, int)
        ``(height, width)`` of the displayed pictures.
    selected : int or None
        Reference id of the selected object (its target object is ringed too).

    Returns
    -------
    (ndarray, ndarray)
        The reference and target layers, uint8 of shape ``(*shape, 4)``.
    """
    scale = max(shape) / 360.0  # image pixels per screen pixel, roughly
    change = None
    if on["Change mask"] and pair.change_mask is not None:
        change = render.resize_for_display(pair.change_mask, factor, labels=True)[: shape[0], : shape[1]]
    colours: dict[str, dict[int, tuple[int, int, int]]] = {"reference": {}, "target": {}}
    names: dict[str, dict[int, str] | None] = {"reference": None, "target": {}}
    if association is not None:
        for index, obj in enumerate(association.objects):
            colour = render.pair_colour(index)
            colours["reference"][obj.ref_id] = colour
            colours["target"][obj.tgt_id] = colour
            names["target"][obj.tgt_id] = str(obj.ref_id)
    selected_tgt = None
    if association is not None and selected is not None:
        match = association.by_ref().get(selected)
        selected_tgt = match.tgt_id if match is not None else None
    layers = []
    for image, index in (("reference", 0), ("target", 1)):
        labels = None
        if objects is not None and (on["Object outlines"] or on["Object ids"] or selected is not None):
            source = objects.reference if index == 0 else objects.target
            labels = render.resize_for_display(source, factor, labels=True)[: shape[0], : shape[1]]
        points = invariant = None
        if association is not None and len(association.matches):
            xy = association.matches.ref_xy if index == 0 else association.matches.tgt_xy
            if on["SIFT matches"]:
                points = xy / factor
            if on["Invariant points"]:
                chosen = [o.invariant_indices for o in association.objects if o.invariant_indices.size]
                if chosen:
                    invariant = xy[np.concatenate(chosen)] / factor
        layers.append(
            render.draw_overlay(
                shape,
                labels=labels,
                outlines=on["Object outlines"],
                colours=colours[image],
                names=names[image] if on["Object ids"] else {},
                selected=selected if index == 0 else selected_tgt,
                points=points,
                invariant=invariant,
                change=change,
                scale=scale,
            )
        )
    return layers[0], layers[1]


class OverlayLayers:
    """The overlay layers of the shown run, redrawn only when something they show changed.

    The last layers are reused while the checkboxes, the selection, the display geometry
    and the run's pair, objects and association (compared by identity) stay the same: a
    radiometric parameter change does not redraw or resend them.
    """

    def __init__(self) -> None:
        self._last: tuple[Any, ...] | None = None

    def layers(
        self,
        on: Mapping[str, bool],
        run: Any,
        work: WorkPair,
        factor: int,
        shape: tuple[int, int],
        selected: int | None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """The layers of ``run`` (or of the bare work pair before its first run).

        Parameters
        ----------
        on : mapping
            :data:`OVERLAYS` label -> drawn.
        run : radcons.pipeline.Run or None
        work : WorkPair
        factor : int
            Downsampling factor from the work pair to the displayed pictures.
        shape : (int, int)
            ``(height, width)`` of the displayed pictures.
        selected : int or None
            Reference id of the selected object.
        """
        pair = run.working_pair if run is not None else work.pair
        sources = (pair, run.objects if run is not None else None, run.association if run is not None else None)
        key = (tuple(on.items()), selected, factor, tuple(shape))
        last = self._last
        if last is not None and last[0] == key and all(a is b for a, b in zip(last[1], sources)):
            return last[2]
        layers = draw_layers(on, *sources, factor, shape, selected)
        self._last = (key, sources, layers)
        return layers
