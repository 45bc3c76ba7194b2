"""RPC models (reading, projection) and the RPC-based epipolar rectification.

The synthetic pair is rendered from two affine cameras written as RPCs (linear numerators,
unit denominators) looking at a textured ground at a known altitude with a raised block.
Its answers follow from the cameras alone: the epipolar parallax per metre of height, the
heights of the ground and the block, and common rows. The real samples of shared/data
(Pleiades .geom files, the WorldView-3 NITF) check the readers against GDAL's and
shareloc's and against the crop offsets the data set documents.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.ndimage

from radcons.errors import InputError, StageError
from radcons.io import read_raster
from radcons.rpc import Rpc, pair_rpcs, read_rpc, rpc_from_geom, rpc_from_tiff_tag
from radcons.stages.rectify.features import match_sift
from radcons.stages.rectify.rpc import RpcMisfit
from radcons.stages.rectify.run import RectifyParams, rectify_pair

# Normalisation of the synthetic models: 1 unit of normalised longitude / latitude is 1000
# scene pixels; heights 100 +- 500 m.
HEIGHT_OFF, HEIGHT_SCALE = 100.0, 500.0
LON_OFF, LAT_OFF, DEG_SCALE = 10.0, 45.0, 0.01
GROUND_H, BLOCK_H = 112.0, 136.0
BLOCK = ((-0.02, 0.06), (-0.05, 0.04))  # normalised (longitude, latitude) box of the block
SHAPE = (260, 250)
# Linear parts (column, row) per normalised (lon, lat, height) of each camera, scene pixels.
REF_CAMERA = np.array([[1000.0, 40.0, 10.0], [-25.0, -1000.0, 400.0]])
TGT_CAMERA = np.array([[990.0, 55.0, -5.0], [-20.0, -1010.0, -380.0]])
REF_OFFSET, TGT_OFFSET = (880.0, 1890.0), (893.0, 1860.0)  # crops in their scenes (col, row)


def _affine_rpc(camera: np.ndarray, crop_offset: tuple[float, float]) -> Rpc:
    """An RPC whose numerators are linear and denominators 1: an affine camera."""
    def numerator(row: np.ndarray) -> tuple[float, ...]:
        return (0.0, *(row / 1000.0), *([0.0] * 16))

    unit = (1.0, *([0.0] * 19))
    return Rpc(
        line_off=2000.0, samp_off=1000.0, lat_off=LAT_OFF, long_off=LON_OFF, height_off=HEIGHT_OFF,
        line_scale=1000.0, samp_scale=1000.0, lat_scale=DEG_SCALE, long_scale=DEG_SCALE, height_scale=HEIGHT_SCALE,
        line_num_coeff=numerator(camera[1]), line_den_coeff=unit, samp_num_coeff=numerator(camera[0]),
        samp_den_coeff=unit, crop_offset=crop_offset, source="synthetic affine camera",
    )


def _texture() -> np.ndarray:
    noise = np.random.default_rng(7).standard_normal((900, 900))
    smooth = scipy.ndimage.gaussian_filter(noise, 1.5)
    return (300.0 + 1500.0 * (smooth - smooth.min()) / np.ptp(smooth)).astype(np.float32)


def _render(camera: np.ndarray, offset: tuple[float, float], texture: np.ndarray) -> np.ndarray:
    """The crop seen by ``camera``: the block's top where the ray at its height meets it, else ground."""
    rows, cols = np.indices(SHAPE, dtype=np.float64)
    pixel = np.stack([cols + offset[0] - 1000.0, rows + offset[1] - 2000.0], axis=-1)
    inverse = np.linalg.inv(camera[:, :2])

    def ground(height: float) -> np.ndarray:
        h_n = (height - HEIGHT_OFF) / HEIGHT_SCALE
        return (pixel - camera[:, 2] * h_n) @ inverse.T  # normalised (lon, lat)

    on_ground, on_block = ground(GROUND_H), ground(BLOCK_H)
    (l0, l1), (p0, p1) = BLOCK
    top = (on_block[..., 0] > l0) & (on_block[..., 0] < l1) & (on_block[..., 1] > p0) & (on_block[..., 1] < p1)
    lonlat = np.where(top[..., None], on_block, on_ground)
    texture_rc = [(lonlat[..., 1] + 0.45) * 1000.0, (lonlat[..., 0] + 0.45) * 1000.0]
    return scipy.ndimage.map_coordinates(texture, texture_rc, order=3).astype(np.float32)


