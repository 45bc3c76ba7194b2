"""Scene mode's light correction across the scene (:mod:`radcons.scene.light`) against the
in-memory correction (:mod:`radcons.stages.refine.light`) on the same images."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.ndimage

from radcons.io import write_raster
from radcons.scene import stats as st
from radcons.scene.light import block_moved_moments, block_tile_moments, scene_light, scene_spread, stage_values
from radcons.scene.source import SceneImage
from radcons.stages.refine.light import light_spread, local_light_correction


def _scene_image(tmp_path: Path, name: str, data: np.ndarray) -> SceneImage:
    path = write_raster(tmp_path / name, data)
    return SceneImage(path, data.shape, data.dtype, None, {"crs": None, "transform": (0, 1, 0, 0, 0, 1), "rpcs": None})


@pytest.mark.parametrize("tiles", [1, 4, 6])
def test_summed_over_row_blocks_the_tiles_equal_the_in_memory_correction(tmp_path, tiles):
    rng = np.random.default_rng(7)
    shape = (150, 190)
    texture = scipy.ndimage.gaussian_filter(rng.random(shape), 2.0)
    reference = np.rint(200 + 3000 * (texture - texture.min()) / np.ptp(texture)).astype(np.uint16)
    x = (np.arange(shape[1]) + 0.5) / shape[1]
    target = (0.4 * reference * (0.7 + 0.6 * x)[None, :] + rng.normal(0, 8, shape)).astype(np.float32)
    target[rng.random(shape) < 0.03] = np.nan
    target[:, :20] = np.nan
    lut = (np.linspace(np.nanmin(target), np.nanmax(target), 50), np.linspace(100.0, 3500.0, 50) ** 1.02)
    scale = 1.3
    ref_image, tgt_image = _scene_image(tmp_path, "r.tif", reference), _scene_image(tmp_path, "t.tif", target)
    blocks = st.row_blocks(shape, 40 * shape[1])  # four row blocks, cutting across the tiles
    assert len(blocks) == 4

    moments = [
        np.sum([block_tile_moments(b, image, tiles, lam, table) for b in blocks], axis=0)
        for image, lam, table in ((ref_image, scale, None), (tgt_image, 1.0, lut))
    ]
    field = scene_light(*moments, tiles, shape)
    # the images as the refine stage sees them in memory: the reference times lambda, the
    # target through the background's mapping
    ref_stage = reference.astype(np.float32) * np.float32(scale)
    mapped = np.full(shape, np.nan, np.float32)
    valid = np.isfinite(target)
    mapped[valid] = np.interp(target[valid], *lut)
    np.testing.assert_array_equal(stage_values(target, 1.0, lut), mapped)
    expected = local_light_correction(ref_stage, mapped, tiles)
    np.testing.assert_allclose(field.apply(mapped), expected, rtol=1e-5, atol=1e-3)
    # a window applies the field at its place in the scene
    np.testing.assert_allclose(field.apply(mapped[60:110, 30:170], (60, 30)), expected[60:110, 30:170], rtol=1e-5, atol=1e-3)

    moved = np.sum([block_moved_moments(b, tgt_image, lut, 1.0, field) for b in blocks], axis=0)
    reference_stats = st.merge_stats([st.block_stats(b, ref_image) for b in blocks])
    assert scene_spread(moved, reference_stats, scale) == pytest.approx(light_spread(ref_stage, mapped, expected), rel=1e-4)
