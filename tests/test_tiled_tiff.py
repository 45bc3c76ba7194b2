"""Tiled GeoTIFFs from blocks encoded tile by tile, against GDAL writing the same image."""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest
import rasterio
import tifffile

from radcons.io import tiled_tiff
from radcons.io.tiled_tiff import Pyramid, TiledGeoTiffWriter, encode_tile

RPCS = dict(
    height_off=10.0, height_scale=100.0, lat_off=36.0, lat_scale=0.1, long_off=37.0, long_scale=0.1,
    line_off=500.0, line_scale=500.0, samp_off=600.0, samp_scale=600.0,
    line_num_coeff=[0.0, 1.0] + [0.0] * 18, line_den_coeff=[1.0] + [0.0] * 19,
    samp_num_coeff=[0.0, 0.0, 1.0] + [0.0] * 17, samp_den_coeff=[1.0] + [0.0] * 19,
)
UTM = {"crs": rasterio.crs.CRS.from_epsg(32637).to_wkt(), "transform": (500000.0, 0.5, 0.0, 4100000.0, 0.0, -0.5), "rpcs": RPCS}


def _write_by_tiles(path: Path, image: np.ndarray, tile: int, gdal: dict, nodata: float | None) -> Pyramid:
    """Encode ``image`` tile by tile (in a shuffled order, as workers finish) and write it."""
    pyramid = Pyramid.plan(image.shape, tile)
    origins = [(r, c) for r in range(0, image.shape[0], tile) for c in range(0, image.shape[1], tile)]
    random.Random(0).shuffle(origins)
    with TiledGeoTiffWriter(path, pyramid, image.dtype, gdal, nodata) as writer:
        for r, c in origins:
            writer.add(encode_tile(image[r : r + tile, c : c + tile], (r, c), pyramid, nodata))
        writer.finish()
    return pyramid


def _block_means(image: np.ndarray, factor: int, nodata: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Means of the valid pixels of each ``factor`` x ``factor`` block straight from full
    resolution (the independent reference), and which blocks are all and partly nodata."""
    pad = ((0, -image.shape[0] % factor), (0, -image.shape[1] % factor))
    valid = np.pad(image != nodata, pad)
    inside = np.pad(np.ones(image.shape, bool), pad)
    values = np.pad(np.where(image != nodata, image, 0).astype(np.float64), pad)

    def blocks(a: np.ndarray) -> np.ndarray:
        return a.reshape(a.shape[0] // factor, factor, -1, factor).sum(axis=(1, 3))

    count = blocks(valid.astype(np.float64))
    return blocks(values) / np.maximum(count, 1), count == 0, count < blocks(inside.astype(np.float64))


def _terrain(shape: tuple[int, int], seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    rows, columns = np.mgrid[: shape[0], : shape[1]]
    smooth = 2000 + 800 * np.sin(rows / 37.0) * np.cos(columns / 53.0)
    return (smooth + rng.normal(0, 40, shape)).clip(1, 65535).astype(np.uint16)


@pytest.mark.parametrize("shape, tile", [((1100, 1300), 256), ((2100, 2300), 1024), ((700, 600), 64)])
def test_tiles_written_in_any_order_read_back_as_gdal_writes_them(tmp_path, shape, tile):
    image = _terrain(shape, seed=1)
    image[:40, :70] = 0  # nodata in a corner, across block and tile borders of every level
    path = tmp_path / "out.tif"
    pyramid = _write_by_tiles(path, image, tile, UTM, 0)
    with rasterio.open(path) as dataset:
        np.testing.assert_array_equal(dataset.read(1), image)
        assert dataset.crs.to_epsg() == 32637
        assert dataset.transform.to_gdal() == UTM["transform"]
        assert dataset.nodata == 0
        rpcs = dataset.rpcs.to_dict()
        for key, value in RPCS.items():
            np.testing.assert_allclose(rpcs[key], value, err_msg=key)
        assert dataset.block_shapes[0] == (pyramid.block, pyramid.block)
        assert dataset.compression.value == "DEFLATE"
        factors = dataset.overviews(1)
        ours = [dataset.read(1, out_shape=(-(-shape[0] // f), -(-shape[1] // f))) for f in factors]
    # the overviews GDAL builds for a large image (radcons.io.gdal.write_gdal): 2, 4, ... down to 256 px
    assert factors == [2**k for k in range(1, 12) if max(shape) / 2**k >= 256]
    for factor, mine in zip(factors, ours):
        exact, empty, partial = _block_means(image, factor, 0)
        # each level is rounded before the next is averaged from it: half a count per level
        difference = np.abs(mine - exact)[~partial]
        assert difference.max() <= 0.5 * np.log2(factor) + 1e-9, factor
        assert np.array_equal(mine == 0, empty), factor  # nodata exactly where a block has no valid pixel


def test_float_images_keep_nan_and_average_the_rest(tmp_path):
    image = np.random.default_rng(2).normal(100.0, 5.0, (600, 520)).astype(np.float32)
    image[100:104, 200:204] = np.nan  # one whole 2 x 2 and 4 x 4 group
    image[301, 7] = np.nan
    path = tmp_path / "float.tif"
    _write_by_tiles(path, image, 128, {"crs": None, "transform": (0, 1, 0, 0, 0, 1), "rpcs": None}, None)
    with rasterio.open(path) as dataset:
        np.testing.assert_array_equal(dataset.read(1), image)  # NaN compares equal in assert_array_equal
        assert dataset.crs is None and dataset.nodata is None
        half = dataset.read(1, out_shape=(300, 260))
    expected = np.nanmean(image.reshape(300, 2, 260, 2), axis=(1, 3))
    np.testing.assert_allclose(half, expected, rtol=1e-6)


def test_a_large_output_is_a_bigtiff(tmp_path, monkeypatch):
    monkeypatch.setattr(tiled_tiff, "BIGTIFF_FROM", 0)
    image = _terrain((520, 530), seed=3)
    _write_by_tiles(tmp_path / "big.tif", image, 256, UTM, None)
    with tifffile.TiffFile(tmp_path / "big.tif") as tiff:
        assert tiff.is_bigtiff
    with rasterio.open(tmp_path / "big.tif") as dataset:
        np.testing.assert_array_equal(dataset.read(1), image)
        assert dataset.crs.to_epsg() == 32637


def test_a_missing_tile_is_named_and_the_scratch_file_removed(tmp_path):
    image = _terrain((512, 512), seed=4)
    pyramid = Pyramid.plan(image.shape, 256)
    with TiledGeoTiffWriter(tmp_path / "out.tif", pyramid, image.dtype, UTM, None) as writer:
        for r, c in [(0, 0), (0, 256), (256, 0)]:
            writer.add(encode_tile(image[r : r + 256, c : c + 256], (r, c), pyramid, None))
        with pytest.raises(ValueError, match="block 1, 1 of level 0 was never written"):
            writer.finish()
    assert not any(p.name.endswith(".blocks") for p in tmp_path.iterdir())


def test_tiles_must_be_whole_blocks():
    with pytest.raises(ValueError, match="multiple of 64"):
        Pyramid.plan((1000, 1000), 100)
    assert Pyramid.plan((40000, 40000), 1024) == Pyramid((40000, 40000), 256, 8, 3)
