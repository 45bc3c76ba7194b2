"""The object table and the drill-down of one object, from a run and its review.

Each reference object gets a row: its associated target object, how it was associated,
the number of SIFT matches and invariant points, the modal disparity D̄m, the refine fit
(gain and offset of eq 8, the offset in the reference's grey levels with a fixed number of
decimals that suits its range, :func:`grey_decimals`), and, once the review is done, the
eq 20 similarity and the correct-matching rate before (original pair) and after (the shown
stage). Objects found from height (``[objects] method = "height"``) add what the pair's
SIFT matches say about each association (``evidence``) and a flag where they contradict
its disparity; :func:`objects_status` says how the objects of a run were found.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from inspector import plots, render

#: Decimals of a gain (a ratio of grey levels).
GAIN_DECIMALS = 3

__all__ = [
    "number_text", "fixed_text", "grey_decimals", "GAIN_DECIMALS", "ObjectRow", "object_rows", "table_markdown",
    "objects_status", "ObjectDetails", "object_details", "reference_id_at",
]


@dataclass(frozen=True)
class ObjectRow:
    """One line of the object table (NaN where a value is not known)."""

    ref_id: int
    tgt_id: int | None
    method: str
    matches: int
    invariant: int
    modal_disparity: float
    gain: float
    offset: float
    applied: bool
    clipped: bool
    similarity_before: float
    similarity_after: float
    rate_before: float
    rate_after: float
    evidence: str = ""
    flagged: bool = False


#: Evidence of an object found from height whose copy in the target fails the left-right check.
_NOT_MATCHED_BACK = "not matched back"
#: Evidence of a roof clipped in one image, placed by its outline (no census inside it).
_BY_OUTLINE = "clipped: D̄m from its outline"


def _fit_by_ref(run: Any) -> dict[int, Any]:
    return {int(fit.ref_id): fit for fit in run.fits}


def object_rows(run: Any, review: Any = None) -> list[ObjectRow]:
    """Rows for every reference object of ``run`` (sorted by id)."""
    if run is None or run.objects is None:
        return []
    ids = np.unique(run.objects.reference)
    associations = run.association.by_ref() if run.association is not None else {}
    unmatched = set(getattr(run.objects, "unmatched", ()))
    by_outline = set(getattr(run.objects, "by_outline", ()))
    fits = _fit_by_ref(run)
    nan = float("nan")
    rows = []
    for ref_id in (int(i) for i in ids if i > 0):
        assoc = associations.get(ref_id)
        fit = fits.get(ref_id)
        before = review.original if review is not None else None
        after = review.current if review is not None else None
        rows.append(
            ObjectRow(
                ref_id=ref_id,
                tgt_id=int(assoc.tgt_id) if assoc is not None else None,
                method=assoc.method if assoc is not None else "",
                matches=assoc.n_matches if assoc is not None else 0,
                invariant=assoc.n_invariant if assoc is not None else 0,
                modal_disparity=float(assoc.modal_disparity) if assoc is not None else nan,
                gain=float(fit.gain) if fit is not None else nan,
                offset=float(fit.offset) if fit is not None else nan,
                applied=bool(fit.applied) if fit is not None else False,
                clipped=bool(fit.clipped) if fit is not None else False,
                similarity_before=before.similarity.get(ref_id, nan) if before is not None else nan,
                similarity_after=after.similarity.get(ref_id, nan) if after is not None else nan,
                rate_before=before.object_rates.get(ref_id, nan) if before is not None else nan,
                rate_after=after.object_rates.get(ref_id, nan) if after is not None else nan,
                evidence=_evidence(assoc, ref_id in unmatched, ref_id in by_outline),
                flagged=bool(getattr(assoc, "flagged", False)),
            )
        )
    return rows


def _evidence(assoc: Any, unmatched: bool, by_outline: bool) -> str:
    """What supports an object's D̄m: its matches' verdict, a failed left-right check, its outline."""
    parts = [str(getattr(assoc, "evidence", "")) or (_NOT_MATCHED_BACK if unmatched else "")]
    if by_outline:
        parts.append(_BY_OUTLINE)
    return " · ".join(part for part in parts if part)


def number_text(value: float | None, digits: int = 3) -> str:
    """``value`` with ``digits`` significant digits, or ``·`` when it is missing or not finite."""
    return "·" if value is None or not math.isfinite(value) else f"{value:.{digits}g}"


def fixed_text(value: float | None, decimals: int) -> str:
    """``value`` in fixed notation with ``decimals`` decimals (never an exponent), or ``·``
    when it is missing or not finite: a 12-bit image's offset ``-1600.0``, not ``-1.6e+03``."""
    return "·" if value is None or not math.isfinite(value) else f"{value:.{decimals}f}"


