"""Epipolar rectification: affine epipolar geometry, rectify_pair on a pair with known truth.

The synthetic pair is built from a rectified pair with a known piecewise-constant disparity
(a random texture and its copy, a block shifted more than the background), each image then
warped by its own known affine map. Every check compares with quantities derived from
those known maps, never with the function's own output.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import scipy.ndimage
import tifffile

from radcons.errors import InputError, ParamsError, StageError
from radcons.stages.rectify.epipolar import fit_affine_epipolar, ransac_affine_epipolar
from radcons.stages.rectify.run import RectifyParams, rectify_pair

# Rectified truth: reference(x, y) <-> target(x - d, y); d = BLOCK_D inside the block (target
# frame), BACKGROUND_D elsewhere.
TRUE_SHAPE = (230, 240)
BACKGROUND_D, BLOCK_D = 3, 11
BLOCK = (slice(70, 160), slice(80, 160))  # rows, target columns


def _texture(shape: tuple[int, int], seed: int) -> np.ndarray:
    noise = np.random.default_rng(seed).standard_normal(shape)
    smooth = scipy.ndimage.gaussian_filter(noise, 1.2)
    return (200.0 + 1000.0 * (smooth - smooth.min()) / np.ptp(smooth)).astype(np.float32)


def _affine(angle_deg: float, scale: float, shear: float, shift: tuple[float, float]) -> np.ndarray:
    """3x3 map true-rectified -> original pixel coordinates."""
    t = np.deg2rad(angle_deg)
    rotation = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    linear = scale * rotation @ np.array([[1.0, shear], [0.0, 1.0]])
    return np.vstack([np.column_stack([linear, shift]), [0.0, 0.0, 1.0]])


def _apply(matrix: np.ndarray, xy: np.ndarray) -> np.ndarray:
    return xy @ matrix[:2, :2].T + matrix[:2, 2]


def _true_pair() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rectified reference, target and the target-frame disparity."""
    rows, cols = TRUE_SHAPE
    world = _texture((rows, cols + 2 * BLOCK_D), seed=1)
    disparity_t = np.full(TRUE_SHAPE, BACKGROUND_D)
    disparity_t[BLOCK] = BLOCK_D
    x_t = np.arange(cols)[None, :]
    target = np.take_along_axis(world, x_t + disparity_t, axis=1)
    reference = world[:, :cols].copy()
    return reference, target, disparity_t


def _reference_disparity() -> np.ndarray:
    """Reference-frame truth, NaN where occluded, ambiguous or within 2 px of an edge."""
    d = np.full(TRUE_SHAPE, float(BACKGROUND_D))
    rows, cols = BLOCK
    d[rows, cols.start + BLOCK_D : cols.stop + BLOCK_D] = BLOCK_D
    edges = [cols.start + BACKGROUND_D, cols.start + BLOCK_D, cols.stop + BACKGROUND_D, cols.stop + BLOCK_D]
    lo, hi = min(edges) - 2, max(edges) + 2
    for left, right in ((edges[0] - 2, edges[1] + 2), (edges[2] - 2, edges[3] + 2)):
        d[rows, left:right] = np.nan
    d[rows.start - 2 : rows.start + 2, lo:hi] = np.nan
    d[rows.stop - 2 : rows.stop + 2, lo:hi] = np.nan
    return d


REF_MAP = _affine(4.0, 1.03, 0.02, (22.0, 8.0))
TGT_MAP = _affine(-3.0, 0.96, -0.03, (-14.0, 38.0))
REF_SHAPE, TGT_SHAPE = (250, 262), (268, 236)


@pytest.fixture(scope="module")
def synthetic():
    reference, target, _ = _true_pair()
    warp = dict(flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_CONSTANT, borderValue=float("nan"))
    ref_img = cv2.warpAffine(reference, REF_MAP[:2], REF_SHAPE[::-1], **warp)
    tgt_img = cv2.warpAffine(target, TGT_MAP[:2], TGT_SHAPE[::-1], **warp)
    return ref_img, tgt_img, rectify_pair(ref_img, tgt_img)