def _parallax_per_metre() -> float:
    """Epipolar parallax of one metre of height, reference pixels: |v_r - J_r J_t^-1 v_t|."""
    w = REF_CAMERA[:, 2] - REF_CAMERA[:, :2] @ np.linalg.solve(TGT_CAMERA[:, :2], TGT_CAMERA[:, 2])
    return float(np.linalg.norm(w)) / HEIGHT_SCALE


@pytest.fixture(scope="module")
def synthetic():
    texture = _texture()
    reference, target = _render(REF_CAMERA, REF_OFFSET, texture), _render(TGT_CAMERA, TGT_OFFSET, texture)
    rpcs = (_affine_rpc(REF_CAMERA, REF_OFFSET), _affine_rpc(TGT_CAMERA, TGT_OFFSET))
    return reference, target, rpcs, rectify_pair(reference, target, RectifyParams(), rpcs)


# ----------------------------------------------------------------------------- models


def test_projection_of_an_affine_rpc_is_the_affine_camera():
    rpc = _affine_rpc(REF_CAMERA, REF_OFFSET)
    lon, lat, h = np.array([10.001, 9.998]), np.array([45.002, 44.999]), np.array([150.0, -20.0])
    col, row = rpc.project(lon, lat, h)
    normalised = np.stack([(lon - LON_OFF) / DEG_SCALE, (lat - LAT_OFF) / DEG_SCALE, (h - HEIGHT_OFF) / HEIGHT_SCALE])
    expected = REF_CAMERA @ normalised + np.array([[1000.0 - REF_OFFSET[0]], [2000.0 - REF_OFFSET[1]]])
    np.testing.assert_allclose(np.stack([col, row]), expected, atol=1e-9)


def test_tiff_tag_order_is_gdal_s():
    values = [0.5, 0.3, 11.0, 12.0, 45.0, 10.0, 100.0, 21.0, 22.0, 0.1, 0.2, 500.0]
    values += list(range(1, 21)) + [1.0] + [0.0] * 19 + list(range(21, 41)) + [1.0] + [0.0] * 19
    rpc = rpc_from_tiff_tag(tuple(values), "x.tif (TIFF RPC tag)")
    assert (rpc.line_off, rpc.samp_off, rpc.lat_off, rpc.long_off, rpc.height_off) == (11, 12, 45, 10, 100)
    assert (rpc.line_scale, rpc.samp_scale, rpc.long_scale, rpc.height_scale) == (21, 22, 0.2, 500)
    assert rpc.line_num_coeff[0] == 1 and rpc.samp_num_coeff[0] == 21 and rpc.samp_den_coeff[0] == 1
    with pytest.raises(InputError, match="holds 91 numbers"):
        rpc_from_tiff_tag(tuple(values[:91]), "x.tif")


def test_geom_problems_name_the_file(tmp_path):
    path = tmp_path / "a.geom"
    path.write_text("type: ossimRpcModel\nline_off: 1\n")
    with pytest.raises(InputError, match=r"a\.geom: RPC keyword 'samp_off' missing"):
        rpc_from_geom(path)
    path.write_text("type: ossimPleiadesModel\n")
    with pytest.raises(InputError, match=r"a\.geom: not an RPC model .*ossimPleiadesModel"):
        rpc_from_geom(path)


# ----------------------------------------------------------------------------- synthetic pair


def test_synthetic_pair_is_rectified_from_its_models(synthetic):
    *_, rect = synthetic
    assert rect.method == "rpc" and rect.reason.startswith("RPC models of both images")
    assert abs(rect.rpc_row_offset) < 0.3  # exact models: no pointing error
    assert rect.metres_per_pixel == pytest.approx(1.0 / _parallax_per_metre(), rel=0.01)


