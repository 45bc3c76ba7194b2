"""The US3D / DFC2019 multi-date pairs read as pairs with ground truth (real data)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from radcons.errors import InputError, ParamsError
from radcons.evaluate.truth_pairs import load_us3d, us3d_names

US3D = "us3d_jacksonville_multidate"


@pytest.fixture(scope="module")
def us3d_dir(shared_data):
    folder = shared_data / US3D
    if not folder.is_dir():
        pytest.skip(f"the US3D tiles ({folder}) are absent")
    return folder


def sift_offsets(reference: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Left points ``(x, y)`` and ``x_left - x_right`` of ratio-tested SIFT matches on one row."""
    sift = cv2.SIFT_create()
    kl, dl = sift.detectAndCompute(reference, None)
    kr, dr = sift.detectAndCompute(target, None)
    good = [m for m, n in cv2.BFMatcher().knnMatch(dl, dr, k=2) if m.distance < 0.75 * n.distance]
    left = np.array([kl[m.queryIdx].pt for m in good])
    right = np.array([kr[m.trainIdx].pt for m in good])
    same_row = np.abs(left[:, 1] - right[:, 1]) < 2.0  # epipolar: rows correspond
    return left[same_row], (left[:, 0] - right[:, 0])[same_row]


@pytest.mark.realdata
def test_us3d_tiles_read_with_nodata_as_nan(us3d_dir):
    names = us3d_names(us3d_dir)
    assert names == ["JAX_072_011_022", "JAX_122_019_005"]
    for name in names:
        pair = load_us3d(us3d_dir, name)
        assert pair.shape == (1024, 1024) and pair.reference.data.dtype == np.uint8
        assert pair.target.data.ndim == 2  # RGB read as one grey band
        known = np.isfinite(pair.disparity)
        assert 0.70 < known.mean() < 0.90  # the data README: 74-85 % valid
        assert not (pair.disparity[known] == -999).any()
        assert np.array_equal(pair.disparity[known], np.rint(pair.disparity[known]))  # integer lidar values
        assert pair.reference_objects.max() >= 3
        assert set(np.unique(pair.target_objects)) <= set(np.unique(pair.reference_objects))


@pytest.mark.realdata
@pytest.mark.parametrize("name", ["JAX_072_011_022", "JAX_122_019_005"])
def test_us3d_disparity_sign_is_ours(us3d_dir, name):
    """SIFT matches agree with reference(x, y) <-> target(x - d, y), not with x + d."""
    pair = load_us3d(us3d_dir, name)
    points, offsets = sift_offsets(pair.reference.data, pair.target.data)
    rows, cols = np.rint(points[:, 1]).astype(int), np.rint(points[:, 0]).astype(int)
    truth = pair.disparity[rows, cols]
    known = np.isfinite(truth)
    assert known.sum() >= 40
    ours = np.abs(offsets[known] - truth[known])
    opposite = np.abs(offsets[known] + truth[known])
    assert np.mean(ours < 3.0) > 0.7
    assert np.mean(ours < 3.0) > np.mean(opposite < 3.0) + 0.25


@pytest.mark.realdata
def test_us3d_crop_and_errors(us3d_dir, tmp_path):
    full = load_us3d(us3d_dir, "JAX_072_011_022")
    crop = load_us3d(us3d_dir, "JAX_072_011_022", crop=256)
    assert crop.shape == (256, 256)
    np.testing.assert_array_equal(crop.reference.data, full.reference.data[384:640, 384:640])
    np.testing.assert_array_equal(crop.disparity, full.disparity[384:640, 384:640])
    with pytest.raises(ParamsError):
        load_us3d(us3d_dir, "JAX_072_011_022", crop=4)
    with pytest.raises(InputError, match="not found"):
        load_us3d(us3d_dir, "JAX_999_000_000")
    with pytest.raises(InputError, match="no \\*_LEFT_DSP.tif"):
        us3d_names(tmp_path)
