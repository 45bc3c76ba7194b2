"""The report's pairs and the evaluation of every method on them.

* synthetic pairs of :mod:`demo_data_gen` (every scenario of
  :data:`~.common.SCENARIOS` and seed) with their exact ground truth;
* real stereo pairs with real ground truth whose target gets the simulated date / sensor
  difference of ``benchmarks/bench_baselines.py``;
* the real, epipolar-rectified Pleiades pair over La Reunion, measured against the
  left-right checked SGBM disparity of its clean version.
"""

from __future__ import annotations

import os
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import numpy as np

from bench_baselines import DEGRADATION
from demo_data_gen import generate
from radcons.evaluate.compare import Comparison, Evaluation, evaluate_matchers, evaluate_methods
from radcons.evaluate.matching import MatcherParams, dense_disparity, disparity_range_from_matches
from radcons.evaluate.simulate import Degradation, degrade
from radcons.evaluate.truth_pairs import labels_to_target, load_cones, load_motorcycle, objects_from_disparity
from radcons.io import Pair, Raster, read_raster
from radcons.params import Params
from radcons.pipeline import Pipeline
from radcons.stages.association.run import match_features
from radcons.workflow import evaluate_pair_matchers

from .common import ABLATION, COMPARED, REPO, SCENARIOS, Entry, Settings, log

# ----------------------------------------------------------------------------- pairs


def shared_data_dir(explicit: str | None) -> Path:
    """The shared data folder: ``--data``, else ``$RADCONS_DATA``, else beside the checkout.

    Parameters
    ----------
    explicit : str or None
        The folder given on the command line, if any.

    Returns
    -------
    Path
        The shared data folder (not checked to exist).
    """
    if explicit:
        return Path(explicit)
    return Path(os.environ.get("RADCONS_DATA") or REPO.parent / "shared" / "data")


def degraded_target(pair: Pair, degradation: Degradation) -> tuple[Pair, dict]:
    """The pair with its target degraded; also the share of the saturated object clipped.

    Parameters
    ----------
    pair : Pair
        The clean pair, with target objects.
    degradation : Degradation
        The simulated date / sensor difference applied to the target.

    Returns
    -------
    degraded : Pair
        The pair in float32 with the degraded target, under the same name.
    info : dict
        ``saturated_object`` (its label) and ``saturated_share_clipped`` (share of its
        target pixels at the clean target's maximum; NaN when the object is absent).
    """
    target = pair.target.as_float32()
    out = degrade(target, degradation, labels=pair.target_objects)
    high = float(np.nanmax(target))
    region = pair.target_objects == degradation.saturate_label
    clipped = float(np.mean(out[region] >= high)) if region.any() else float("nan")
    degraded = replace(pair.with_images(pair.reference.as_float32(), out), name=pair.name)
    return degraded, {"saturated_object": degradation.saturate_label, "saturated_share_clipped": clipped}


def lr_checked_disparity(
    reference: np.ndarray, target: np.ndarray, matcher: MatcherParams, search: tuple[float, float]
) -> tuple[np.ndarray, dict]:
    """SGBM disparity of the reference, kept where the target's own disparity agrees (< 1 px).

    The target's disparity is computed by matching the mirrored target against the mirrored
    reference (mirroring turns ``target(x') <-> reference(x' + d)`` into the project's
    convention); a reference pixel ``x`` is kept when the target's disparity at
    ``round(x - d)`` is within 1 px of ``d``.

    Parameters
    ----------
    reference, target : numpy.ndarray
        The two images of the pair, same shape.
    matcher : MatcherParams
        The dense matcher's settings.
    search : tuple of float
        Disparity search range (low, high) in pixels.

    Returns
    -------
    disparity : numpy.ndarray
        float32 disparity of the reference, NaN where missing or not confirmed.
    stats : dict
        ``search_range``, ``left_valid_share`` (share matched) and ``kept_share`` (share
        that passed the check).
    """
    left = dense_disparity(reference, target, matcher, search)
    right = dense_disparity(target[:, ::-1], reference[:, ::-1], matcher, search)[:, ::-1]
    rows, cols = np.nonzero(np.isfinite(left))
    match = np.rint(cols - left[rows, cols]).astype(np.intp)
    inside = (match >= 0) & (match < left.shape[1])
    rows, cols, match = rows[inside], cols[inside], match[inside]
    agree = np.abs(right[rows, match] - left[rows, cols]) <= 1.0
    out = np.full(left.shape, np.nan, np.float32)
    out[rows[agree], cols[agree]] = left[rows[agree], cols[agree]]
    stats = {
        "search_range": [float(search[0]), float(search[1])],
        "left_valid_share": float(np.isfinite(left).mean()),
        "kept_share": float(np.isfinite(out).mean()),
    }
    return out, stats


