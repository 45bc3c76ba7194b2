"""The stage pipeline: order, caching by inputs and params, switches, NaN handling."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from demo_data_gen import generate
from radcons.io import Raster
from radcons.params import STAGES, Params
from radcons.pipeline import IMAGE_STAGES, Pipeline, to_output_dtype

FAST = Params().with_stage("smoothness", iterations=1)


@pytest.fixture(scope="module")
def pair():
    return generate(size=160, seed=3, scenario="mixed")


def test_runs_every_stage_in_order(pair):
    pipeline = Pipeline(FAST)
    run = pipeline.run(pair)
    assert list(run.timings) == list(STAGES)
    assert run.image_stages == list(IMAGE_STAGES)
    for stage in run.image_stages:
        ref, tgt = run.images(stage)
        assert ref.shape == tgt.shape == pair.shape and ref.dtype == np.float32
    assert run.objects.source == "user"  # the demo pair carries label rasters; they win
    assert len(run.association.objects) > 0
    assert set(run.results["global"].info) >= {"A", "lambda_reference", "lambda_target"}
    assert all(count == 1 for count in pipeline.calls.values())


@pytest.mark.parametrize("preset", ["paper", "radcons"])
def test_a_preset_gives_the_same_images_bit_for_bit_run_after_run(pair, preset):
    params = Params.from_preset(preset).with_stage("smoothness", iterations=2)
    runs = [Pipeline(params).run(pair) for _ in range(3)]
    for stage in runs[0].image_stages:
        for run in runs[1:]:
            for first, again in zip(runs[0].images(stage), run.images(stage)):
                np.testing.assert_array_equal(again, first, err_msg=f"{preset}: {stage} differs between runs")


def test_changing_a_parameter_recomputes_that_stage_and_later_only(pair):
    pipeline = Pipeline(FAST)
    pipeline.run(pair)
    pipeline.run(pair)  # same params: everything from the cache
    assert all(pipeline.calls[name] == 1 for name in STAGES)

    run = pipeline.run(pair, FAST.with_stage("uniformity", mu=0.2))
    assert {name: pipeline.calls[name] for name in STAGES} == {
        "rectify": 1, "objects": 1, "association": 1, "uniformity": 2, "global": 2, "refine": 2, "sharpness": 2,
        "smoothness": 2,
    }
    assert run.cached["objects"] and run.cached["association"] and not run.cached["uniformity"]

    pipeline.run(pair, FAST.with_stage("uniformity", mu=0.2).with_stage("smoothness", c=2.0))
    assert pipeline.calls["smoothness"] == 3 and pipeline.calls["refine"] == 2

    pipeline.run(pair, FAST.with_stage("uniformity", mu=0.2).with_stage("association", ratio=0.7))
    assert pipeline.calls["association"] == 2 and pipeline.calls["objects"] == 1
    assert pipeline.calls["uniformity"] == 2 and pipeline.calls["global"] == 2
    assert pipeline.calls["refine"] == 3

    # back to the first setting: served from the cache, nothing recomputed
    before = dict(pipeline.calls)
    pipeline.run(pair, FAST)
    assert dict(pipeline.calls) == before


def test_new_pair_content_is_not_served_from_cache(pair):
    pipeline = Pipeline(FAST)
    first = pipeline.run(pair)
    data = pair.target.data.copy()
    data[:20, :20] = data[:20, :20] // 2
    other = replace(pair, target=replace(pair.target, data=data))
    second = pipeline.run(other)
    assert pipeline.calls["uniformity"] == 2
    assert not np.array_equal(first.images("uniformity")[1], second.images("uniformity")[1])


def test_until_and_disabled_stages(pair):
    run = Pipeline(FAST).run(pair, until="global")
    assert run.image_stages == ["original", "uniformity", "global"] and "refine" not in run.timings

    params = FAST.with_stage("uniformity", enabled=False).with_stage("smoothness", enabled=False)
    run = Pipeline(params).run(pair)
    np.testing.assert_array_equal(run.images("uniformity")[0], run.images("original")[0])
    np.testing.assert_array_equal(run.images("smoothness")[1], run.images("refine")[1])


def test_nodata_pixels_stay_invalid(pair):
    data = pair.target.data.copy()
    data[10:20, 30:60] = 0
    ref = pair.reference.data.copy()
    ref[100:110, 5:15] = 0
    nodata_pair = replace(
        pair,
        reference=Raster(ref, nodata=0),
        target=Raster(data, nodata=0),
    )
    run = Pipeline(FAST).run(nodata_pair)
    for stage in run.image_stages:
        r, t = run.images(stage)
        assert np.isnan(t[10:20, 30:60]).all() and np.isnan(r[100:110, 5:15]).all()
        assert np.isfinite(t[40:, :]).all()
    out = to_output_dtype(run.images()[1], data.dtype, 0)
    assert (out[10:20, 30:60] == 0).all() and out.dtype == data.dtype


def test_refine_leaves_out_the_pixels_clipped_in_the_images_as_read(pair):
    """The uniformity stage spreads a clipping level over many grey values, so the refine
    stage must find the clipped pixels in the original images, not in its input."""
    from radcons.numerics.valid_pixels import clipped_mask

    params = Params.from_preset("radcons").with_stage("uniformity", enabled=True)
    run = Pipeline(params).run(pair, until="refine")
    original, refine_input = run.images("original")[1], run.images("global")[1]
    assert clipped_mask(original).sum() > 100 and not clipped_mask(refine_input).any()
    on_clip = [fit for fit in run.fits if fit.clipped]
    assert on_clip, "the demo pair's target has a roof clipped at 255"
    labels = run.objects.target
    for fit in on_clip:
        assert clipped_mask(original)[labels == fit.tgt_id].any()
        if fit.clipped > params.refine.max_clipped * fit.n_points:
            assert fit.gain == 1.0 and fit.note.startswith("offset only")


def test_output_dtype_conversion():
    image = np.array([[-5.0, 12.4], [300.0, np.nan]], np.float32)
    np.testing.assert_array_equal(to_output_dtype(image, np.uint8, None), [[0, 12], [255, 0]])
    np.testing.assert_array_equal(to_output_dtype(image, np.uint16, 7), [[0, 12], [300, 7]])
    assert np.isnan(to_output_dtype(image, np.float32, None)[1, 1])


def test_paper_preset_runs_on_a_pair_whose_objects_include_one_pixel_wide_templates():
    # Seed 1 at 96 px has an object that reaches template matching one column wide: it
    # is left unmatched, not an OpenCV error.
    run = Pipeline(Params.from_preset("paper").with_stage("smoothness", iterations=1)).run(
        generate(size=96, seed=1)
    )
    assert list(run.timings) == list(STAGES)


def test_sift_matches_run_beside_the_objects_once_per_pair_and_association_params(pair, monkeypatch):
    import radcons.stages.association.run as association

    calls = []
    real = association.match_features

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(association, "match_features", counted)
    params = FAST.with_stage("objects", use_supplied=False)
    pipeline = Pipeline(params)
    run = pipeline.run(pair, until="association")
    reference, target = run.images("original")
    direct = real(reference, target, params.association, rectified=pair.rectified)
    assert len(direct) > 0
    np.testing.assert_array_equal(run.association.matches.ref_xy, direct.ref_xy)
    np.testing.assert_array_equal(run.association.matches.tgt_xy, direct.tgt_xy)
    assert len(calls) == 1

    # new objects, same matches: the matching is not run again
    pipeline.run(pair, params.with_stage("objects", min_area_m2=params.objects.min_area_m2 * 2), until="association")
    assert pipeline.calls["objects"] == 2 and pipeline.calls["association"] == 2 and len(calls) == 1
    # new association parameters: matched again
    pipeline.run(pair, params.with_stage("association", ratio=0.7), until="association")
    assert len(calls) == 2


def test_sift_beside_the_height_objects_runs_opencv_on_one_thread_and_otherwise_on_all(pair, monkeypatch):
    import cv2

    import radcons.stages.association.run as association

    threads = []
    real = association.match_features

    def recorded(*args, **kwargs):
        threads.append(cv2.getNumThreads())
        return real(*args, **kwargs)

    monkeypatch.setattr(association, "match_features", recorded)
    cv2.setNumThreads(2)
    params = FAST.with_stage("objects", method="height", use_supplied=False)
    pipeline = Pipeline(params)
    pipeline.run(pair, until="association")
    assert threads == [1] and cv2.getNumThreads() == 2
    # objects already computed: the matching runs alone, on every thread
    pipeline.run(pair, params.with_stage("association", ratio=0.7), until="association")
    assert threads == [1, 2] and cv2.getNumThreads() == 2
    # supplied labels or image-only objects take no census matching: every thread too
    for objects in ({"method": "height", "use_supplied": True}, {"method": "mbi", "use_supplied": False}):
        Pipeline(FAST.with_stage("objects", **objects)).run(pair, until="association")
    assert threads == [1, 2, 2, 2] and cv2.getNumThreads() == 2


def test_overlapping_holders_of_one_opencv_thread_restore_the_first_count():
    import threading

    import cv2

    from radcons.pipeline import _ONE_OPENCV_THREAD

    cv2.setNumThreads(2)
    entered, release = threading.Event(), threading.Event()

    def hold():
        with _ONE_OPENCV_THREAD.held():
            entered.set()
            release.wait(10)

    other = threading.Thread(target=hold)
    other.start()
    assert entered.wait(10)
    with _ONE_OPENCV_THREAD.held():
        assert cv2.getNumThreads() == 1
    assert cv2.getNumThreads() == 1  # the other holder is still matching
    release.set()
    other.join(10)
    assert cv2.getNumThreads() == 2


def test_the_height_methods_census_matching_is_kept_while_its_rules_change(pair, monkeypatch):
    import radcons.stages.objects.matching as objects

    matched = []
    real = objects.match_pair

    def counted(*args, **kwargs):
        matched.append(kwargs)
        return real(*args, **kwargs)

    monkeypatch.setattr(objects, "match_pair", counted)
    params = FAST.with_stage("objects", method="height", use_supplied=False)
    pipeline = Pipeline(params)
    pipeline.run(pair, until="objects")
    # a rule's and a search's thresholds: the objects again, on the kept matching
    tuned = params.with_stage("objects", tree_texture=2.0, missed_scale=params.objects.missed_scale * 2)
    again = pipeline.run(pair, tuned, until="objects").objects
    assert pipeline.calls["objects"] == 2 and len(matched) == 1
    fresh = Pipeline(tuned).run(pair, until="objects").objects  # matched anew
    assert np.array_equal(again.reference, fresh.reference) and np.array_equal(again.target, fresh.target)
    assert again.modal_disparity == fresh.modal_disparity
    # a census field: matched again
    pipeline.run(pair, tuned.with_stage("objects", census_cell_m=2.0), until="objects")
    assert len(matched) == 3
    pipeline.clear()
    pipeline.run(pair, tuned, until="objects")
    assert len(matched) == 4
