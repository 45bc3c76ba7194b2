"""Deciding a pair's geometry when nobody said: sizes, then the vertical parallax of matches."""

from __future__ import annotations

import numpy as np
import pytest

from demo_data_gen import generate
from radcons.geometry import UNRECTIFIED_PARALLAX_PX, median_vertical_parallax, settle_geometry
from radcons.io import load_pair_files, write_raster


@pytest.fixture(scope="module")
def demo():
    return generate(size=256, seed=0, scenario="none")


def _files(tmp_path, reference, target):
    return write_raster(tmp_path / "a.tif", reference), write_raster(tmp_path / "b.tif", target)


def test_a_rectified_pair_of_equal_sizes_stays_rectified(tmp_path, demo):
    pair = settle_geometry(load_pair_files(*_files(tmp_path, demo.reference.data, demo.target.data)))
    assert pair.rectified and pair.metadata["geometry"].startswith("rectified: median vertical parallax")


def test_a_vertical_offset_makes_an_equal_size_pair_unrectified(tmp_path, demo):
    shifted = np.roll(demo.target.data, 24, axis=0)  # rows no longer correspond: 24 px of parallax
    parallax, count = median_vertical_parallax(demo.reference.as_float32(), shifted.astype(np.float32))
    assert count > 20 and abs(parallax - 24) < 2
    pair = settle_geometry(load_pair_files(*_files(tmp_path, demo.reference.data, shifted)))
    assert not pair.rectified and parallax > UNRECTIFIED_PARALLAX_PX
    assert pair.metadata["geometry"].startswith("unrectified")


def test_given_geometry_is_never_second_guessed(tmp_path, demo):
    shifted = np.roll(demo.target.data, 24, axis=0)
    pair = settle_geometry(load_pair_files(*_files(tmp_path, demo.reference.data, shifted), rectified=True))
    assert pair.rectified and "geometry" not in pair.metadata
    assert "beyond 8 px" in pair.metadata["rows"] and np.array_equal(pair.target.data, shifted)  # not levelled either
    smaller = settle_geometry(load_pair_files(*_files(tmp_path, demo.reference.data, demo.target.data[:-5])))
    assert not smaller.rectified and "differ in size" in smaller.metadata["geometry"]


@pytest.mark.realdata
def test_the_raw_pleiades_pair_is_recognised(shared_data):
    folder = shared_data / "pleiades_kahramanmaras_prepost"
    pair = settle_geometry(load_pair_files(folder / "pre_event_img1.tif", folder / "pre_event_img2.tif"))
    assert not pair.rectified
    us3d = shared_data / "us3d_jacksonville_multidate"
    pair = settle_geometry(load_pair_files(us3d / "JAX_072_011_022_LEFT_RGB.tif", us3d / "JAX_072_011_022_RIGHT_RGB.tif"))
    assert pair.rectified