def pleiades_pair(folder: Path, crop: int | None, matcher: MatcherParams) -> tuple[Pair, Pair, dict]:
    """The clean Pleiades pair with its reference disparity and objects, and its degraded copy.

    Parameters
    ----------
    folder : Path
        Folder holding the rectified images ``a.tif`` (reference) and ``b.tif`` (target).
    crop : int or None
        Side of the central square crop, or None for the whole images.
    matcher : MatcherParams
        The dense matcher's settings.

    Returns
    -------
    clean : Pair
        The pair as it is, with the left-right checked disparity and its objects.
    degraded : Pair
        The same pair with the target degraded (offset and noise scaled to its range).
    stats : dict
        The disparity statistics of :func:`lr_checked_disparity`, the saturation info of
        :func:`degraded_target`, the scaled ``degradation`` and the ``percentile_span``.
    """
    reference = read_raster(folder / "a.tif").data.astype(np.float32)
    target = read_raster(folder / "b.tif").data.astype(np.float32)
    if crop is not None:
        y0 = (reference.shape[0] - crop) // 2
        x0 = (reference.shape[1] - crop) // 2
        reference = reference[y0 : y0 + crop, x0 : x0 + crop].copy()
        target = target[y0 : y0 + crop, x0 : x0 + crop].copy()
    search = disparity_range_from_matches(match_features(reference, target))
    disparity, stats = lr_checked_disparity(reference, target, matcher, search)
    labels = objects_from_disparity(disparity)
    clean = Pair(
        Raster(reference), Raster(target), disparity=disparity, reference_objects=labels,
        target_objects=labels_to_target(labels, disparity), name="pleiades-reunion",
        source=folder,
    )
    # offset and noise are given for a 0..255 image: scale them to the target's 1-99 %
    # percentile span, where nearly all of its pixels lie (a few bright outliers stretch
    # its minimum-maximum range eightfold)
    low, high = np.nanpercentile(target, [1, 99])
    scale = float(high - low) / 255.0
    degradation = replace(
        DEGRADATION, offset=DEGRADATION.offset * scale, noise_sigma=DEGRADATION.noise_sigma * scale
    )
    degraded, info = degraded_target(clean, degradation)
    stats.update(info, degradation=asdict(degradation), percentile_span=[float(low), float(high)])
    return clean, degraded, stats


def undegraded_result(clean: Pair, comparison: Comparison, degraded: Pair, matcher: Any) -> Comparison:
    """The comparison with a first column for the clean pair, measured the same way.

    Parameters
    ----------
    clean : Pair
        The pair before its target was degraded.
    comparison : Comparison
        The methods' comparison on the degraded pair.
    degraded : Pair
        The degraded pair (its ground truth and objects measure the clean images).
    matcher : MatcherParams or CensusParams
        The dense matcher of ``comparison``.

    Returns
    -------
    Comparison
        ``comparison`` with an ``undegraded`` method first.
    """
    images = {"undegraded": (clean.reference.as_float32(), clean.target.as_float32())}
    extra = evaluate_methods(
        degraded, images, comparison.object_pairs, matcher, disparity_range=comparison.disparity_range
    )
    return replace(comparison, methods=(*extra.methods, *comparison.methods))


def undegraded_results(clean: Pair, evaluation: Evaluation, degraded: Pair) -> dict[str, Comparison]:
    """:func:`undegraded_result` for every matcher of ``evaluation``: matcher name -> comparison."""
    return {
        name: undegraded_result(clean, comparison, degraded, comparison.matcher)
        for name, comparison in evaluation.comparisons.items()
    }


def make_entry(key: str, title: str, pair: Pair, comparisons: dict[str, Comparison], *rest: Any) -> Entry:
    """An :class:`Entry` whose sections read the first matcher's comparison."""
    return Entry(key, title, pair, next(iter(comparisons.values())), *rest, comparisons=comparisons)


# ----------------------------------------------------------------------------- evaluation


def run_demo(settings: Settings, params: Params) -> tuple[dict[str, list[Entry]], list[Entry]]:
    """Every scenario and seed; also the same-date, same-sensor pairs (original only).

    Parameters
    ----------
    settings : Settings
        The run's image size, seeds and matcher.
    params : Params
        Parameters of ours.

    Returns
    -------
    entries : dict of str to list of Entry
        Per scenario of :data:`~.common.SCENARIOS`, one entry per seed, with every method
        of :data:`~.common.COMPARED` and every ablation stage.
    ceiling : list of Entry
        Per seed, the original pair of scenario ``none``.
    """
    pipeline = Pipeline(params)
    entries: dict[str, list[Entry]] = {}
    for scenario in SCENARIOS:
        methods = [*COMPARED, *ABLATION[1:-1]]
        entries[scenario] = []
        for seed in settings.seeds:
            log(f"demo {scenario} seed {seed} ...")
            pair = generate(settings.size, seed, scenario)
            run, evaluation = evaluate_pair_matchers(pair, methods, params, settings.matchers, pipeline=pipeline)
            meta = pair.metadata
            built = f"`generate({settings.size}, {seed}, {scenario!r})`"
            entries[scenario].append(
                make_entry(
                    f"{scenario}-{seed}", f"{scenario}, seed {seed}", pair, evaluation.comparisons,
                    dict(run.timings), built, "the generator's building labels", {"metadata": meta},
                )
            )
    ceiling = []
    for seed in settings.seeds:
        log(f"demo none seed {seed} ...")
        pair = generate(settings.size, seed, "none")
        images = {"original": (pair.reference.as_float32(), pair.target.as_float32())}
        evaluation = evaluate_matchers(pair, images, matchers=settings.matchers)
        ceiling.append(
            make_entry(
                f"none-{seed}", f"none, seed {seed}", pair, evaluation.comparisons, {}, "", "", {"metadata": pair.metadata}
            )
        )
    return entries, ceiling


