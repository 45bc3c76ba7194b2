"""The overlay layers of the viewport: object outlines and ids, matches, invariant points,
the change mask, the selected object, and the height above ground of objects found from
height with the elevated regions its rules left out.

Each associated object pair gets one colour in both images (:func:`render.pair_colour`);
a target object is named by the reference object it is associated with, so that the two
images show the same ids. The height above ground (:class:`radcons.stages.objects.ground.HeightMap`
of the ``"height"`` objects method) lies in the reference's frame: it is drawn under the
reference's other layers, in turbo colours from the ground (0) to the 99.5th percentile of
the heights (:func:`render.height_range`). The regions the method's rules left out
(:attr:`radcons.stages.objects.regions.HeightObjects.left_out`) are drawn over it, each in
its rule's colour (:data:`render.LEFT_OUT_COLOURS`, named in :func:`left_out_legend`), so
that an analyst sees which rule took a building and which threshold to move. The layers
depend on the objects and the
association only, not on the images: :class:`OverlayLayers` reuses the last ones while
those stay the same.

The layers are drawn at the size of the pictures sent (after cropping and shrinking,
:class:`render.DisplayFrame`), with outlines :data:`OUTLINE_PX` canvas pixels wide at
the framed zoom: a 1000 px picture drawn 400 px wide gets 5 px outlines, which the
browser's shrinking leaves 2 px wide instead of thinning them away.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np
import scipy.ndimage

from inspector import render
from inspector.state import WorkPair
from radcons.io import Pair

__all__ = ["OVERLAYS", "OUTLINE_PX", "HEIGHT", "LEFT_OUT", "height_of", "height_legend", "left_out_legend", "left_out_choices", "EVERY_RULE", "draw_layers", "OverlayLayers"]

#: Overlay of the height above ground (objects found from height only).
HEIGHT = "Height above ground"
#: Overlay of the elevated regions the height method's rules left out, by rule.
LEFT_OUT = "Left-out regions"

#: Width of the object outlines on the canvas at the framed zoom, pixels.
OUTLINE_PX = 2.0

#: Overlay checkboxes: label -> shown by default.
OVERLAYS: dict[str, bool] = {
    "Object outlines": True,
    "Object ids": True,
    "SIFT matches": False,
    "Invariant points": False,
    "Change mask": False,
    HEIGHT: False,
    LEFT_OUT: False,
}


def height_of(objects: Any, shape: tuple[int, int]) -> tuple[np.ndarray, tuple[float, float], str] | None:
    """The height above ground of a run's objects at the working pair's ``shape``.

    Parameters
    ----------
    objects : radcons.results.ObjectLabels or None
        The run's objects; only those of the ``"height"`` method carry a height map.
    shape : (int, int)
        ``(height, width)`` of the working pair.

    Returns
    -------
    (ndarray, (float, float), str) or None
        The map (:meth:`HeightMap.full`, NaN where unknown), its colour range
        (:func:`render.height_range`) and its unit (``"m"`` or ``"px"``); None when the
        objects carry no height map (supplied labels, the image-only method, a fallback).
    """
    heights = getattr(objects, "height", None)
    if heights is None:
        return None
    full = heights.full(tuple(shape[:2]), "height")
    return full, render.height_range(full), heights.unit


def height_legend(objects: Any, shape: tuple[int, int]) -> str:
    """Markdown legend of the height overlay: its colour range and unit, or why there is none.

    Parameters
    ----------
    objects : radcons.results.ObjectLabels or None
    shape : (int, int)
        ``(height, width)`` of the working pair.
    """
    found = height_of(objects, shape)
    if found is None:
        why = "no run yet" if objects is None else (
            "the objects are the pair's own labels; untick use_supplied" if objects.source == "user"
            else f"the objects come from the image-only method ({getattr(objects, 'note', '') or 'mbi'})"
        )
        return f"<sub>Height above ground: none ({why}; Tune ▸ objects ▸ method = height).</sub>"
    _, (low, high), unit = found
    return (
        f"<sub>Height above ground (reference): **{low:.1f} – {high:.1f} {unit}**, turbo colours "
        f"from blue (ground and below) to red ({high:.1f} {unit} and above); none where the disparity "
        "is unknown.</sub>"
    )


#: The left-out rule choice that draws every rule's regions.
EVERY_RULE = "every rule"


def left_out_legend(objects: Any, params: Any = None) -> str:
    """Markdown legend of the left-out overlay: each rule's colour, what it says, and how many regions.

    Parameters
    ----------
    objects : radcons.results.ObjectLabels or None
        Only the ``"height"`` method's objects carry left-out regions.
    params : radcons.stages.objects.params.ObjectsParams, optional
        The parameters the objects were found with: each rule's parameters are written
        with their values (``tree_texture = 1.3``), the values an analyst moves.
    """
    counts = left_out_counts(objects)
    if counts is None:
        return ""
    if not counts:
        return "<sub>Left-out regions: none (no elevated region was left out by a rule).</sub>"
    from radcons.stages.objects.rules import LEFT_OUT_RULES

    lines = [
        f"{render.LEFT_OUT_COLOURS[code][1]} {count} × {_with_values(LEFT_OUT_RULES[code], params)}"
        for code, count in counts.items()
    ]
    return "<sub>Left-out regions (reference):<br>" + "<br>".join(lines) + "</sub>"


def left_out_choices(objects: Any) -> dict[str, int | None]:
    """The left-out rules an analyst can show one at a time: dropdown label -> rule code.

    ``"every rule"`` (None) first, then each rule that left a region out of ``objects``,
    labelled with its code, its first words and how many regions it left out.
    """
    from radcons.stages.objects.rules import LEFT_OUT_RULES

    choices: dict[str, int | None] = {EVERY_RULE: None}
    for code, count in (left_out_counts(objects) or {}).items():
        choices[f"{code}: {LEFT_OUT_RULES[code].split(' (')[0].split(':')[0]} ({count})"] = code
    return choices


def left_out_counts(objects: Any) -> dict[int, int] | None:
    """Rule code -> how many regions (connected) it left out of ``objects``, for the rules
    that left any out, in the order of :data:`radcons.stages.objects.rules.LEFT_OUT_RULES`;
    None for objects without left-out regions (not found from height)."""
    codes = getattr(objects, "left_out", None)
    if codes is None:
        return None
    from radcons.stages.objects.rules import LEFT_OUT_RULES

    counts = {code: int(scipy.ndimage.label(codes == code)[1]) for code in LEFT_OUT_RULES}
    return {code: count for code, count in counts.items() if count}


def _with_values(text: str, params: Any) -> str:
    """A rule's text with the parameters it names in its closing parentheses followed by their values."""
    if params is None or not text.endswith(")"):
        return text
    head, _, names = text[:-1].rpartition("(")
    shown = [f"{name} = {getattr(params, name):g}" if hasattr(params, name) else name for name in names.split(", ")]
    return f"{head}({', '.join(shown)})"


