"""Which way up the affine route turns a pair: the relief skew (radcons.stages.rectify.orientation)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.ndimage

from radcons.errors import ParamsError
from radcons.io import read_raster
from radcons.rpc import Rpc, pair_rpcs
from radcons.stages.rectify.orientation import ORIENTATION_SKEW, relief_skew
from radcons.stages.rectify.run import Rectification, RectifyParams, rectify_pair

GROUND_D, BOX_D = 2, 9


def _boxes_on_ground(seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """A rectified pair of textured ground with 24 boxes standing on it (disparity 9 px over 2 px).

    ``reference(x) = world(x)`` and ``target(x_t) = world(x_t + d_t)``: the reference point
    ``x`` is seen in the target at ``x - d``, the nearer boxes with the larger ``d``.
    """
    rng = np.random.default_rng(seed)
    rows, cols = 384, 384
    world = scipy.ndimage.gaussian_filter(rng.normal(size=(rows, cols + 2 * BOX_D)), 1.5).astype(np.float32)
    disparity_t = np.full((rows, cols), GROUND_D)
    for _ in range(24):
        r, c = rng.integers(10, rows - 40), rng.integers(10, cols - 40)
        disparity_t[r : r + 28, c : c + 28] = BOX_D
    target = np.take_along_axis(world, np.arange(cols)[None, :] + disparity_t, axis=1)
    return world[:, :cols].copy(), target


def test_boxes_standing_on_the_ground_lean_upward_and_the_pair_turned_round_leans_downward():
    reference, target = _boxes_on_ground()
    upright = relief_skew(reference, target, (GROUND_D, BOX_D))
    # turning both images by 180 deg negates every disparity: the boxes become pits
    turned = relief_skew(reference[::-1, ::-1].copy(), target[::-1, ::-1].copy(), (-BOX_D, -GROUND_D))
    assert upright > ORIENTATION_SKEW
    assert turned < -ORIENTATION_SKEW


def test_ground_without_relief_does_not_lean():
    reference, _ = _boxes_on_ground()
    skew = relief_skew(reference, _shifted(reference), (0, 4))
    assert not abs(skew) > ORIENTATION_SKEW  # NaN (a flat disparity) or near 0


def _shifted(image: np.ndarray) -> np.ndarray:
    """``image`` seen GROUND_D px further right: ``target(x - GROUND_D) = image(x)``."""
    return np.pad(image, ((0, 0), (0, GROUND_D)), mode="edge")[:, GROUND_D:]


def test_an_unknown_orient_is_refused():
    with pytest.raises(ParamsError, match=r"^\[rectify\] orient must be one of relief, rotation, got 'sideways'$"):
        RectifyParams(orient="sideways")


def _ground_under(rpc: Rpc, col: float, row: float, height: float) -> tuple[float, float]:
    """Longitude and latitude that ``rpc`` projects to the image pixel ``(col, row)`` at ``height`` (Newton)."""
    lon, lat = rpc.long_off, rpc.lat_off
    for _ in range(8):
        c0, r0 = (float(v[0]) for v in rpc.project(np.array([lon]), np.array([lat]), np.array([height])))
        step = 1e-5
        c1, r1 = (float(v[0]) for v in rpc.project(np.array([lon + step]), np.array([lat]), np.array([height])))
        c2, r2 = (float(v[0]) for v in rpc.project(np.array([lon]), np.array([lat + step]), np.array([height])))
        jacobian = np.array([[c1 - c0, c2 - c0], [r1 - r0, r2 - r0]]) / step
        lon, lat = np.array([lon, lat]) + np.linalg.solve(jacobian, [col - c0, row - r0])
    return float(lon), float(lat)


def _disparity_per_metre(rectification: Rectification, rpcs: tuple[Rpc, Rpc], shape: tuple[int, int]) -> float:
    """How the rectified disparity at the reference's centre changes with height, px/m, from the RPC models."""
    ref_rpc, tgt_rpc = rpcs
    row, col = shape[0] / 2.0, shape[1] / 2.0
    heights = np.array([50.0, 150.0])
    lon, lat = _ground_under(ref_rpc, col, row, 100.0)
    ref_col, ref_row = ref_rpc.project(np.full(2, lon), np.full(2, lat), heights)
    tgt_col, tgt_row = tgt_rpc.project(np.full(2, lon), np.full(2, lat), heights)
    ref_x = rectification.ref_transform[0] @ np.vstack([ref_col, ref_row, np.ones(2)])
    tgt_x = rectification.tgt_transform[0] @ np.vstack([tgt_col, tgt_row, np.ones(2)])
    disparity = ref_x - tgt_x
    return float((disparity[1] - disparity[0]) / (heights[1] - heights[0]))


def test_the_affine_route_turns_the_gizeh_pair_so_that_higher_points_get_larger_disparities(shared_data):
    """Pleiades Gizeh without its RPC models: the rotation rule turns it upside down; its relief turns it back.

    The RPC models (not used by the affine route) say which way up the rectified pair is.
    """
    folder = shared_data / "pleiades_gizeh"
    reference, target = read_raster(folder / "img1.tif"), read_raster(folder / "img2.tif")
    rpcs, _ = pair_rpcs(reference, target)
    assert rpcs is not None
    ref, tgt = reference.as_float32(), target.as_float32()
    by_rotation = rectify_pair(ref, tgt, RectifyParams(method="affine", orient="rotation"))
    by_relief = rectify_pair(ref, tgt, RectifyParams(method="affine"))
    assert _disparity_per_metre(by_rotation, rpcs, ref.shape) < 0
    assert _disparity_per_metre(by_relief, rpcs, ref.shape) > 0
    assert by_relief.orientation.startswith("turned by 180 deg")
    assert by_rotation.orientation == ""


def test_a_relief_that_cannot_be_measured_keeps_the_rotation_rule(monkeypatch):
    """The census run failing (Pandora, memory) is no error: the pair keeps the rotation rule and says why."""
    import radcons.stages.rectify.run as rectify
    from radcons.errors import StageError

    reference, target = _boxes_on_ground()
    by_rotation = rectify_pair(reference, target, RectifyParams(method="affine", orient="rotation"))

    def failing(*args, **kwargs):
        raise StageError("Pandora census matching failed: out of luck")

    monkeypatch.setattr(rectify, "relief_skew", failing)
    kept = rectify_pair(reference, target, RectifyParams(method="affine"))
    np.testing.assert_allclose(kept.ref_transform, by_rotation.ref_transform)
    assert "could not be measured (Pandora census matching failed: out of luck)" in kept.orientation