def run_truth_pair(clean: Pair, settings: Settings, params: Params, built: str) -> Entry:
    """A real pair with ground truth, its target degraded by :data:`DEGRADATION`.

    Parameters
    ----------
    clean : Pair
        The real pair with its ground-truth disparity and objects.
    settings : Settings
        The run's matcher.
    params : Params
        Parameters of ours.
    built : str
        How the pair was made, for the report (markdown).

    Returns
    -------
    Entry
        Every method, the ablation stages and ``undegraded`` on the degraded pair.
    """
    log(f"{clean.name} ...")
    pair, info = degraded_target(clean, DEGRADATION)
    run, evaluation = evaluate_pair_matchers(pair, [*COMPARED, *ABLATION[1:-1]], params, settings.matchers)
    comparisons = undegraded_results(clean, evaluation, pair)
    objects = "connected 4 px disparity layers of the ground truth (>= 300 px, 12 largest), carried to the target along it"
    return make_entry(clean.name, clean.name, pair, comparisons, dict(run.timings), built, objects, info)


def run_pleiades(folder: Path, settings: Settings, params: Params) -> Entry:
    """The Pleiades pair against the left-right checked disparity of its clean version.

    Parameters
    ----------
    folder : Path
        Folder of the rectified pair (``a.tif``, ``b.tif``).
    settings : Settings
        The run's matcher and crop.
    params : Params
        Parameters of ours.

    Returns
    -------
    Entry
        Every method, the ablation stages and ``undegraded`` on the degraded pair; its
        ``extra`` holds the statistics of :func:`pleiades_pair`.
    """
    log("pleiades-reunion ...")
    clean, pair, info = pleiades_pair(folder, settings.pleiades_crop, settings.matcher)
    run, evaluation = evaluate_pair_matchers(pair, [*COMPARED, *ABLATION[1:-1]], params, settings.matchers)
    comparisons = undegraded_results(clean, evaluation, pair)
    shape = f"{clean.shape[1]} x {clean.shape[0]}"
    built = f"`{folder.name}/a.tif`, `b.tif` ({shape}" + (", central crop)" if settings.pleiades_crop else ")")
    objects = (
        "connected 4 px layers of the reference disparity (>= 300 px, 12 largest), carried to the target along it"
    )
    return make_entry("pleiades-reunion", "pleiades-reunion", pair, comparisons, dict(run.timings), built, objects, info)


def run_real_pairs(settings: Settings, params: Params) -> tuple[list[Entry], list[str], Entry | None, str | None]:
    """Every real pair: Cones and Motorcycle with ground truth, then the Pleiades pair.

    Cones and the Pleiades pair come from the shared data folder and are skipped, with a
    note, where it does not hold them; Motorcycle comes with scikit-image.

    Parameters
    ----------
    settings : Settings
        The run's data folder, matcher, Motorcycle reduction and Pleiades crop.
    params : Params
        Parameters of ours.

    Returns
    -------
    truth_entries : list of Entry
        The pairs with real ground truth (Cones when present, Motorcycle).
    skipped : list of str
        A note per pair with ground truth that was not found.
    pleiades : Entry or None
        The Pleiades pair, None when it was not found.
    pleiades_note : str or None
        Why the Pleiades pair was skipped, None when it was run.
    """
    truth_entries, skipped = [], []
    cones_dir = settings.data / "middlebury_cones"
    if cones_dir.is_dir():
        truth_entries.append(run_truth_pair(
            load_cones(cones_dir), settings, params, f"`{cones_dir.name}/left.tif`, `right.tif`, `disp_left_gt.tif`"
        ))
    else:
        skipped.append(f"Cones skipped: {cones_dir} not found (set --data or $RADCONS_DATA).")
    truth_entries.append(run_truth_pair(
        load_motorcycle(settings.motorcycle_downsample), settings, params,
        f"`skimage.data.stereo_motorcycle()`, grey, reduced {settings.motorcycle_downsample}x",
    ))
    pleiades_dir = settings.data / "pleiades_reunion_rectified"
    pleiades, pleiades_note = None, None
    if pleiades_dir.is_dir():
        pleiades = run_pleiades(pleiades_dir, settings, params)
    else:
        pleiades_note = f"Skipped: {pleiades_dir} not found (set --data or $RADCONS_DATA)."
    return truth_entries, skipped, pleiades, pleiades_note