def draw_layers(
    on: Mapping[str, bool],
    pair: Pair,
    objects: Any,
    association: Any,
    factor: int,
    shape: tuple[int, int],
    selected: int | None,
    box: tuple[int, int, int, int] | None = None,
    scale: float | None = None,
    left_out_rule: int | None = None,
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
    box : (int, int, int, int), optional
        ``(row0, row1, col0, col1)`` of the pair shown (:attr:`render.DisplayFrame.box`; None: all).
    scale : float, optional
        Picture pixels per canvas pixel at the framed zoom; outlines are
        :data:`OUTLINE_PX` canvas pixels wide, text and dots grow with it. None takes a
        picture drawn 360 px wide.
    left_out_rule : int, optional
        Draw only this rule's left-out regions (:data:`radcons.stages.objects.rules.
        LEFT_OUT_RULES`; None: every rule's), to see where one rule acts.

    Returns
    -------
    (ndarray, ndarray)
        The reference and target layers, uint8 of shape ``(*shape, 4)``.
    """
    frame = render.DisplayFrame(box or (0, pair.shape[0], 0, pair.shape[1]), factor)
    scale = max(shape) / 360.0 if scale is None else scale

    def shown(array: np.ndarray, labels: bool = True) -> np.ndarray:
        return frame.apply(array, labels)[: shape[0], : shape[1]]

    change = shown(pair.change_mask) if on["Change mask"] and pair.change_mask is not None else None
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
    base = _reference_base(on, objects, pair.shape, shown, left_out_rule)
    layers = []
    for image, index in (("reference", 0), ("target", 1)):
        labels = None
        if objects is not None and (on["Object outlines"] or on["Object ids"] or selected is not None):
            source = objects.reference if index == 0 else objects.target
            labels = shown(source)
        points = invariant = None
        if association is not None and len(association.matches):
            xy = association.matches.ref_xy if index == 0 else association.matches.tgt_xy
            xy = (xy - np.asarray(frame.origin)) / factor
            if on["SIFT matches"]:
                points = xy
            if on["Invariant points"]:
                chosen = [o.invariant_indices for o in association.objects if o.invariant_indices.size]
                if chosen:
                    invariant = xy[np.concatenate(chosen)]
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
                base=base if index == 0 else None,
                line_px=OUTLINE_PX,
            )
        )
    return layers[0], layers[1]


def _reference_base(
    on: Mapping[str, bool], objects: Any, shape: tuple[int, int], shown: Any, rule: int | None
) -> np.ndarray | None:
    """The layer under the reference's overlays: the height map and the left-out regions
    (only ``rule``'s when one is chosen), where their overlays are on; ``shown`` maps a
    pair-sized array to the displayed picture."""
    base = None
    found = height_of(objects, shape) if on.get(HEIGHT, False) else None
    if found is not None:
        full, value_range, _ = found
        base = render.height_layer(shown(full, labels=False), value_range)
    codes = getattr(objects, "left_out", None) if on.get(LEFT_OUT, False) else None
    if codes is not None and rule is not None:
        codes = np.where(codes == rule, codes, 0)
    if codes is not None and codes.any():
        base = render.left_out_layer(shown(codes), base)
    return base


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
        box: tuple[int, int, int, int] | None = None,
        scale: float | None = None,
        left_out_rule: int | None = None,
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
        box, scale, left_out_rule
            The part of the pair shown, the picture pixels per canvas pixel and the one
            left-out rule drawn (:func:`draw_layers`).
        """
        pair = run.working_pair if run is not None else work.pair
        sources = (pair, run.objects if run is not None else None, run.association if run is not None else None)
        key = (tuple(on.items()), selected, factor, tuple(shape), box, scale, left_out_rule)
        last = self._last
        if last is not None and last[0] == key and all(a is b for a, b in zip(last[1], sources)):
            return last[2]
        layers = draw_layers(on, *sources, factor, shape, selected, box, scale, left_out_rule)
        self._last = (key, sources, layers)
        return layers