def test_rows_correspond_after_rpc_rectification(synthetic):
    *_, rect = synthetic
    matches = match_sift(rect.reference, rect.target, RectifyParams(ratio=0.7))
    dy = np.abs(matches.ref_xy[:, 1] - matches.tgt_xy[:, 1])
    assert len(matches) > 100
    assert np.median(dy) < 0.3 and np.percentile(dy, 90) < 0.8


def test_heights_of_ground_and_block_come_back_from_disparity(synthetic):
    """Eq. 3: h = h_zero + m d gives the rendered altitudes at the matches."""
    *_, rect = synthetic
    matches = match_sift(rect.reference, rect.target, RectifyParams(ratio=0.7))
    good = np.abs(matches.ref_xy[:, 1] - matches.tgt_xy[:, 1]) < 1.0
    heights = rect.zero_disparity_altitude + rect.metres_per_pixel * matches.disparity[good]
    block = np.abs(heights - BLOCK_H) < 4.0
    ground = np.abs(heights - GROUND_H) < 4.0
    assert block.sum() > 20 and ground.sum() > 100 and (block | ground).mean() > 0.95
    assert np.median(heights[ground]) == pytest.approx(GROUND_H, abs=1.0)
    assert np.median(heights[block]) == pytest.approx(BLOCK_H, abs=1.0)


def test_rectified_reference_goes_back_to_the_original(synthetic):
    reference, _, _, rect = synthetic
    back = rect.to_original(rect.reference, "reference")
    inner = np.zeros(reference.shape, bool)
    inner[8:-8, 8:-8] = True
    ok = inner & np.isfinite(back)
    assert ok.mean() > 0.9 * inner.mean()
    assert np.median(np.abs(back[ok] - reference[ok])) < 0.02 * np.ptp(reference)


def test_correspondences_of_the_ground_land_on_the_target_truth(synthetic):
    """A constant disparity map (the ground's) maps reference pixels to their target truth."""
    _, _, rpcs, rect = synthetic
    d_ground = (GROUND_H - rect.zero_disparity_altitude) / rect.metres_per_pixel
    positions = rect.correspondences_to_original(np.full(rect.shape, d_ground, np.float32))
    ref_rpc, tgt_rpc = rpcs
    rows, cols = np.mgrid[40:200:20, 40:200:20]
    pixel = np.stack([cols.ravel() + REF_OFFSET[0] - 1000.0, rows.ravel() + REF_OFFSET[1] - 2000.0])
    h_n = (GROUND_H - HEIGHT_OFF) / HEIGHT_SCALE
    lon_lat = np.linalg.solve(REF_CAMERA[:, :2], pixel - REF_CAMERA[:, 2:] * h_n)
    lon, lat = lon_lat[0] * DEG_SCALE + LON_OFF, lon_lat[1] * DEG_SCALE + LAT_OFF
    expected = np.stack(tgt_rpc.project(lon, lat, np.full(lon.shape, GROUND_H)), axis=-1)
    got = positions[rows.ravel(), cols.ravel()]
    np.testing.assert_allclose(got, expected, atol=0.3)


def test_rpcs_that_do_not_fit_fall_back_to_the_affine_method(synthetic):
    reference, target, (ref_rpc, tgt_rpc), _ = synthetic
    # A crop offset 40 columns off: across the epipolar lines (they run along the rows of
    # these along-track cameras, where an offset only shifts the disparity).
    shifted = tgt_rpc.with_offset((TGT_OFFSET[0] + 40.0, TGT_OFFSET[1]))
    rect = rectify_pair(reference, target, RectifyParams(), (ref_rpc, shifted))
    assert rect.method == "affine"
    assert rect.reason.startswith("RPC models not used: the RPCs do not fit the pixels")
    with pytest.raises(RpcMisfit, match="do not fit"):
        rectify_pair(reference, target, RectifyParams(method="rpc"), (ref_rpc, shifted))


def test_method_choices():
    image = np.zeros((64, 64), np.float32)
    with pytest.raises(StageError, match="method is 'rpc' but the target carries no RPC model"):
        rectify_pair(image, image, RectifyParams(method="rpc"), None, "the target carries no RPC model")