def grey_decimals(image: np.ndarray) -> int:
    """Decimals that show grey levels of ``image`` to about 1/10 000 of its range.

    The range is that of :func:`render.display_range` (0.5th to 99.5th percentile): one
    decimal for 8- to 16-bit counts (``-1600.0``), four for reflectances in 0..1
    (``0.0123``), at most six.
    """
    low, high = render.display_range(image)
    return int(min(6, max(1, 4 - math.ceil(math.log10(high - low)))))


def _change(before: float, after: float) -> str:
    if not (math.isfinite(before) and math.isfinite(after)):
        return "·"
    arrow = "▲" if after > before + 0.005 else ("▼" if after < before - 0.005 else "=")
    return f"{before:.2f}→{after:.2f}{arrow}"


def _target_text(row: ObjectRow) -> str:
    if row.tgt_id is None:
        return "—"
    target = str(row.tgt_id) if row.tgt_id > 0 else "·"
    return target + ("ᵗ" if row.method == "template" else "")


def table_markdown(rows: list[ObjectRow], selected: int | None, has_truth: bool, reviewed: bool, decimals: int = 1) -> str:
    """The object table as markdown; the selected row is bold.

    Parameters
    ----------
    rows : list of ObjectRow
    selected : int or None
        The selected reference object.
    has_truth : bool
        Adds the correct-matching rates.
    reviewed : bool
        Whether the review's figures are in the rows (else "…").
    decimals : int
        Decimals of the offsets, grey levels of the reference (:func:`grey_decimals`);
        gains have :data:`GAIN_DECIMALS`.
    """
    if not rows:
        return "_No objects (segmentation found none)._"
    header = "| id | tgt | matches / inv. | D̄m | gain / offset | C (eq 20) |"
    rule = "|---:|---:|---:|---:|---:|:---|"
    evidence = any(row.evidence for row in rows)
    if evidence:
        header += " evidence | flag |"
        rule += ":---|:---:|"
    if has_truth:
        header += " correct rate |"
        rule += ":---|"
    lines = [header, rule]
    for row in rows:
        fit = "·" if not math.isfinite(row.gain) else (
            f"{fixed_text(row.gain, GAIN_DECIMALS)} / {fixed_text(row.offset, decimals)}"
            + ("ᶜ" if row.clipped else "") + ("" if row.applied else "*")
        )
        cells = [
            str(row.ref_id), _target_text(row), f"{row.matches} / {row.invariant}", number_text(row.modal_disparity),
            fit, _change(row.similarity_before, row.similarity_after) if reviewed else "…",
        ]
        if evidence:
            cells += [row.evidence or "·", "⚑" if row.flagged else ""]
        if has_truth:
            cells.append(_change(row.rate_before, row.rate_after) if reviewed else "…")
        if row.ref_id == selected:
            cells = [f"**{c}**" for c in cells]
        lines.append("| " + " | ".join(cells) + " |")
    legend = (
        "tgt: associated target object (ᵗ by template matching, · no target object: the "
        "footprint shifted by D̄m) · gain / offset of the refine fit (eq 8, offset in the reference's grey "
        "levels; ᶜ clipped pixels left out, or an offset only; * not applied) · C and "
        "correct rate: original → shown stage"
    )
    if evidence:
        legend += (
            " · evidence: what the SIFT matches inside an object found from height say about its D̄m "
            "(agrees: at least half within the invariant threshold; contradicts: fewer, flagged ⚑; "
            f"few matches: too few to tell; {_NOT_MATCHED_BACK}: its copy in the target matches the reference "
            "best elsewhere, so it has no D̄m and is not associated)"
        )
    return "\n".join(lines) + f"\n\n<sub>{legend}</sub>"