def _truth_points(step: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Known correspondences: true-frame reference points, their disparity, original points."""
    d = _reference_disparity()
    rows, cols = np.mgrid[4 : TRUE_SHAPE[0] - 4 : step, 16 : TRUE_SHAPE[1] - 4 : step]
    u = np.column_stack([cols.ravel(), rows.ravel()]).astype(float)
    disparity = d[rows.ravel(), cols.ravel()]
    keep = np.isfinite(disparity)
    u, disparity = u[keep], disparity[keep]
    ref_original = _apply(REF_MAP, u)
    tgt_original = _apply(TGT_MAP, u - np.column_stack([disparity, np.zeros_like(disparity)]))
    return disparity, ref_original, tgt_original


# ----------------------------------------------------------------------------- epipolar fit


def _affine_cameras(seed: int):
    """Two random affine cameras (2x4) and the reference-image epipolar direction."""
    rng = np.random.default_rng(seed)
    cameras = [np.column_stack([rng.normal(size=(2, 3)), rng.uniform(-50, 50, 2)]) for _ in range(2)]
    centre_2 = np.linalg.svd(cameras[1][:, :3])[2][-1]  # direction of the target's rays
    direction = cameras[0][:, :3] @ centre_2  # their image in the reference: epipolar lines
    return cameras, direction / np.linalg.norm(direction)


def _project(camera: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ camera[:, :3].T + camera[:, 3]


def test_fit_matches_the_epipolar_direction_of_known_affine_cameras():
    cameras, direction = _affine_cameras(seed=3)
    points = np.random.default_rng(4).uniform(-100, 100, (60, 3))
    ref_xy, tgt_xy = _project(cameras[0], points), _project(cameras[1], points)
    geometry = fit_affine_epipolar(ref_xy, tgt_xy)
    a, b, c, d, e = geometry.coefficients
    assert np.hypot(c, d) == pytest.approx(1.0)
    assert abs(np.dot([c, d], direction)) < 1e-9  # (c, d) is normal to the epipolar lines
    np.testing.assert_allclose(geometry.residuals(ref_xy, tgt_xy), 0.0, atol=1e-8)
    tgt_h, ref_h = (np.column_stack([xy, np.ones(len(xy))]) for xy in (tgt_xy, ref_xy))
    algebraic = np.einsum("ni,ij,nj->n", tgt_h, geometry.matrix, ref_h)
    np.testing.assert_allclose(algebraic, 0.0, atol=1e-8)


def test_ransac_separates_outliers():
    cameras, direction = _affine_cameras(seed=5)
    rng = np.random.default_rng(6)
    points = rng.uniform(-100, 100, (200, 3))
    ref_xy = _project(cameras[0], points) + rng.normal(0, 0.2, (200, 2))
    tgt_xy = _project(cameras[1], points) + rng.normal(0, 0.2, (200, 2))
    outliers = np.zeros(200, bool)
    outliers[rng.choice(200, 70, replace=False)] = True
    tgt_xy[outliers] += rng.uniform(-60, 60, (70, 2)) + 20.0 * np.sign(rng.uniform(-1, 1, (70, 2)))
    geometry, inliers = ransac_affine_epipolar(ref_xy, tgt_xy, threshold=1.5, rng=0)
    # an outlier may fall on its epipolar line by chance: it then is consistent
    assert inliers[~outliers].all()
    chance = outliers & inliers
    assert chance.sum() <= 5
    assert abs(np.dot(geometry.coefficients[2:4], direction)) < 0.01


def test_fit_refuses_too_few_matches():
    with pytest.raises(InputError, match="at least 5"):
        fit_affine_epipolar(np.zeros((4, 2)), np.zeros((4, 2)))


# ----------------------------------------------------------------------------- rectify_pair


def test_rows_correspond_after_rectification(synthetic):
    _, _, rect = synthetic
    assert rect.residual_parallax_p90 < 0.5
    assert rect.n_inliers >= 50
    _, ref_original, tgt_original = _truth_points()
    dy = _apply(rect.ref_transform, ref_original)[:, 1] - _apply(rect.tgt_transform, tgt_original)[:, 1]
    assert np.abs(dy).max() < 0.5


def test_reference_is_only_rotated_by_less_than_90_degrees(synthetic):
    _, _, rect = synthetic
    linear = rect.ref_transform[:2, :2]
    np.testing.assert_allclose(linear @ linear.T, np.eye(2), atol=1e-12)
    assert np.linalg.det(linear) == pytest.approx(1.0)
    assert linear[0, 0] > 0  # cos(angle) > 0
    # the true frame is the original rotated back by 4 deg (plus shear): close to it
    assert abs(np.degrees(np.arctan2(linear[1, 0], linear[0, 0])) + 4.0) < 2.0


def test_disparity_recovers_the_known_levels_up_to_an_affine_freedom(synthetic):
    _, _, rect = synthetic
    disparity, ref_original, tgt_original = _truth_points()
    recovered = _apply(rect.ref_transform, ref_original)[:, 0] - _apply(rect.tgt_transform, tgt_original)[:, 0]
    # d_rect = alpha * d_true + plane(x, y): the affine freedom of the rectification
    design = np.column_stack([disparity, ref_original, np.ones(len(disparity))])
    coefficients, *_ = np.linalg.lstsq(design, recovered, rcond=None)
    assert np.abs(design @ coefficients - recovered).max() < 0.3
    assert 0.9 < coefficients[0] < 1.15  # the sign of the disparity is kept
    assert np.abs(recovered).max() < 15  # disparities stay modest
    low, high = rect.disparity_range
    assert low < recovered.min() + 1 and high > recovered.max() - 1


def test_inlier_matches_show_the_two_disparity_levels(synthetic):
    _, _, rect = synthetic
    # where each inlier match lies in the true frame, and the truth there
    back = np.linalg.inv(REF_MAP) @ np.linalg.inv(rect.ref_transform)
    u = _apply(back, rect.matches.ref_xy.astype(float))
    truth = _reference_disparity()
    col, row = np.round(u[:, 0]).astype(int), np.round(u[:, 1]).astype(int)
    inside = (row >= 0) & (row < TRUE_SHAPE[0]) & (col >= 0) & (col < TRUE_SHAPE[1])
    known = np.full(len(u), np.nan)
    known[inside] = truth[row[inside], col[inside]]
    on_block, on_ground = known == BLOCK_D, known == BACKGROUND_D
    assert on_block.sum() >= 10 and on_ground.sum() >= 10
    d = rect.matches.disparity
    gap = np.median(d[on_block]) - np.median(d[on_ground])
    assert gap == pytest.approx(BLOCK_D - BACKGROUND_D, abs=1.0)
    assert np.abs(d[on_block] - np.median(d[on_block])).max() < 2.0


def _expected_rectified_disparity(rect) -> np.ndarray:
    """Truth carried into the rectified reference frame through the known maps."""
    rows, cols = np.indices(rect.shape)
    q = np.column_stack([cols.ravel(), rows.ravel()]).astype(float)
    u = _apply(np.linalg.inv(REF_MAP) @ np.linalg.inv(rect.ref_transform), q)
    col, row = np.round(u[:, 0]).astype(int), np.round(u[:, 1]).astype(int)
    inside = (row >= 0) & (row < TRUE_SHAPE[0]) & (col >= 0) & (col < TRUE_SHAPE[1])
    d = np.full(len(q), np.nan)
    d[inside] = _reference_disparity()[row[inside], col[inside]]
    target_true = u - np.column_stack([d, np.zeros_like(d)])
    target_rect = _apply(rect.tgt_transform @ TGT_MAP, target_true)
    return (q[:, 0] - target_rect[:, 0]).reshape(rect.shape)


def _sgbm(rect, margin: int) -> np.ndarray:
    """cv2.StereoSGBM on the rectified pair, 8 bits over the pair's common range, NaN = none."""
    values = np.concatenate([rect.reference[np.isfinite(rect.reference)], rect.target[np.isfinite(rect.target)]])
    lo, hi = np.percentile(values, [0.5, 99.5])
    left, right = (
        np.clip((np.nan_to_num(im, nan=lo) - lo) / (hi - lo) * 255, 0, 255).astype(np.uint8)
        for im in (rect.reference, rect.target)
    )
    min_disp = int(np.floor(rect.disparity_range[0])) - margin
    num = int(np.ceil((rect.disparity_range[1] + margin - min_disp) / 16)) * 16
    matcher = cv2.StereoSGBM_create(minDisparity=min_disp, numDisparities=num, blockSize=5, P1=200, P2=800)
    raw = matcher.compute(left, right).astype(np.float32) / 16.0
    return np.where(raw >= min_disp, raw, np.nan)


def test_sgbm_on_the_rectified_pair_finds_the_known_disparity(synthetic):
    _, _, rect = synthetic
    found = _sgbm(rect, margin=4)
    expected = _expected_rectified_disparity(rect)
    both = np.isfinite(expected) & np.isfinite(rect.reference) & np.isfinite(rect.target)
    core = scipy.ndimage.binary_erosion(both, iterations=8)
    compared = core & np.isfinite(found)
    assert compared.sum() > 0.7 * core.sum()
    assert np.mean(np.abs(found[compared] - expected[compared]) < 1.0) > 0.9


def test_images_of_different_sizes_share_one_rectified_frame(synthetic):
    ref_img, tgt_img, rect = synthetic
    assert ref_img.shape != tgt_img.shape
    assert rect.reference.shape == rect.target.shape == rect.shape
    assert rect.ref_shape == ref_img.shape and rect.tgt_shape == tgt_img.shape
    assert rect.reference.dtype == rect.target.dtype == np.float32
    # NaN exactly where the rectified pixel maps outside the original reference
    rows, cols = np.indices(rect.shape)
    source = _apply(np.linalg.inv(rect.ref_transform), np.column_stack([cols.ravel(), rows.ravel()]).astype(float))
    far_outside = ((source < -2) | (source > np.array(ref_img.shape[::-1]) + 1)).any(axis=1).reshape(rect.shape)
    assert np.isnan(rect.reference[far_outside]).all()


def test_to_original_returns_the_original_reference(synthetic):
    ref_img, _, rect = synthetic
    back = rect.to_original(rect.reference)
    assert back.shape == ref_img.shape
    both = np.isfinite(back) & np.isfinite(ref_img)
    assert both.sum() > 0.85 * np.isfinite(ref_img).sum()
    spread = np.nanpercentile(ref_img, 99) - np.nanpercentile(ref_img, 1)
    assert np.median(np.abs(back[both] - ref_img[both])) < 0.02 * spread


def test_correspondences_to_original_land_on_the_true_target_points(synthetic):
    _, _, rect = synthetic
    positions = rect.correspondences_to_original(_expected_rectified_disparity(rect))
    disparity, ref_original, tgt_original = _truth_points(step=5)
    col, row = np.round(ref_original[:, 0]).astype(int), np.round(ref_original[:, 1]).astype(int)
    inside = (row >= 0) & (row < rect.ref_shape[0]) & (col >= 0) & (col < rect.ref_shape[1])
    # the truth at the pixel centre, not at the (sub-pixel) grid point
    u = _apply(np.linalg.inv(REF_MAP), np.column_stack([col, row]).astype(float))
    expected = _apply(TGT_MAP, u - np.column_stack([disparity, np.zeros_like(disparity)]))
    got = positions[row[inside], col[inside]]
    ok = np.isfinite(got).all(axis=1)
    assert ok.mean() > 0.9
    assert np.abs(got[ok] - expected[inside][ok]).max() < 0.25


def test_flip_negates_the_disparity(synthetic):
    ref_img, tgt_img, rect = synthetic
    flipped = rectify_pair(ref_img, tgt_img, RectifyParams(flip=True))
    disparity, ref_original, tgt_original = _truth_points()
    plain = _apply(rect.ref_transform, ref_original)[:, 0] - _apply(rect.tgt_transform, tgt_original)[:, 0]
    turned = _apply(flipped.ref_transform, ref_original)[:, 0] - _apply(flipped.tgt_transform, tgt_original)[:, 0]
    np.testing.assert_allclose(turned, -plain, atol=0.05)


def test_non_overlapping_images_raise_a_stage_error():
    reference = _texture((160, 160), seed=11)
    target = _texture((150, 170), seed=12)
    with pytest.raises(StageError, match="at least 20"):
        rectify_pair(reference, target)


def test_a_flat_scene_raises_a_stage_error():
    reference, _, _ = _true_pair()
    warp = dict(flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_CONSTANT, borderValue=float("nan"))
    tgt_img = cv2.warpAffine(reference, TGT_MAP[:2], TGT_SHAPE[::-1], **warp)  # one affine map, no relief
    with pytest.raises(StageError, match="relief"):
        rectify_pair(reference, tgt_img)


def test_bad_parameters_and_inputs_are_refused():
    with pytest.raises(ParamsError, match="output_size"):
        RectifyParams(output_size="largest")
    with pytest.raises(ParamsError, match="min_matches"):
        RectifyParams(min_matches=3)
    with pytest.raises(InputError, match="2-D"):
        rectify_pair(np.zeros((3, 40, 40)), np.zeros((40, 40)))


# ----------------------------------------------------------------------------- real pairs


@pytest.mark.realdata
@pytest.mark.slow
@pytest.mark.parametrize(
    "folder, left, right",
    [("pleiades_gizeh", "img1.tif", "img2.tif"), ("pleiades_ventoux", "left_image.tif", "right_image.tif")],
)
def test_pleiades_pairs_rectify_below_one_pixel(shared_data, folder, left, right):
    reference = tifffile.imread(shared_data / folder / left)
    target = tifffile.imread(shared_data / folder / right)
    rect = rectify_pair(reference, target)
    assert rect.residual_parallax_p90 < 1.0
    assert rect.n_inliers >= 200
    found = _sgbm(rect, margin=8)  # runs through on the rectified pair
    overlap = np.isfinite(rect.reference) & np.isfinite(rect.target)
    assert np.isfinite(found[overlap]).mean() > 0.5