# ----------------------------------------------------------------------------- shared data


def test_pleiades_models_and_crop_offsets(shared_data):
    folder = shared_data / "pleiades_kahramanmaras_prepost"
    expected = {"pre_event_img1": (12114.5, 5511.5), "post_event_img2": (12815.0, 7219.0)}
    for name, offset in expected.items():
        raster = read_raster(folder / f"{name}.tif")
        rpc = read_rpc(raster.path, raster.georef, raster.gdal)
        assert rpc.crop_offset == offset and rpc.source == f"{name}.geom (OSSIM keyword list)"


def test_projection_agrees_with_shareloc_direct_localisation(shared_data):
    """Round trip: shareloc locates crop pixels on the ground; the model projects them back."""
    from shareloc.geomodels.rpc import RPC
    from shareloc.geomodels.rpc_readers import rpc_reader_ossim_kwl

    path = shared_data / "pleiades_gizeh" / "img2.tif"
    raster = read_raster(path)
    rpc = read_rpc(raster.path, raster.georef, raster.gdal)
    model = RPC(rpc_reader_ossim_kwl(str(path.with_suffix(".geom"))))  # pixel corner convention
    cols, rows = np.array([0.0, 400.0, 790.0]), np.array([0.0, 300.0, 800.0])
    heights = np.array([60.0, 140.0, 250.0])
    ground = model.direct_loc_h(rows + rpc.crop_offset[1] + 0.5, cols + rpc.crop_offset[0] + 0.5, heights)
    col, row = rpc.project(ground[:, 0], ground[:, 1], heights)
    np.testing.assert_allclose(col, cols, atol=1e-3)
    np.testing.assert_allclose(row, rows, atol=1e-3)


def test_nitf_rpc00b_is_read(shared_data):
    raster = read_raster(shared_data / "worldview3_buenos_aires_nitf" / "wv3_20.NTF")
    rpc = read_rpc(raster.path, raster.georef, raster.gdal)
    assert rpc.source == "wv3_20.NTF (RPC00B read by GDAL)" and rpc.crop_offset == (0.0, 0.0)
    assert (rpc.height_off, rpc.lat_off, rpc.long_off) == (31.0, -34.5043, -58.6024)


def test_a_physical_model_is_reported_not_used(shared_data):
    folder = shared_data / "pleiades_ventoux"
    models, reason = pair_rpcs(read_raster(folder / "left_image.tif"), read_raster(folder / "right_image.tif"))
    assert models is None
    assert "left_image.geom: not an RPC model (OSSIM type 'ossimPleiadesModel'" in reason


def test_real_crop_with_a_wrong_offset_falls_back(shared_data):
    """A 400 px crop of the Kahramanmaras same-date pair: its models fit; 60 columns off, they do not."""
    folder = shared_data / "pleiades_kahramanmaras_prepost"
    images, models = [], []
    for name in ("pre_event_img1", "pre_event_img2"):
        raster = read_raster(folder / f"{name}.tif")
        rpc = read_rpc(raster.path, raster.georef, raster.gdal)
        images.append(raster.as_float32()[300:700, 300:700])
        models.append(rpc.with_offset((rpc.crop_offset[0] + 300, rpc.crop_offset[1] + 300)))
    params = RectifyParams(max_features=4000)
    fitting = rectify_pair(*images, params, tuple(models))
    assert fitting.method == "rpc" and abs(fitting.rpc_row_offset) < 1.0
    shifted = models[1].with_offset((models[1].crop_offset[0] + 60, models[1].crop_offset[1]))
    wrong = rectify_pair(*images, params, (models[0], shifted))
    assert wrong.method == "affine" and "RPC models not used" in wrong.reason


# ----------------------------------------------------------------------------- through the pipeline


def _write_geom(path, rpc: Rpc) -> None:
    """An OSSIM keyword list of ``rpc`` (as OTB writes them)."""
    lines = ["type: ossimRpcModel", "polynomial_format: B"]
    for name in ("line_off", "samp_off", "lat_off", "long_off", "height_off",
                 "line_scale", "samp_scale", "lat_scale", "long_scale", "height_scale"):
        lines.append(f"{name}: {float(getattr(rpc, name))!r}")
    for name in ("line_num_coeff", "line_den_coeff", "samp_num_coeff", "samp_den_coeff"):
        lines += [f"{name}_{k:02d}: {float(value)!r}" for k, value in enumerate(getattr(rpc, name))]
    path.write_text("\n".join(lines) + "\n")