def objects_status(run: Any) -> str:
    """One line on how the objects of ``run`` were found (empty before its objects stage).

    Names the method (the pair's own labels, the image-only ``mbi`` method, or ``height``
    with the unit of its heights), the number of objects, for the height method the
    elevated regions left out as trees or as mismatched or shadows and the objects left unassociated
    by the left-right check, and the method's note (a flat
    scene, or why it fell back to the image-only method).
    """
    objects = getattr(run, "objects", None) if run is not None else None
    if objects is None:
        return ""
    count = int(np.unique(objects.reference[objects.reference > 0]).size)
    if objects.source == "user":
        return f"objects: the pair's own labels · {count} objects"
    method = getattr(objects, "method", "mbi")
    parts = [f"objects: **{method}** · {count} objects"]
    heights = getattr(objects, "height", None)
    if method == "height" and heights is not None:
        parts[0] += f" (heights in {heights.unit}"
        params = getattr(getattr(run, "params", None), "objects", None)
        if params is not None:
            threshold = params.min_height_m if heights.unit == "m" else params.min_height_px
            parts[0] += f", elevated above {threshold:g} {heights.unit}"
        parts[0] += f", a census step {heights.step:.2g} {heights.unit})"
        parts.append(f"left out: {objects.trees} tree-like, {objects.mismatched} mismatched or shadows")
        if objects.unmatched:
            parts.append(f"{len(objects.unmatched)} not associated (their copy in the target does not match back)")
        if getattr(objects, "by_outline", ()):
            parts.append(f"{len(objects.by_outline)} clipped in one image, placed by their outline")
    association = getattr(run, "association", None)
    if association is not None:
        flagged = sum(1 for obj in association.objects if getattr(obj, "flagged", False))
        if flagged:
            parts.append(f"{flagged} flagged (matches contradict D̄m)")
    note = getattr(objects, "note", "")
    if note:
        parts.append(note)
    return " · ".join(parts)


@dataclass(frozen=True)
class ObjectDetails:
    """What the drill-down shows for one object."""

    metrics: str
    crops: np.ndarray
    histograms: np.ndarray
    fit: np.ndarray


def reference_id_at(run: Any, image: str, x: float, y: float) -> int | None:
    """Reference object id under pixel ``(x, y)`` of the reference or target image.

    A target object maps to the reference object it is associated with; None for the
    background or an unassociated target object.
    """
    if run is None or run.objects is None:
        return None
    labels = run.objects.reference if image == "reference" else run.objects.target
    row, col = int(y), int(x)
    if not (0 <= row < labels.shape[0] and 0 <= col < labels.shape[1]):
        return None
    label = int(labels[row, col])
    if label == 0:
        return None
    if image == "reference":
        return label
    if run.association is None:
        return None
    for assoc in run.association.objects:
        if assoc.tgt_id == label:
            return int(assoc.ref_id)
    return None


