"""Object (building) extraction."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from radcons.errors import InputError, ParamsError
from radcons.stages.objects.mbi import building_index, extract_objects
from radcons.stages.objects.params import ObjectsParams


def _buildings_on_textured_ground(n=192, seed=0, count=8):
    """Bright rectangles (buildings) on textured ground; returns image and true labels."""
    rng = np.random.default_rng(seed)
    ground = cv2.GaussianBlur(rng.normal(0, 1, (n, n)).astype(np.float32), (0, 0), 2) * 25 + 100
    truth = np.zeros((n, n), np.int32)
    image = ground.copy()
    while truth.max() < count:
        w, h = rng.integers(12, 40, 2)
        x, y = rng.integers(2, n - w - 2), rng.integers(2, n - h - 2)
        if truth[max(y - 4, 0) : y + h + 4, max(x - 4, 0) : x + w + 4].any():
            continue
        truth[y : y + h, x : x + w] = truth.max() + 1
        image[y : y + h, x : x + w] += rng.uniform(50, 90)
    image += rng.normal(0, 3, (n, n)).astype(np.float32)
    return image, truth


def _best_iou(truth, labels, ident):
    mask = truth == ident
    under = labels[mask]
    under = under[under > 0]
    if under.size == 0:
        return 0.0
    best = np.bincount(under).argmax()
    other = labels == best
    return (mask & other).sum() / (mask | other).sum()


def test_bright_buildings_are_found():
    image, truth = _buildings_on_textured_ground()
    labels = extract_objects(image)
    assert labels.dtype == np.int32 and labels.shape == image.shape
    ious = [_best_iou(truth, labels, i) for i in range(1, truth.max() + 1)]
    assert min(ious) > 0.5, ious


def test_labels_are_consecutive_and_respect_min_area():
    image, _ = _buildings_on_textured_ground(seed=1)
    params = ObjectsParams(min_area=200)
    labels = extract_objects(image, params)
    ids = np.unique(labels)
    assert np.array_equal(ids, np.arange(ids.size))
    assert np.bincount(labels.ravel())[1:].min() >= 200


def test_flat_noisy_image_has_no_objects():
    rng = np.random.default_rng(2)
    yy, xx = np.mgrid[0:160, 0:160]
    flat = (100 + 0.1 * xx + 0.05 * yy + rng.normal(0, 3, (160, 160))).astype(np.float32)
    assert not extract_objects(flat).any()


def test_constant_image_has_no_objects():
    assert not extract_objects(np.full((64, 64), 7.0, np.float32)).any()


def test_nan_pixels_are_background_and_do_not_stop_detection():
    image, truth = _buildings_on_textured_ground(seed=3)
    holed = image.copy()
    holed[:, :20] = np.nan
    labels = extract_objects(holed)
    assert not labels[:, :20].any()
    inside = [i for i in range(1, truth.max() + 1) if (np.argwhere(truth == i)[:, 1] >= 24).all()]
    assert inside and min(_best_iou(truth, labels, i) for i in inside) > 0.5


def test_building_index_responds_to_compact_bright_structures_not_long_ones():
    image = np.full((120, 120), 50.0, np.float32)
    image[20:40, 20:40] = 150.0  # a 20 x 20 roof
    image[80:86, :] = 150.0  # a road crossing the image
    index = building_index(image, ObjectsParams())
    assert index[30, 30] == pytest.approx(100.0, rel=0.05)  # high in all four directions
    assert index[83, 60] < 0.8 * index[30, 30]
    assert index[100, 100] == pytest.approx(0.0, abs=1.0)


def test_bad_input_and_params():
    with pytest.raises(InputError, match="single-band 2-D"):
        extract_objects(np.zeros((4, 4, 3), np.float32))
    with pytest.raises(InputError, match="every pixel of the image is NaN"):
        extract_objects(np.full((8, 8), np.nan, np.float32))
    with pytest.raises(InputError, match=r"shape \(0, 8\) is empty"):
        extract_objects(np.zeros((0, 8), np.float32))
    with pytest.raises(ParamsError):
        ObjectsParams(min_size=10, max_size=5)
    with pytest.raises(ParamsError):
        ObjectsParams(min_area=0)
    with pytest.raises(ParamsError):
        ObjectsParams(polarity="grey")