def test_files_with_geom_sidecars_are_rectified_from_their_models(tmp_path, synthetic):
    """TIFFs with a crop offset tag and .geom files beside them: the summary names the RPC route."""
    from radcons.io import load_pair_files, write_raster
    from radcons.pipeline import Pipeline
    from radcons.summary import run_summary

    reference, target, rpcs, _ = synthetic
    paths = []
    for name, image, rpc in (("ref", reference, rpcs[0]), ("tgt", target, rpcs[1])):
        matrix = (1.0, 0.0, 0.0, rpc.crop_offset[0], 0.0, 1.0, 0.0, rpc.crop_offset[1]) + (0.0,) * 7 + (1.0,)
        paths.append(write_raster(tmp_path / f"{name}.tif", image, {34264: (12, 16, matrix)}))
        _write_geom(tmp_path / f"{name}.geom", rpc.with_offset((0.0, 0.0)))
    pair = load_pair_files(*paths, rectified=False)
    summary = run_summary(Pipeline().run(pair, until="rectify"))["rectification"]
    assert summary["method"] == "rpc" and "ref.geom (OSSIM keyword list)" in summary["reason"]
    assert summary["metres_per_disparity_px"] == pytest.approx(1.0 / _parallax_per_metre(), rel=0.01)
    (tmp_path / "tgt.geom").unlink()
    summary = run_summary(Pipeline().run(load_pair_files(*paths, rectified=False), until="rectify"))["rectification"]
    assert summary["method"] == "affine" and summary["reason"] == "the target carries no RPC model"
    assert "relief skew" in summary["orientation"]  # which way up the affine route turned it, and why


def test_ground_sample_distance_of_an_affine_rpc():
    """The root of a pixel's ground area, against the affine camera's own Jacobian."""
    rpc = _affine_rpc(REF_CAMERA, REF_OFFSET)
    metres_per_degree = 111_320.0 * np.array([np.cos(np.radians(LAT_OFF)), 1.0])
    pixels_per_metre = REF_CAMERA[:, :2] / DEG_SCALE / metres_per_degree
    assert rpc.ground_sample_distance() == pytest.approx(1.0 / np.sqrt(abs(np.linalg.det(pixels_per_metre))), rel=1e-6)


def test_rectified_frame_keeps_the_reference_ground_sample_distance(synthetic):
    _, _, (ref_rpc, _), rect = synthetic
    assert rect.gsd_m == pytest.approx(ref_rpc.ground_sample_distance(rect.altitude), rel=0.05)


def test_ground_sample_distance_agrees_with_shareloc(shared_data):
    """Pleiades Gizeh: the area of a pixel that shareloc locates on the ground."""
    from shareloc.geomodels.rpc import RPC
    from shareloc.geomodels.rpc_readers import rpc_reader_ossim_kwl

    path = shared_data / "pleiades_gizeh" / "img2.tif"
    raster = read_raster(path)
    rpc = read_rpc(raster.path, raster.georef, raster.gdal)
    model = RPC(rpc_reader_ossim_kwl(str(path.with_suffix(".geom"))))
    row, col = rpc.line_off, rpc.samp_off  # the scene's centre, scene pixels
    ground = model.direct_loc_h(np.array([row, row, row + 100.0]), np.array([col, col + 100.0, col]), np.full(3, rpc.height_off))
    east = (ground[:, 0] - ground[0, 0]) * 111_320.0 * np.cos(np.radians(ground[0, 1]))
    north = (ground[:, 1] - ground[0, 1]) * 111_320.0
    area = abs(east[1] * north[2] - east[2] * north[1]) / 100.0**2
    assert 0.45 < rpc.ground_sample_distance() < 0.6
    assert rpc.ground_sample_distance() == pytest.approx(np.sqrt(area), rel=0.01)
