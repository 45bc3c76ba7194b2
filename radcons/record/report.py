"""The markdown summary of a recording: what ran, how long, with which parameters, per object."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import tomli_w

from radcons.evaluate.compare import Comparison
from radcons.pipeline import Run
from radcons.record.layout import ERROR_SPAN
from radcons.summary import run_summary

if TYPE_CHECKING:
    from radcons.record.stage_review import StageReview

__all__ = ["final_method", "markdown_summary"]


_LEGEND = (
    "Move the time cursor of the `stage` timeline to step through the stages; both images of "
    "a stage share one grey range, from 0 to the brighter image's maximum.",
    "Objects: one colour per associated pair, the same in both images; grey objects have no "
    "partner. Lines join SIFT matches; the bright ones are the invariant points (eq 12).",
    "Fits: invariant points (target grey →, reference grey ↑; larger = larger weight τ, eq 11) "
    "and each object's line (eq 8); grey: not applied.",
    "Disparity: colours span the searched range; magenta = no match, grey = no ground truth. "
    f"The error |d - d_gt| spans 0 (dark) to {ERROR_SPAN:g}x the correct-match threshold (yellow).",
    "Bars stand at the reference object ids, one bar per method.",
    "Stage disparity (beside the images): the dense disparity of the stage under the cursor, "
    "its error map below it, and the rates per stage as curves.",
)


def final_method(comparison: Comparison) -> str:
    """The method whose numbers label the objects: ``ours`` when compared, else the last."""
    names = [m.name for m in comparison.methods]
    return "ours" if "ours" in names else names[-1]


def _number(value: Any, digits: int = 3) -> str:
    """A table cell: numbers rounded, booleans as yes/no, missing or non-finite as "-"."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return f"{value:.{digits}f}" if math.isfinite(value) else "-"
    return "-" if value is None else str(value)


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(row) + " |" for row in rows]


def _object_rows(summary: dict, comparison: Comparison | None) -> tuple[list[str], list[list[str]]]:
    fits = {fit["ref_id"]: fit for fit in summary.get("fits", [])}
    header = ["object", "target", "link", "matches", "invariant", "D̄m px", "gain λ", "offset ζ", "fit applied"]
    methods = list(comparison.methods) if comparison is not None else []
    header += [f"C {m.name}" for m in methods]
    if comparison is not None and comparison.has_ground_truth:
        header += [f"rate {m.name}" for m in methods]
    rows = []
    for link in summary.get("associations", []):
        fit = fits.get(link["ref_id"], {})
        row = [
            str(link["ref_id"]),
            str(link["tgt_id"]),
            link["method"],
            _number(link["matches"]),
            _number(link["invariant_points"]),
            _number(link["modal_disparity"], 2),
            _number(fit.get("gain")),
            _number(fit.get("offset"), 2),
            _number(fit.get("applied")),
        ]
        row += [_number(m.similarity.get(link["ref_id"])) for m in methods]
        if comparison is not None and comparison.has_ground_truth:
            row += [_number(m.object_rates.get(link["ref_id"])) for m in methods]
        rows.append(row)
    return header, rows


def markdown_summary(
    run: Run, comparison: Comparison | None = None, preview_factor: int = 1, stage_review: StageReview | None = None
) -> str:
    """Markdown report of a run (and of its comparison of methods, when given).

    Parameters
    ----------
    run : Run
        A finished pipeline run.
    comparison : Comparison, optional
        Measurements of the compared methods on the same pair.
    preview_factor : int
        Reduction factor of the logged images (1 = full resolution), stated in the text.
    stage_review : StageReview, optional
        Every image stage's dense disparity: its rates per stage.

    Returns
    -------
    str
    """
    summary = run_summary(run)
    rows, cols = summary["shape"]
    lines = [f"# {summary['pair']}", ""]
    facts = [f"{cols} x {rows} px, {summary['dtype']}", "stages: " + " → ".join(summary["stages"])]
    if preview_factor > 1:
        facts.append(f"images logged as previews reduced {preview_factor}x")
    if "objects" in summary:
        objects = summary["objects"]
        facts.append(
            f"objects ({objects['source']}): {objects['reference_count']} reference, "
            f"{objects['target_count']} target"
        )
    if "matches" in summary:
        facts.append(f"{summary['matches']} SIFT matches, {len(summary['associations'])} object pairs")
    lines += [f"- {fact}" for fact in facts]

    if comparison is not None:
        lines += ["", f"## Methods (dense matching, |d - d_gt| < {comparison.threshold:g} px is correct)", ""]
        header = ["method", "mean C", "mean rate (objects)", "rate (all pixels)", "noise ratio", "matching s"]
        lines += _table(
            header,
            [
                [
                    m.name,
                    _number(m.mean_similarity),
                    _number(m.mean_object_rate),
                    _number(m.correct_rate),
                    _number(m.noise_ratio, 2),
                    _number(m.seconds.get("matching"), 2),
                ]
                for m in comparison.methods
            ],
        )

    if stage_review is not None:
        lines += ["", f"## Dense matching of each stage ({stage_review.matcher})", ""]
        if stage_review.disparity_range is None:
            lines.append(stage_review.note + ".")
        else:
            low, high = stage_review.disparity_range
            lines.append(f"Disparities {low:g} to {high:g} px, {stage_review.seconds:.2f} s for all stages.")
            if stage_review.truth is not None:
                lines += [""] + _table(
                    ["stage", f"rate (all pixels, < {stage_review.threshold:g} px)", "mean rate (objects)"],
                    [[s.stage, _number(s.rate_all), _number(s.rate_objects)] for s in stage_review.stages],
                )

    header, object_rows = _object_rows(summary, comparison)
    if object_rows:
        lines += ["", "## Objects", ""] + _table(header, object_rows)
        if summary.get("unassociated_reference_objects"):
            ids = ", ".join(str(i) for i in summary["unassociated_reference_objects"])
            lines += ["", f"Reference objects without a partner: {ids}."]

    lines += ["", "## Timings", ""]
    timings = summary["timings_s"].items()
    lines += _table(
        ["stage", "seconds", "cached"],
        [[name, _number(seconds), _number(bool(run.cached.get(name)))] for name, seconds in timings],
    )
    values = [
        (stage, key, value)
        for stage in ("rectification", "global", "smoothness")
        for key, value in summary.get(stage, {}).items()
        if not isinstance(value, (list, dict))
    ]
    if values:
        lines += ["", "## Stage values", ""]
        lines += _table(["stage", "value", ""], [[stage, key, _number(value, 4)] for stage, key, value in values])
    lines += ["", "## Reading the views", ""] + [f"- {line}" for line in _LEGEND]
    lines += ["", "## Parameters", ""] + _parameters(run.params.to_dict()) + [""]
    return "\n".join(lines)


def _parameters(tables: dict[str, Any]) -> list[str]:
    """The parameters as the TOML block ``radcons process --params`` accepts."""
    return ["```toml", tomli_w.dumps(tables).strip(), "```"]