def object_details(
    run: Any,
    ref_id: int,
    view: str,
    images: tuple[np.ndarray, np.ndarray],
    review: Any = None,
) -> ObjectDetails:
    """Crops, histograms, fit plot and metrics of reference object ``ref_id``.

    Parameters
    ----------
    run : radcons.pipeline.Run
    ref_id : int
    view : str
        Name of the shown stage (for captions).
    images : (ndarray, ndarray)
        The shown stage's ``(reference, target)`` float images.
    review : inspector.review.Review, optional
        Adds the similarity and correct-matching rates before and after.
    """
    assoc = run.association.by_ref().get(ref_id) if run.association is not None else None
    fit = _fit_by_ref(run).get(ref_id)
    ref_mask = run.objects.reference == ref_id
    tgt_mask = _target_mask(run, ref_mask, assoc)
    colour = (64, 200, 255)
    after = render.display_range(*images)
    original = run.images("original")
    decimals = grey_decimals(original[0])
    before = render.display_range(*original)
    ref_box = plots.crop_box(ref_mask)
    tgt_box = plots.crop_box(tgt_mask) if tgt_mask.any() else ref_box
    crops = plots.side_by_side(
        plots.crop_with_outline(images[0], ref_mask, after, colour, ref_box),
        plots.crop_with_outline(images[1], tgt_mask, after, (255, 170, 60), tgt_box),
    )
    tgt_values_before = original[1][tgt_mask] if tgt_mask.any() else np.zeros(0)
    tgt_values_after = images[1][tgt_mask] if tgt_mask.any() else np.zeros(0)
    histograms = np.concatenate(
        [
            plots.histogram_plot(
                [("reference", original[0][ref_mask], (86, 180, 233)), ("target", tgt_values_before, (240, 160, 40))],
                before, "before: original",
            ),
            plots.histogram_plot(
                [("reference", images[0][ref_mask], (86, 180, 233)), ("target", tgt_values_after, (240, 160, 40))],
                after, f"after: {view}",
            ),
        ],
        axis=0,
    )
    if fit is not None:
        kind = "pixel pairs at D̄m" if run.params.refine.points == "dense" else "invariant points"
        plot = plots.fit_plot(fit.x, fit.y, fit.weights, fit.gain, fit.offset, f"object {ref_id}: {fit.n_points} {kind}")
    else:
        plot = plots.fit_plot(np.zeros(0), np.zeros(0), None, float("nan"), float("nan"), f"object {ref_id}: no fit")
    lines = [f"### Object {ref_id}"]
    if assoc is None:
        lines.append("Not associated with a target object (too few matches and no template match).")
    else:
        lines.append(
            (f"Target object **{assoc.tgt_id}**" if assoc.tgt_id > 0 else "No target object at the match (footprint shifted by D̄m)")
            + f", by {assoc.method}"
            + (f" (NCC {assoc.score:.2f})" if assoc.method == "template" and math.isfinite(assoc.score) else "")
            + f" · {assoc.n_matches} matches · {assoc.n_invariant} invariant points · D̄m = {assoc.modal_disparity:.2f} px"
            + (f" · SIFT evidence: {assoc.evidence}" + (" ⚑" if assoc.flagged else "") if hasattr(assoc, "evidence") else "")
        )
    if fit is not None:
        sign = "−" if fit.offset < 0 else "+"
        lines.append(
            f"Fit: reference ≈ {fixed_text(fit.gain, GAIN_DECIMALS)} × target {sign} "
            f"{fixed_text(abs(fit.offset), decimals)} ({fit.state})"
        )
    lines += ["", "| | before (original) | after (" + view + ") |", "|---|---:|---:|"]
    ref_area, tgt_area = int(ref_mask.sum()), int(tgt_mask.sum())
    means = [_mean(image, mask, decimals) for image, mask in zip((*original, *images), (ref_mask, tgt_mask) * 2)]
    lines.append(f"| mean grey ref / tgt | {means[0]} / {means[1]} | {means[2]} / {means[3]} |")
    if review is not None:
        lines.append(
            f"| similarity C (eq 20) | {number_text(review.original.similarity.get(ref_id, float('nan')))} | "
            f"{number_text(review.current.similarity.get(ref_id, float('nan')))} |"
        )
        if review.truth is not None:
            lines.append(
                f"| correct-matching rate | {number_text(review.original.object_rates.get(ref_id, float('nan')))} | "
                f"{number_text(review.current.object_rates.get(ref_id, float('nan')))} |"
            )
    else:
        lines.append("| similarity, matching rate | … | … |")
    lines.append(f"\n<sub>area: {ref_area} px reference, {tgt_area} px target</sub>")
    return ObjectDetails("\n".join(lines), crops, histograms, plot)


def _target_mask(run: Any, ref_mask: np.ndarray, assoc: Any) -> np.ndarray:
    """The object's region in the target: its target object, or (template match without a
    target object) the reference footprint moved by D̄m, ``target(x - d) <-> reference(x)``."""
    if assoc is None:
        return np.zeros_like(ref_mask)
    if assoc.tgt_id > 0:
        return run.objects.target == assoc.tgt_id
    shift = int(round(assoc.modal_disparity))
    moved = np.zeros_like(ref_mask)
    width = ref_mask.shape[1]
    if abs(shift) < width:
        if shift >= 0:
            moved[:, : width - shift] = ref_mask[:, shift:]
        else:
            moved[:, -shift:] = ref_mask[:, : width + shift]
    return moved


def _mean(image: np.ndarray, mask: np.ndarray, decimals: int) -> str:
    """Mean of the finite pixels of ``image`` in ``mask``, with ``decimals`` decimals."""
    values = image[mask]
    values = values[np.isfinite(values)]
    return fixed_text(float(values.mean()), decimals) if values.size else "·"
