"""Eq 20 improved histogram similarity: known values, bounds, object crops."""

from __future__ import annotations

import numpy as np
import pytest

from radcons.errors import InputError
from radcons.evaluate.similarity import common_range, histogram_similarity, object_similarities


def eq20_literal(levels_1: np.ndarray, levels_2: np.ndarray) -> float:
    """Eq 20 exactly as printed, for two crops of the same size holding integer levels."""
    m = levels_1.size
    o1 = np.bincount(levels_1.ravel(), minlength=256)
    o2 = np.bincount(levels_2.ravel(), minlength=256)
    occupied = [j for j in range(256) if o1[j] or o2[j]]
    a = np.concatenate([levels_1.ravel(), levels_2.ravel()]).mean()
    zeta = [abs(a - j) + 1 for j in range(256)]
    zeta_max = max(zeta[j] for j in occupied)
    total = sum(abs(int(o1[j]) - int(o2[j])) * zeta[j] for j in range(256))
    return 1 - (max(occupied) - min(occupied)) * total / (2 * 255 * m * zeta_max)


def test_hand_computed_value():
    # O1 = {0: 2, 10: 2}, O2 = {0: 1, 10: 2, 20: 1}; span 20, A = 7.5, zeta = 8.5, 3.5, 13.5
    # C = 1 - 20 * (1 * 8.5 + 1 * 13.5) / (2 * 255 * 4 * 13.5)
    ref = np.array([[0.0, 0.0], [10.0, 10.0]])
    tgt = np.array([[0.0, 10.0], [10.0, 20.0]])
    expected = 1 - 20 * 22 / (2 * 255 * 4 * 13.5)
    assert histogram_similarity(ref, tgt, (0.0, 256.0)) == pytest.approx(expected, abs=1e-12)


def test_matches_the_printed_formula_on_equal_sizes():
    rng = np.random.default_rng(1)
    for _ in range(20):
        a = rng.integers(0, 256, (12, 9))
        b = np.clip(a + rng.integers(-40, 60, a.shape), 0, 255)
        value = histogram_similarity(a.astype(float), b.astype(float), (0.0, 256.0))
        assert value == pytest.approx(eq20_literal(a, b), abs=1e-12)


def test_identical_crops_give_one():
    rng = np.random.default_rng(0)
    crop = rng.normal(500.0, 80.0, (40, 30))
    assert histogram_similarity(crop, crop.copy(), (100.0, 900.0)) == 1.0
    # the same histogram in another arrangement and size still gives 1
    assert histogram_similarity(crop, np.tile(crop[:, ::-1], (2, 1)), (100.0, 900.0)) == 1.0


def test_bounds_on_random_crops():
    rng = np.random.default_rng(2)
    for _ in range(50):
        a = rng.uniform(0, 1000, rng.integers(5, 40, 2))
        b = rng.uniform(rng.uniform(0, 500), 1000, rng.integers(5, 40, 2))
        assert 0.0 <= histogram_similarity(a, b, (0.0, 1000.0)) <= 1.0


def test_opposite_extremes_give_zero():
    dark, bright = np.zeros((5, 5)), np.full((5, 5), 255.0)
    assert histogram_similarity(dark, bright, (0.0, 255.0)) == pytest.approx(0.0, abs=1e-12)


def test_more_different_is_less_similar():
    rng = np.random.default_rng(3)
    crop = rng.uniform(60.0, 140.0, (32, 32))
    near = histogram_similarity(crop, crop + 10.0, (0.0, 256.0))
    far = histogram_similarity(crop, crop + 80.0, (0.0, 256.0))
    assert 1.0 > near > far >= 0.0


def test_nan_pixels_are_left_out():
    crop = np.arange(16, dtype=float).reshape(4, 4) * 10
    holed = crop.copy()
    holed[0, 0] = np.nan
    # a NaN pixel counts as if it were not there
    value = histogram_similarity(crop, holed, (0.0, 160.0))
    assert value == histogram_similarity(crop, crop.ravel()[1:], (0.0, 160.0))
    assert value < 1.0
    with pytest.raises(InputError):
        histogram_similarity(crop, np.full((2, 2), np.nan), (0.0, 160.0))
    with pytest.raises(InputError):
        histogram_similarity(crop, crop, (5.0, 5.0))


def test_object_similarities_crop_and_background():
    rng = np.random.default_rng(4)
    reference = rng.uniform(200.0, 800.0, (64, 64)).astype(np.float32)
    target = rng.uniform(200.0, 800.0, (64, 64)).astype(np.float32)  # other surroundings
    labels_ref = np.zeros((64, 64), np.int32)
    labels_tgt = np.zeros((64, 64), np.int32)
    # object 1: a disc, moved by 7 px in the target with the same content
    yy, xx = np.mgrid[:64, :64]
    disc = (yy - 20) ** 2 + (xx - 30) ** 2 < 100
    labels_ref[disc] = 1
    moved = np.roll(disc, -7, axis=1)
    labels_tgt[moved] = 1
    target[moved] = reference[disc]
    # object 2: a square whose target content is brightened
    labels_ref[40:60, 5:25] = 2
    labels_tgt[40:60, 2:22] = 5
    target[40:60, 2:22] = reference[40:60, 5:25] * 1.4
    result = object_similarities(reference, target, labels_ref, labels_tgt, [(1, 1), (2, 5)])
    assert set(result) == {1, 2}
    assert result[1] == 1.0
    assert 0.0 <= result[2] < 0.95
    # what lies outside the object masks does not count
    other = np.where(labels_tgt == 0, np.float32(790.0), target)
    assert object_similarities(reference, other, labels_ref, labels_tgt, [(1, 1)])[1] == 1.0
    low = float(min(reference.min(), target.min()))
    high = float(max(reference.max(), target.max()))
    assert common_range(reference, target) == (low, high)


def test_object_similarities_errors():
    image = np.ones((8, 8), np.float32)
    image[0, 0] = 2
    labels = np.zeros((8, 8), np.int32)
    labels[2:4, 2:4] = 1
    with pytest.raises(InputError, match="absent"):
        object_similarities(image, image, labels, labels, [(1, 3)])
    with pytest.raises(InputError):
        object_similarities(image, image, labels[:4], labels, [(1, 1)])
