"""Pair format and raster I/O: round trips, georeferencing, nodata, bad input."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import tifffile

from radcons.errors import InputError
from radcons.io import Pair, Raster, load_pair, load_pair_files, read_raster, save_pair, write_raster

GEOREF = {
    33550: (12, 3, (0.5, 0.5, 0.0)),
    33922: (12, 6, (0.0, 0.0, 0.0, 500000.0, 4100000.0, 0.0)),
    34735: (3, 16, (1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32633)),
}


def _image(dtype, shape=(40, 50), seed=0):
    rng = np.random.default_rng(seed)
    if np.dtype(dtype).kind == "f":
        return rng.uniform(400, 1900, shape).astype(dtype)
    top = 2047 if dtype == np.uint16 else 255
    return rng.integers(0, top + 1, shape).astype(dtype)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
@pytest.mark.parametrize("suffix", [".tif", ".png"])
def test_raster_round_trip(tmp_path, dtype, suffix):
    data = _image(dtype)
    if suffix == ".png" and dtype == np.float32:
        with pytest.raises(InputError, match="PNG holds"):
            write_raster(tmp_path / f"a{suffix}", data)
        return
    path = write_raster(tmp_path / f"a{suffix}", data)
    back = read_raster(path)
    assert back.data.dtype == data.dtype
    np.testing.assert_array_equal(back.data, data)


def test_geotiff_tags_and_nodata_survive(tmp_path):
    data = np.maximum(_image(np.uint16), 1)
    data[:3, :3] = 0
    path = write_raster(tmp_path / "geo.tif", data, GEOREF, nodata=0)
    # an independent reader sees the georeferencing tags
    with tifffile.TiffFile(path) as tif:
        tags = tif.pages.first.tags
        assert tags[33922].value == GEOREF[33922][2]
        assert tags[34735].value == GEOREF[34735][2]
        assert tags[42113].value.strip("\x00") == "0"
    back = read_raster(path)
    assert back.nodata == 0
    assert {code: value for code, (_, _, value) in back.georef.items()} == {
        code: value for code, (_, _, value) in GEOREF.items()
    }
    assert not back.valid_mask()[:3, :3].any() and back.valid_mask()[3:, 3:].all()


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
def test_pair_round_trip(tmp_path, dtype):
    rng = np.random.default_rng(1)
    ref, tgt = _image(dtype, seed=1), _image(dtype, seed=2)
    disparity = rng.uniform(0, 20, ref.shape).astype(np.float32)
    disparity[0, :5] = np.nan
    labels = rng.integers(0, 7, ref.shape).astype(np.int32)
    pair = Pair(
        Raster(ref, GEOREF, 0 if dtype != np.float32 else None),
        Raster(tgt, GEOREF, 0 if dtype != np.float32 else None),
        disparity=disparity,
        reference_objects=labels,
        target_objects=labels[:, ::-1].copy(),
        change_mask=labels == 3,
        metadata={"sensor": "WV2 / QB", "gsd_m": 0.5, "bit_depth": 11, "note": "hand-written"},
        name="round",
    )
    save_pair(pair, tmp_path / "p")
    back = load_pair(tmp_path / "p")
    np.testing.assert_array_equal(back.reference.data, ref)
    np.testing.assert_array_equal(back.target.data, tgt)
    np.testing.assert_array_equal(back.disparity, disparity)  # NaN positions equal too
    np.testing.assert_array_equal(back.reference_objects, labels)
    np.testing.assert_array_equal(back.target_objects, labels[:, ::-1])
    np.testing.assert_array_equal(back.change_mask, labels == 3)
    assert back.metadata == pair.metadata
    assert back.reference.nodata == pair.reference.nodata
    assert {c: v for c, (_, _, v) in back.target.georef.items()} == {c: v for c, (_, _, v) in GEOREF.items()}
    assert back.name == "round" and back.rectified


def test_hand_written_manifest(tmp_path):
    write_raster(tmp_path / "left.png", _image(np.uint8, seed=3))
    write_raster(tmp_path / "right.png", _image(np.uint8, seed=4))
    (tmp_path / "pair.toml").write_text(
        'reference = "left.png"\ntarget = "right.png"\nnodata = 0\n\n[metadata]\nsensor = "BJ-2"\ndate = "2016"\n'
    )
    pair = load_pair(tmp_path)
    assert pair.reference.nodata == 0 and pair.metadata["sensor"] == "BJ-2"
    assert pair.disparity is None and pair.rectified


def test_two_files_directly(tmp_path):
    a = write_raster(tmp_path / "a.tif", _image(np.float32, seed=5))
    b = write_raster(tmp_path / "b.tif", _image(np.float32, seed=6))
    pair = load_pair_files(a, b)
    assert pair.shape == (40, 50)


def test_nan_is_invalid(tmp_path):
    data = _image(np.float32)
    data[5, 5] = np.nan
    raster = read_raster(write_raster(tmp_path / "n.tif", data))
    assert not raster.valid_mask()[5, 5] and raster.valid_mask().sum() == data.size - 1


def test_interrupted_write_leaves_previous_file(tmp_path, monkeypatch):
    path = write_raster(tmp_path / "keep.tif", _image(np.uint8, seed=7))
    before = path.read_bytes()

    def explode(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(tifffile, "imwrite", explode)
    with pytest.raises(OSError):
        write_raster(path, _image(np.uint8, seed=8))
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["keep.tif"]


# ------------------------------------------------------------------------- bad input


def test_mismatched_sizes(tmp_path):
    a = write_raster(tmp_path / "a.png", _image(np.uint8, (40, 50)))
    b = write_raster(tmp_path / "b.png", _image(np.uint8, (40, 51)))
    with pytest.raises(InputError, match=r"b\.png.*needs equal sizes"):
        load_pair_files(a, b, rectified=True)
    assert load_pair_files(a, b, rectified=False).target.data.shape == (40, 51)
    # Unforced, two sizes cannot be a rectified pair.
    assert not load_pair_files(a, b).rectified
    assert load_pair_files(a, a).rectified


def test_rgb_and_multiband_images_become_one_grey_band(tmp_path):
    import cv2
    import tifffile

    rgb = np.random.default_rng(0).integers(0, 256, (20, 30, 3), dtype=np.uint8)
    expected = np.clip(np.rint(rgb.astype(np.float64) @ [0.299, 0.587, 0.114]), 0, 255).astype(np.uint8)
    tifffile.imwrite(tmp_path / "rgb.tif", rgb, photometric="rgb")
    cv2.imwrite(str(tmp_path / "rgb.png"), rgb[..., ::-1])  # OpenCV writes B, G, R
    for name in ("rgb.tif", "rgb.png"):
        raster = read_raster(tmp_path / name)
        assert raster.data.dtype == np.uint8 and "luminance" in raster.bands
        assert np.abs(raster.data.astype(int) - expected).max() <= 1, name
    assert np.array_equal(read_raster(tmp_path / "rgb.tif", band=2).data, rgb[..., 1])
    cube = np.random.default_rng(1).integers(0, 4096, (5, 20, 30), dtype=np.uint16)
    tifffile.imwrite(tmp_path / "ms.tif", cube, photometric="minisblack", planarconfig="separate")
    raster = read_raster(tmp_path / "ms.tif")
    assert raster.bands == "mean of 5 bands"
    assert np.abs(raster.data.astype(float) - cube.mean(axis=0)).max() <= 0.5
    with pytest.raises(InputError, match="--band 7 is out of range: the image has 5"):
        read_raster(tmp_path / "ms.tif", band=7)
    tifffile.imwrite(tmp_path / "cube.tif", np.zeros((20, 10, 17), np.uint8), photometric="minisblack", planarconfig="contig")
    with pytest.raises(InputError, match="17 bands"):
        read_raster(tmp_path / "cube.tif")


def test_an_rgb_image_keeps_its_green_leaf_index_beside_the_grey_band(tmp_path):
    import cv2

    rgb = np.zeros((20, 16, 3), np.uint8)
    rgb[..., 0], rgb[..., 1], rgb[..., 2] = 60, 120, 40  # a leaf
    rgb[5:, :] = (150, 140, 130)  # a roof
    rgb[0, 0] = 0  # black: no index
    tifffile.imwrite(tmp_path / "rgb.tif", rgb, photometric="rgb")
    cv2.imwrite(str(tmp_path / "rgb.png"), rgb[..., ::-1])
    for name in ("rgb.tif", "rgb.png"):
        greenness = read_raster(tmp_path / name).greenness
        assert greenness.shape == (20, 16) and np.isnan(greenness[0, 0]), name
        assert greenness[1, 1] == pytest.approx((240 - 60 - 40) / (240 + 60 + 40)), name
        assert greenness[7, 4] == pytest.approx((280 - 150 - 130) / (280 + 150 + 130)), name
    assert read_raster(tmp_path / "rgb.tif", band=2).greenness is None  # a band chosen: no colour
    rgba = np.concatenate([rgb, np.full((20, 16, 1), 255, np.uint8)], axis=-1)
    tifffile.imwrite(tmp_path / "rgba.tif", rgba, photometric="rgb", extrasamples=[2])
    np.testing.assert_array_equal(read_raster(tmp_path / "rgba.tif").greenness, read_raster(tmp_path / "rgb.tif").greenness)
    grey = write_raster(tmp_path / "grey.tif", rgb[..., 1])
    assert read_raster(grey).greenness is None
    cube = np.random.default_rng(1).integers(1, 4096, (4, 20, 16), dtype=np.uint16)
    tifffile.imwrite(tmp_path / "ms.tif", cube, photometric="minisblack", planarconfig="separate")
    assert read_raster(tmp_path / "ms.tif").greenness is None  # band order of 4 bands unknown


def test_all_nan_and_constant_refused(tmp_path):
    nan = write_raster(tmp_path / "nan.tif", np.full((16, 16), np.nan, np.float32))
    with pytest.raises(InputError, match=r"nan\.tif.*NaN or nodata"):
        read_raster(nan)
    flat = write_raster(tmp_path / "flat.tif", np.full((16, 16), 9, np.uint8))
    with pytest.raises(InputError, match=r"flat\.tif.*constant"):
        read_raster(flat)
    nodata_only = write_raster(tmp_path / "nd.tif", np.full((16, 16), 3, np.uint16), nodata=3)
    with pytest.raises(InputError, match="NaN or nodata"):
        read_raster(nodata_only)


def test_unreadable_and_truncated(tmp_path):
    junk = tmp_path / "junk.tif"
    junk.write_bytes(b"this is not a tiff")
    with pytest.raises(InputError, match=r"junk\.tif.*unreadable"):
        read_raster(junk)
    good = write_raster(tmp_path / "good.png", _image(np.uint8, (64, 64)))
    cut = tmp_path / "cut.png"
    cut.write_bytes(good.read_bytes()[: len(good.read_bytes()) // 2])
    with pytest.raises(InputError, match=r"cut\.png.*unreadable"):
        read_raster(cut)
    tif = write_raster(tmp_path / "t.tif", _image(np.uint16, (64, 64)))
    short = tmp_path / "short.tif"
    short.write_bytes(tif.read_bytes()[:300])
    with pytest.raises(InputError, match=r"short\.tif"):
        read_raster(short)
    with pytest.raises(InputError, match="file not found"):
        read_raster(tmp_path / "missing.tif")


def test_manifest_problems(tmp_path):
    with pytest.raises(InputError, match="no pair.toml"):
        load_pair(tmp_path)
    write_raster(tmp_path / "left.png", _image(np.uint8))
    (tmp_path / "pair.toml").write_text('reference = "left.png"\ntarget = "gone.png"\n')
    with pytest.raises(InputError, match=r"pair\.toml.*target names a missing file 'gone\.png'"):
        load_pair(tmp_path)
    (tmp_path / "pair.toml").write_text('reference = "left.png"\n')
    with pytest.raises(InputError, match="required key 'target'"):
        load_pair(tmp_path)
    (tmp_path / "pair.toml").write_text('reference = "left.png"\ntarget = "../escape.png"\n')
    with pytest.raises(InputError, match="outside the pair folder"):
        load_pair(tmp_path)
    (tmp_path / "pair.toml").write_text('reference = "left.png"\ntarget = [1\n')
    with pytest.raises(InputError, match="malformed manifest"):
        load_pair(tmp_path)
    (tmp_path / "pair.toml").write_text('reference = "left.png"\ntarget = "left.png"\nrefrence = "x"\n')
    with pytest.raises(InputError, match="unknown manifest keys: refrence"):
        load_pair(tmp_path)


def test_a_manifest_names_files_inside_its_folder_only(tmp_path):
    from radcons import preflight
    from radcons.io import read_manifest

    folder = tmp_path / "pair"
    folder.mkdir()
    write_raster(folder / "left.png", _image(np.uint8))
    outside = write_raster(tmp_path / "outside.png", _image(np.uint8, seed=1))
    manifest = folder / "pair.toml"
    (folder / "leaves.png").symlink_to(outside)
    (folder / "loop.png").symlink_to(folder / "loop.png")
    (folder / "sub").mkdir()
    (folder / "sub" / "inside.png").symlink_to(folder / "left.png")
    cases = {
        str(outside): r"target = '/.*outside\.png' points outside the pair folder",
        "../outside.png": r"target = '\.\./outside\.png' points outside the pair folder",
        "sub/../../outside.png": r"target = 'sub/\.\./\.\./outside\.png' points outside the pair folder",
        "leaves.png": r"target = 'leaves\.png' is a symbolic link that leads outside the pair folder .*outside\.png",
        "loop.png": r"target = 'loop\.png': a symbolic link loop",
        "sub": r"target = 'sub': a folder, not a file",
    }
    for target, message in cases.items():
        manifest.write_text(f'reference = "left.png"\ntarget = {target!r}\n')
        for read in (load_pair, read_manifest, preflight.input_files, preflight.image_files):
            with pytest.raises(InputError, match=r"pair\.toml: " + message):
                read([folder] if read in (preflight.input_files, preflight.image_files) else folder)
    manifest.write_text('reference = "left.png"\ntarget = "left.png"\ndisparity = "/etc/hostname"\n')
    with pytest.raises(InputError, match="disparity = '/etc/hostname' points outside"):
        read_manifest(folder)
    manifest.write_text('reference = "left.png"\ntarget = "sub/inside.png"\n')  # a link that stays inside
    assert read_manifest(folder).files["target"] == (folder / "left.png").resolve()


def test_jpeg_images_are_read_like_the_other_gdal_formats(tmp_path):
    import cv2

    from radcons.io import read_header

    grey = _image(np.uint8, (48, 64))
    smooth = cv2.GaussianBlur(grey, (0, 0), 2)  # little for JPEG to lose
    for suffix in (".jpg", ".jpeg"):
        path = tmp_path / f"grey{suffix}"
        assert cv2.imwrite(str(path), smooth, [cv2.IMWRITE_JPEG_QUALITY, 95])
        raster = read_raster(path)
        assert raster.data.shape == (48, 64) and raster.data.dtype == np.uint8 and raster.gdal["crs"] is None
        assert np.abs(raster.data.astype(int) - smooth).mean() < 2
        assert read_header(path).shape == (48, 64)
    colour = tmp_path / "colour.jpg"
    cv2.imwrite(str(colour), np.dstack([smooth, smooth, smooth]))
    assert read_raster(colour).bands == "luminance (ITU-R BT.601) of 3 bands (RGB)"
    assert read_header(colour).bands == 3
    pair = load_pair_files(tmp_path / "grey.jpg", colour)
    assert pair.reference.data.shape == pair.target.data.shape == (48, 64)


def test_ground_truth_size_checked(tmp_path):
    write_raster(tmp_path / "l.png", _image(np.uint8))
    write_raster(tmp_path / "r.png", _image(np.uint8, seed=2))
    write_raster(tmp_path / "d.tif", np.zeros((10, 10), np.float32))
    (tmp_path / "pair.toml").write_text('reference = "l.png"\ntarget = "r.png"\ndisparity = "d.tif"\n')
    with pytest.raises(InputError, match=r"d\.tif.*differs"):
        load_pair(tmp_path)


def test_float_nodata_nan_not_written_in_manifest(tmp_path):
    pair = Pair(Raster(_image(np.float32), {}, math.nan), Raster(_image(np.float32, seed=3), {}, math.nan))
    save_pair(pair, tmp_path / "f")
    assert "nodata" not in (tmp_path / "f" / "pair.toml").read_text()


def test_written_files_get_ordinary_permissions(tmp_path):
    import os
    import stat

    umask = os.umask(0o022)
    try:
        raster = write_raster(tmp_path / "p.tif", _image(np.uint8))
        save_pair(Pair(Raster(_image(np.uint8)), Raster(_image(np.uint8, seed=1))), tmp_path / "pair")
    finally:
        os.umask(umask)
    for path in (raster, tmp_path / "pair" / "pair.toml", tmp_path / "pair" / "target.tif"):
        assert stat.S_IMODE(path.stat().st_mode) == 0o644


@pytest.mark.realdata
def test_nitf_and_jpeg2000_read_with_their_georeferencing_and_write_it_back(shared_data, tmp_path):
    import rasterio

    nitf = read_raster(shared_data / "worldview3_buenos_aires_nitf" / "wv3_20.NTF")
    assert nitf.data.shape == (500, 500) and nitf.data.dtype == np.uint16
    assert nitf.gdal["rpcs"]["line_off"] > 0  # the RPC00B model came with it
    jp2 = read_raster(shared_data / "sentinel2_two_dates" / "ref_S2A_20160608T153121_T33UUU_sub.jp2")
    assert jp2.data.shape == (3200, 2400) and "32633" in jp2.gdal["crs"]
    assert jp2.gdal["transform"] == (330000.0, 10.0, 0.0, 5862000.0, 0.0, -10.0)
    for name, raster in (("nitf.tif", nitf), ("jp2.tif", jp2)):
        write_raster(tmp_path / name, raster.data, None, raster.nodata, raster.gdal)
        with rasterio.open(tmp_path / name) as written:
            assert np.array_equal(written.read(1), raster.data)
            assert tuple(written.transform.to_gdal()) == raster.gdal["transform"] or raster.gdal["crs"] is None
            assert bool(written.rpcs) == bool(raster.gdal["rpcs"])
            assert written.block_shapes == [(256, 256)]
