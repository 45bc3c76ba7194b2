"""Writing a finished run: the consistent pair folder and ``summary.json``."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from radcons.errors import ParamsError
from radcons.evaluate.measure import as_written
from radcons.io import MANIFEST, atomic_write_bytes, save_pair, staged_folder
from radcons.noise import noise_notice, noise_ratio
from radcons.pipeline import Run, to_output_dtype

__all__ = ["run_summary", "run_noise_notice", "written_noise_ratio", "write_outputs", "output_images", "json_safe", "OUTPUT_DTYPES"]


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
    """Return the plain-dict summary of a run: objects, associations, fits, timings, params.

    ``noise`` holds the noise ratio of the input pair (``ratio_original``) and of the
    consistent one (``ratio``), and ``notice``: one sentence naming the option that evens
    the noise out when ``ratio`` is above 1.5 (:func:`radcons.noise.noise_notice`), else None.
    """
    pair = run.pair
    summary: dict[str, Any] = {
        "pair": pair.name,
        "shape": list(run.working_pair.shape),
        "dtype": str(pair.reference.data.dtype),
        "bands": {"reference": pair.reference.bands, "target": pair.target.bands},
        "rectified_input": bool(pair.rectified),
        "geometry": pair.metadata.get("geometry", "given"),
        "rows": pair.metadata.get("rows", "not checked"),
        "stages": run.image_stages,
        "timings_s": {name: round(seconds, 4) for name, seconds in run.timings.items()},
        "params": run.params.to_dict(),
    }
    rect = run.rectification
    if rect is not None:
        summary["rectification"] = {
            "method": rect.method,
            "reason": rect.reason,
            "matches": rect.n_matches,
            "inliers": rect.n_inliers,
            "residual_vertical_parallax_median_px": rect.residual_parallax_median,
            "residual_vertical_parallax_p90_px": rect.residual_parallax_p90,
            "disparity_range_px": list(rect.disparity_range),
        }
        if rect.method == "rpc":
            summary["rectification"].update(
                rpc_vertical_offset_px=rect.rpc_row_offset,
                grid_altitude_m=rect.altitude,
                metres_per_disparity_px=rect.metres_per_pixel,
                ground_sample_distance_m=rect.gsd_m,
                zero_disparity_altitude_m=rect.zero_disparity_altitude,
                pointing_correction=list(rect.pointing_correction),
            )
        else:
            summary["rectification"].update(
                orientation=rect.orientation,
                reference_transform=rect.ref_transform.tolist(),
                target_transform=rect.tgt_transform.tolist(),
            )
    if run.objects is not None:
        summary["objects"] = {
            "source": run.objects.source,
            "reference_count": int(len(np.unique(run.objects.reference)) - (run.objects.reference == 0).any()),
            "target_count": int(len(np.unique(run.objects.target)) - (run.objects.target == 0).any()),
            **_objects_method(run.objects),
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
                **({"evidence": obj.evidence} if hasattr(obj, "evidence") else {}),
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
    if "refine" in run.results:
        summary["refine"] = {key: value for key, value in run.results["refine"].info.items() if key != "fits"}
    final = written_noise_ratio(run)
    summary["noise"] = {
        "ratio_original": noise_ratio(*run.images("original")),
        "ratio": final,
        "notice": run_noise_notice(run, final),
    }
    return json_safe(summary)


def written_noise_ratio(run: Run) -> float:
    """The noise ratio (:func:`radcons.noise.noise_ratio`) of the run's final images as the
    output files hold them (:func:`radcons.evaluate.measure.as_written`): rounding a
    denoised integer image to whole levels adds noise of its own."""
    return noise_ratio(*as_written(run.working_pair, *run.images()))


def run_noise_notice(run: Run, ratio: float) -> str | None:
    """The notice of a run whose final images have the noise ratio ``ratio``
    (:func:`radcons.noise.noise_notice`), None when the ratio is at most 1.5."""
    sharpness = run.results["sharpness"].info if "sharpness" in run.results else None
    return noise_notice(ratio, run.params, sharpness, run.image_stages)


def _objects_method(objects: Any) -> dict[str, Any]:
    """How segmented objects were found: method, note, and what the height method measured."""
    if not hasattr(objects, "method"):
        return {}
    info: dict[str, Any] = {"method": objects.method, "note": objects.note}
    height = objects.height
    if height is not None:
        info.update(
            height_unit=height.unit,
            census_factor=height.factor,
            census_step=round(height.step, 3),
            disparity_range_px=list(height.disparity_range),
            consistent_share=round(height.valid_share, 4),
            trees_left_out=objects.trees,
            mismatched_left_out=objects.mismatched,
            not_matched_back=list(objects.unmatched),
            clipped_by_outline=list(objects.by_outline),
        )
    return info


def _object_properties(run: Run) -> dict[int, dict[str, Any]]:
    """GeoJSON properties of each reference object: association, D̄m, fit, similarity."""
    props: dict[int, dict[str, Any]] = {}
    if run.association is not None:
        for obj in run.association.objects:
            props[obj.ref_id] = {
                "associated": obj.tgt_id,
                "association": obj.method,
                "modal_disparity": obj.modal_disparity,
                "score": obj.score,
                **({"evidence": obj.evidence} if hasattr(obj, "evidence") else {}),
            }
    for fit in run.fits:
        props.setdefault(fit.ref_id, {}).update(
            fit_gain=fit.gain, fit_offset=fit.offset, fit_applied=fit.applied, fit_note=fit.note
        )
    similarity = _similarity(run)
    for ref_id, value in similarity.items():
        props.setdefault(ref_id, {})["similarity"] = value
    return {ref_id: json_safe(values) for ref_id, values in props.items()}


def _similarity(run: Run) -> dict[int, float]:
    """Eq 20 similarity of each associated object in the final images (empty if none)."""
    if run.association is None or not run.association.objects or run.objects is None:
        return {}
    from radcons.evaluate.similarity import object_similarities

    reference, target = run.images()
    present_ref, present_tgt = set(np.unique(run.objects.reference).tolist()), set(np.unique(run.objects.target).tolist())
    pairs = [
        (obj.ref_id, obj.tgt_id) for obj in run.association.objects
        if obj.tgt_id > 0 and obj.ref_id in present_ref and obj.tgt_id in present_tgt
    ]
    values = object_similarities(reference, target, run.objects.reference, run.objects.target, pairs)
    return {int(k): float(v) for k, v in values.items()}


def _write_objects(run: Run, staging: Path, pair: Any) -> dict[str, str]:
    """Write the objects as GeoJSON polygons beside the pair; the file names written."""
    from radcons.io.geojson import write_geojson

    props = _object_properties(run)
    target_props = {
        obj.tgt_id: {**props.get(obj.ref_id, {}), "associated": obj.ref_id}
        for obj in (run.association.objects if run.association is not None else ())
        if obj.tgt_id > 0
    }
    write_geojson(staging / "reference_objects.geojson", run.objects.reference, props, pair.reference)
    write_geojson(staging / "target_objects.geojson", run.objects.target, target_props, pair.target)
    return {"reference": "reference_objects.geojson", "target": "target_objects.geojson"}


#: How a pair of two bit depths is written: each image in its own dtype and value range
#: (the target's consistent image mapped linearly into the target's own range), or both
#: in the wider dtype, the target then in the reference's range.
OUTPUT_DTYPES: tuple[str, ...] = ("own", "common")


def output_images(run: Run, reference: np.ndarray, target: np.ndarray, pair: Any, output_dtype: str = "own") -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """Convert the consistent float32 images to the dtypes they are written in.

    The stages compute both images in the reference's value range. When the two inputs
    have the same dtype, each keeps it. When they differ (say a uint16 reference and a
    uint8 target) and ``output_dtype`` is ``"own"``, the target is mapped linearly from
    the reference's input range ``[min, max]`` onto the target's input range before it is
    converted, so each output fills its own dtype as its input did; with ``"common"`` both
    are written in the wider dtype (:func:`numpy.promote_types`) on the reference's range.

    Returns
    -------
    reference, target : ndarray
        In their output dtypes.
    info : dict
        What was done, for the summary.
    """
    if output_dtype not in OUTPUT_DTYPES:
        raise ParamsError(f"output dtype must be one of {OUTPUT_DTYPES}, got {output_dtype!r}")
    ref_dtype, tgt_dtype = pair.reference.data.dtype, pair.target.data.dtype
    info: dict[str, Any] = {"reference": str(ref_dtype), "target": str(tgt_dtype), "mapping": "none"}
    if ref_dtype != tgt_dtype:
        if output_dtype == "common":
            ref_dtype = tgt_dtype = np.promote_types(ref_dtype, tgt_dtype)
            info.update(reference=str(ref_dtype), target=str(tgt_dtype), mapping="common dtype, reference range")
        else:
            original_ref, original_tgt = run.images("original")
            lo_r, hi_r = float(np.nanmin(original_ref)), float(np.nanmax(original_ref))
            lo_t, hi_t = float(np.nanmin(original_tgt)), float(np.nanmax(original_tgt))
            scale = (hi_t - lo_t) / (hi_r - lo_r) if hi_r > lo_r else 1.0
            target = ((target - lo_r) * scale + lo_t).astype(np.float32)
            info["mapping"] = f"target mapped from the reference's range [{lo_r:g}, {hi_r:g}] to its own [{lo_t:g}, {hi_t:g}]"
    return (
        to_output_dtype(reference, ref_dtype, pair.reference.nodata),
        to_output_dtype(target, tgt_dtype, pair.target.nodata),
        info,
    )


def write_outputs(run: Run, out: str | Path, *, original_geometry: bool = False, output_dtype: str = "own") -> Path:
    """Write the consistent pair (input dtypes and georeferencing) and ``summary.json``.

    The input's ground truth is carried over. The folder is written whole or not at all:
    its new content is assembled beside it and swapped in at the end
    (:func:`radcons.io.staged_folder`), so an interrupted run leaves the previous result.

    Parameters
    ----------
    run : Run
    out : str or Path
        Output pair folder.
    original_geometry : bool
        For a pair the pipeline rectified: map the consistent images back to the input's
        own geometry (its georeferencing then applies again). Default: write the rectified
        pair, ready for dense matching, without georeferencing.
    output_dtype : str
        ``"own"`` or ``"common"``, for a pair of two dtypes (see :func:`output_images`).

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
    reference, target, dtypes = output_images(run, reference, target, pair, output_dtype)
    consistent = replace(
        pair,
        reference=replace(pair.reference, data=reference, path=None),
        target=replace(pair.target, data=target, path=None),
        metadata={**pair.metadata, "processed_by": "radcons", "final_stage": run.final_stage},
    )
    objects_here = run.objects is not None and (not original_geometry or run.rectification is None)
    if objects_here:
        consistent = replace(consistent, reference_objects=run.objects.reference, target_objects=run.objects.target)
    summary = run_summary(run)
    summary["output_dtypes"] = dtypes
    with staged_folder(out) as staging:
        if objects_here:
            summary["objects"]["polygons"] = _write_objects(run, staging, consistent)
        atomic_write_bytes(staging / "summary.json", json.dumps(summary, indent=2).encode("utf-8"))
        save_pair(consistent, staging)
    return out / MANIFEST
