"""Feature matching and object region association (section 3, eq 12)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from radcons.errors import InputError, ParamsError
from radcons.numerics.modal import modal_disparity
from radcons.results import Matches
from radcons.stages.association.params import AssociationParams
from radcons.stages.association.run import associate_objects, match_features


def _texture(rng, shape, sigma, amplitude):
    return cv2.GaussianBlur(rng.normal(0, 1, shape).astype(np.float32), (0, 0), sigma) * amplitude


def _shifted_pair(n=192, seed=0, objects=5, ground_disparity=4):
    """Textured ground and textured roofs; the target shows each roof shifted by its own
    known disparity (target x = reference x - d), the ground by ``ground_disparity``."""
    rng = np.random.default_rng(seed)
    ground = 100 + _texture(rng, (n, n), 1.5, 60)
    reference = ground.copy()
    target = np.roll(ground, -ground_disparity, axis=1)
    labels_ref = np.zeros((n, n), np.int32)
    labels_tgt = np.zeros((n, n), np.int32)
    truth = {}
    while len(truth) < objects:
        w, h = rng.integers(22, 40, 2)
        x, y = rng.integers(30, n - w - 4), rng.integers(4, n - h - 4)
        if labels_ref[max(y - 4, 0) : y + h + 4, max(x - 26, 0) : x + w + 26].any():
            continue
        d = int(rng.integers(8, 22))
        roof = 170 + _texture(rng, (h, w), 1.2, 40)
        ident = len(truth) + 1
        reference[y : y + h, x : x + w] = roof
        labels_ref[y : y + h, x : x + w] = ident
        target[y : y + h, x - d : x - d + w] = roof
        labels_tgt[y : y + h, x - d : x - d + w] = ident
        truth[ident] = d
    reference += rng.normal(0, 2, (n, n)).astype(np.float32)
    target = 0.8 * target + 15 + rng.normal(0, 2, (n, n)).astype(np.float32)
    return reference, target.astype(np.float32), labels_ref, labels_tgt, truth


@pytest.fixture(scope="module")
def pair():
    reference, target, labels_ref, labels_tgt, truth = _shifted_pair()
    return reference, target, labels_ref, labels_tgt, truth, match_features(reference, target)


def test_matches_follow_rows_and_the_known_disparities(pair):
    reference, target, labels_ref, _, truth, matches = pair
    assert len(matches) > 100
    assert np.all(np.abs(matches.ref_xy[:, 1] - matches.tgt_xy[:, 1]) <= AssociationParams().row_tolerance)
    ids = labels_ref[np.rint(matches.ref_xy[:, 1]).astype(int), np.rint(matches.ref_xy[:, 0]).astype(int)]
    expected = np.array([truth.get(i, 4) for i in ids], float)
    error = np.abs(matches.disparity - expected)
    assert np.median(error) < 0.5
    assert np.mean(error < 1.0) > 0.9


def test_objects_are_associated_by_sift_with_their_disparity(pair):
    reference, target, labels_ref, labels_tgt, truth, matches = pair
    association = associate_objects(reference, target, labels_ref, labels_tgt, matches)
    assert association.unassociated_ref == ()
    assert [o.ref_id for o in association.objects] == sorted(truth)
    for obj in association.objects:
        assert obj.method == "sift"
        assert obj.tgt_id == obj.ref_id
        assert obj.n_matches > 2
        assert abs(obj.modal_disparity - truth[obj.ref_id]) <= 1.0
        assert np.all(np.abs(matches.disparity[obj.invariant_indices] - obj.modal_disparity) < 2.0)
        assert set(obj.invariant_indices) <= set(obj.match_indices)


def test_objects_without_matches_are_associated_by_template(pair):
    reference, target, labels_ref, labels_tgt, truth, _ = pair
    association = associate_objects(reference, target, labels_ref, labels_tgt, Matches.empty())
    assert len(association.objects) == len(truth)
    for obj in association.objects:
        assert obj.method == "template"
        assert obj.tgt_id == obj.ref_id
        assert abs(obj.modal_disparity - truth[obj.ref_id]) <= 1.0
        assert 0.5 < obj.score <= 1.0 + 1e-3
        assert obj.n_matches == 0


def test_an_object_with_one_match_goes_to_template(pair):
    reference, target, labels_ref, labels_tgt, truth, matches = pair
    ids = labels_ref[np.rint(matches.ref_xy[:, 1]).astype(int), np.rint(matches.ref_xy[:, 0]).astype(int)]
    keep = ids != 1
    keep[np.flatnonzero(ids == 1)[0]] = True
    one = Matches(matches.ref_xy[keep], matches.tgt_xy[keep])
    by_ref = associate_objects(reference, target, labels_ref, labels_tgt, one).by_ref()
    assert by_ref[1].method == "template"
    assert by_ref[1].tgt_id == 1
    assert abs(by_ref[1].modal_disparity - truth[1]) <= 1.0
    assert by_ref[2].method == "sift"


def test_blank_target_gives_no_matches_and_does_not_crash(pair):
    reference, _, labels_ref, _, _, _ = pair
    blank = np.full(reference.shape, 90.0, np.float32)
    matches = match_features(reference, blank)
    assert len(matches) == 0
    association = associate_objects(reference, blank, labels_ref, np.zeros_like(labels_ref), matches)
    # a flat window has no correlation: every object stays unassociated
    assert association.objects == ()
    assert set(association.unassociated_ref) == set(np.unique(labels_ref[labels_ref > 0]))


def test_no_objects_gives_an_empty_association(pair):
    reference, target, _, _, _, matches = pair
    empty = np.zeros(reference.shape, np.int32)
    association = associate_objects(reference, target, empty, empty, matches)
    assert association.objects == () and association.unassociated_ref == ()
    assert len(association.matches) == len(matches)


def test_invariant_points_of_eq_12_on_hand_made_matches():
    reference = np.random.default_rng(3).random((40, 60)).astype(np.float32)
    labels = np.zeros((40, 60), np.int32)
    labels[10:30, 30:55] = 1
    labels_tgt = np.zeros_like(labels)
    labels_tgt[10:30, 15:45] = 7
    disparities = np.array([15.2, 14.9, 15.1, 16.4, 25.0, 14.6])
    ref_xy = np.array([[40 + i, 12 + 2 * i] for i in range(6)], np.float32)
    tgt_xy = ref_xy - np.c_[disparities, np.zeros(6)].astype(np.float32)
    tgt_xy[4, 0] = 20  # the mismatch still lands in target object 7
    disparities[4] = ref_xy[4, 0] - 20
    association = associate_objects(reference, reference, labels, labels_tgt, Matches(ref_xy, tgt_xy))
    (obj,) = association.objects
    assert (obj.ref_id, obj.tgt_id, obj.method) == (1, 7, "sift")
    assert obj.modal_disparity == pytest.approx(15.0)  # median of the modal bin {15.2, 14.9, 15.1, 14.6}
    assert list(obj.invariant_indices) == [0, 1, 2, 3, 5]  # 16.4 is 1.4 px away, 24 is not


def test_modal_disparity_uses_the_one_pixel_histogram():
    assert modal_disparity(np.array([3.1, 3.2, 2.9, 7.0, 7.1])) == pytest.approx(3.1)
    assert modal_disparity(np.array([5.0, 9.0])) == pytest.approx(5.0)  # tie: the smaller
    with pytest.raises(InputError):
        modal_disparity(np.array([]))


def test_unrectified_pair_matches_with_a_vertical_offset():
    rng = np.random.default_rng(4)
    image = 100 + _texture(rng, (160, 160), 1.5, 60)
    target = np.roll(np.roll(image, -6, axis=1), 7, axis=0)
    matches = match_features(image, target, rectified=False)
    assert len(matches) > 50
    assert np.median(matches.tgt_xy[:, 1] - matches.ref_xy[:, 1]) == pytest.approx(7.0, abs=0.3)
    assert np.median(matches.disparity) == pytest.approx(6.0, abs=0.3)
    assert len(match_features(image, target, rectified=True)) < 0.2 * len(matches)


def test_unrectified_matches_do_not_depend_on_opencv_random_state():
    rng = np.random.default_rng(4)
    image = 100 + _texture(rng, (160, 160), 1.5, 60)
    target = np.roll(np.roll(image, -6, axis=1), 7, axis=0) + rng.normal(0, 3, image.shape).astype(np.float32)
    first = match_features(image, target, rectified=False)
    cv2.setRNGSeed(321)
    cv2.randu(np.zeros((8, 8), np.float32), 0, 1)
    second = match_features(image, target, rectified=False)
    assert np.array_equal(first.ref_xy, second.ref_xy) and np.array_equal(first.tgt_xy, second.tgt_xy)


def test_nan_pixels_are_not_detected_and_shapes_are_checked(pair):
    reference, target, labels_ref, labels_tgt, _, _ = pair
    holed = reference.copy()
    holed[:, :60] = np.nan
    matches = match_features(holed, target)
    assert len(matches) > 0 and matches.ref_xy[:, 0].min() >= 60
    with pytest.raises(InputError, match="shape"):
        associate_objects(reference, target, labels_ref[:-1], labels_tgt, matches)
    with pytest.raises(InputError, match="integers"):
        associate_objects(reference, target, labels_ref.astype(float), labels_tgt, matches)
    with pytest.raises(ParamsError):
        AssociationParams(ratio=1.5)
