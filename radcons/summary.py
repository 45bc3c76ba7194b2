"""Writing a finished run: the consistent pair folder and ``summary.json``."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from radcons.io import atomic_write_bytes, save_pair
from radcons.pipeline import Run, to_output_dtype

__all__ = ["run_summary", "write_outputs", "json_safe"]


def json_safe(value: Any) -> Any:
    """Convert numpy scalars, tuples and non-finite floats into plain JSON values.

    Arrays are left out (``None``): summaries hold numbers and records, not rasters.
    """
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items() if not isinstance(v, np.ndarray)}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, np.ndarray):
        return None
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def run_summary(run: Run) -> dict[str, Any]:
    """Return the plain-dict summary of a run: objects, associations, fits, timings, params."""
    pair = run.pair
    summary: dict[str, Any] = {
        "pair": pair.name,
        "shape": list(run.working_pair.shape),
        "dtype": str(pair.reference.data.dtype),
        "stages": run.image_stages,
        "timings_s": {name: round(seconds, 4) for name, seconds in run.timings.items()},
        "params": run.params.to_dict(),
    }
    rect = run.rectification
    if rect is not None:
        summary["rectification"] = {
            "matches": rect.n_matches,
            "inliers": rect.n_inliers,
            "residual_vertical_parallax_median_px": rect.residual_parallax_median,
            "residual_vertical_parallax_p90_px": rect.residual_parallax_p90,
            "disparity_range_px": list(rect.disparity_range),
            "reference_transform": rect.ref_transform.tolist(),
            "target_transform": rect.tgt_transform.tolist(),
        }
    if run.objects is not None:
        summary["objects"] = {
            "source": run.objects.source,
            "reference_count": int(len(np.unique(run.objects.reference)) - (run.objects.reference == 0).any()),
            "target_count": int(len(np.unique(run.objects.target)) - (run.objects.target == 0).any()),
        }
    if run.association is not None:
        summary["matches"] = len(run.association.matches)
        summary["associations"] = [
            {
                "ref_id": obj.ref_id,
                "tgt_id": obj.tgt_id,
                "method": obj.method,
                "matches": obj.n_matches,
                "invariant_points": obj.n_invariant,
                "modal_disparity": obj.modal_disparity,
                "score": obj.score,
            }
            for obj in run.association.objects
        ]
        summary["unassociated_reference_objects"] = list(run.association.unassociated_ref)
    if run.fits:
        summary["fits"] = [
            {
                "ref_id": fit.ref_id,
                "tgt_id": fit.tgt_id,
                "gain": fit.gain,
                "offset": fit.offset,
                "points": fit.n_points,
                "clipped_points": fit.clipped,
                "applied": fit.applied,
                "note": fit.note,
            }
            for fit in run.fits
        ]
    for name in ("global", "smoothness"):
        if name in run.results:
            summary[name] = dict(run.results[name].info)
    return json_safe(summary)


def write_outputs(run: Run, out: str | Path, *, original_geometry: bool = False) -> Path:
    """Write the consistent pair (input dtype and georeferencing) and ``summary.json``.

    The input's ground truth is carried over. Every file is written atomically and the
    manifest last, so an interrupted write leaves no half file and no manifest naming one.

    Parameters
    ----------
    run : Run
    out : str or Path
        Output pair folder.
    original_geometry : bool
        For a pair the pipeline rectified: map the consistent images back to the input's
        own geometry (its georeferencing then applies again). Default: write the rectified
        pair, ready for dense matching, without georeferencing.

    Returns
    -------
    Path
        The written manifest.
    """
    out = Path(out)
    pair = run.working_pair
    reference, target = run.images()
    if original_geometry and run.rectification is not None:
        pair = run.pair
        reference = run.rectification.to_original(reference, "reference")
        target = run.rectification.to_original(target, "target")
    consistent = replace(
        pair,
        reference=replace(pair.reference, data=to_output_dtype(reference, pair.reference.data.dtype, pair.reference.nodata), path=None),
        target=replace(pair.target, data=to_output_dtype(target, pair.target.data.dtype, pair.target.nodata), path=None),
        metadata={**pair.metadata, "processed_by": "radcons", "final_stage": run.final_stage},
    )
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(out / "summary.json", json.dumps(run_summary(run), indent=2).encode("utf-8"))
    return save_pair(consistent, out)
