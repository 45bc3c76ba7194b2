"""Roofs clipped at full scale in one image (radcons.stages.objects.searches.clipped)."""

import numpy as np
import pytest

from demo_data_gen import generate
from radcons.numerics.modal import modal_disparity
from radcons.stages.objects.ground import HeightMap
from radcons.stages.objects.run import ObjectsParams, height_objects
from radcons.stages.objects.searches.clipped import (
    clipped_plateaus,
    clipped_roofs,
    dark_surround,
    mostly_on,
)

FULL = 255.0
GROUND_D, ROOF_D = 3, 14


def _clipped_image() -> np.ndarray:
    rng = np.random.default_rng(0)
    image = rng.uniform(40.0, 200.0, (160, 200))
    image[20:80, 20:100] = FULL  # a roof in glare ...
    image[40:44, 50:54] = 120.0  # ... with a vent on it (a hole of 16 px)
    image[90:150, 110:190] = FULL  # a courtyard building ...
    image[105:135, 130:170] = 90.0  # ... around its courtyard (1200 px of 4800)
    image[5, 150] = FULL  # one bright pixel: no plateau
    image[140:143, 20:23] = FULL  # a 3 x 3 patch: a plateau, too small
    return image


def test_plateaus_are_clipped_regions_with_small_holes_filled():
    plateaus = clipped_plateaus(_clipped_image(), smallest=100, largest=10_000)
    roof = np.zeros((160, 200), bool)
    roof[20:80, 20:100] = True
    ring = np.zeros((160, 200), bool)
    ring[90:150, 110:190] = True
    ring[105:135, 130:170] = False
    assert int(plateaus.max()) == 2
    assert np.array_equal(plateaus == plateaus[50, 60], roof)  # the vent is filled
    assert np.array_equal(plateaus == plateaus[95, 150], ring)  # the courtyard is not
    assert plateaus[5, 150] == 0 and plateaus[141, 21] == 0


def test_a_plateau_cut_by_the_frame_or_by_nodata_is_left_out():
    image = _clipped_image()
    image[0:30, 150:200] = FULL  # at the image's corner
    image[55:80, 150:160] = np.nan
    image[50:85, 160:190] = FULL  # beside nodata
    plateaus = clipped_plateaus(image, smallest=100, largest=10_000)
    assert int(plateaus.max()) == 2
    assert not plateaus[0:30, 150:200].any() and not plateaus[50:85, 160:190].any()


def test_an_image_without_clipping_has_no_plateau():
    image = np.random.default_rng(1).uniform(0.0, 1.0, (64, 64))
    assert not clipped_plateaus(image, 1, 10_000).any()
    image[:, :] = np.nan
    assert not clipped_plateaus(image, 1, 10_000).any()


def _scene(roof_disparity: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A textured ground at GROUND_D px and a lit roof with dark walls around it at ``roof_disparity``.

    The target sees the same scene, its roof clipped at full scale.
    """
    rng = np.random.default_rng(2)
    rows, cols = 160, 260
    ground = rng.uniform(60.0, 140.0, (rows, cols + 40))
    roof = np.zeros((rows, cols), bool)
    roof[40:110, 90:170] = True

    def view(shift: int, roof_shift: int, roof_value: float | None) -> np.ndarray:
        image = ground[:, 20 + shift : 20 + shift + cols].copy()
        moved = np.zeros_like(roof)
        moved[:, roof_shift:] = roof[:, : cols - roof_shift] if roof_shift else roof
        walls = np.zeros_like(roof)
        walls[36:114, 86 + roof_shift : 174 + roof_shift] = True
        image[walls] = 30.0 + rng.normal(0.0, 2.0, int(walls.sum()))
        image[moved] = roof_value if roof_value is not None else 180.0 + rng.normal(0.0, 4.0, int(moved.sum()))
        return image

    reference = view(0, roof_disparity, None)
    target = view(GROUND_D, 0, FULL)
    target[target > FULL] = FULL
    reference_roof = np.zeros_like(roof)
    reference_roof[:, roof_disparity:] = roof[:, : cols - roof_disparity]
    return reference, target, reference_roof


def _height(shape, ground_disparity: float) -> HeightMap:
    ground = np.full(shape, ground_disparity, np.float32)
    return HeightMap(ground.copy(), ground, np.zeros(shape, np.float32), "px", 1.0, 1, (0.0, 30.0), 1.0)


def test_a_clipped_roof_is_found_at_its_disparity_by_its_outline():
    reference, target, truth = _scene(ROOF_D)
    found, modal = clipped_roofs(reference, target, _height(reference.shape, GROUND_D), 3.0, (500.0, 20_000.0))
    assert list(modal) == [1]
    assert modal[1] == pytest.approx(ROOF_D, abs=0.5)
    iou = ((found == 1) & truth).sum() / ((found == 1) | truth).sum()
    assert iou > 0.95


def test_a_roof_clipped_in_both_images_is_one_object():
    reference, target, truth = _scene(ROOF_D)
    reference[truth] = FULL  # a white roof in two 8-bit images
    found, modal = clipped_roofs(reference, target, _height(reference.shape, GROUND_D), 3.0, (500.0, 20_000.0))
    assert list(modal) == [1]  # the reference's plateau finds its pixels taken
    assert modal[1] == pytest.approx(ROOF_D, abs=0.5)
    assert np.array_equal(found == 1, truth)


def test_a_clipped_patch_on_the_ground_is_not_a_roof():
    # white ground at the ground's own disparity: its outline fits best there, too low
    reference, target, _ = _scene(GROUND_D)
    found, modal = clipped_roofs(reference, target, _height(reference.shape, GROUND_D), 3.0, (500.0, 20_000.0))
    assert modal == {} and not found.any()


def test_a_roof_clipped_in_the_reference_is_found_in_place():
    reference, target, truth = _scene(ROOF_D)
    # swap the roles: the clipped image is the reference, seen from the other side
    flipped_ref, flipped_tgt = target[:, ::-1].copy(), reference[:, ::-1].copy()
    found, modal = clipped_roofs(
        flipped_ref, flipped_tgt, _height(reference.shape, GROUND_D), 3.0, (500.0, 20_000.0)
    )
    assert list(modal) == [1]
    assert modal[1] == pytest.approx(ROOF_D, abs=0.5)
    plateau = flipped_ref == FULL
    assert ((found == 1) & plateau).sum() / ((found == 1) | plateau).sum() > 0.95


def test_mostly_on_counts_an_objects_share_of_pixels():
    labels = np.zeros((10, 10), np.int32)
    labels[0:4, 0:4] = 1  # 16 px, 12 in the mask
    labels[6:10, 6:10] = 2  # 16 px, 4 in the mask
    mask = np.zeros((10, 10), bool)
    mask[1:4, 0:4] = True
    mask[6:7, 6:10] = True
    assert mostly_on(labels, mask).tolist() == [False, True, False]


def test_the_clipped_core_of_a_bright_roof_is_not_a_roof_clipped_whole():
    reference, target, _ = _scene(ROOF_D)
    whole = target == FULL
    level = 0.5 * (np.median(target) + FULL)
    assert dark_surround(target, whole, level) == 1.0
    # the same roof, bright but clipped only in its middle: the ring is the roof itself
    target[whole] = 235.0
    target[55:95, 110:150] = FULL
    core = target == FULL
    assert dark_surround(target, core, level) == 0.0
    found, modal = clipped_roofs(reference, target, _height(reference.shape, GROUND_D), 3.0, (500.0, 20_000.0))
    assert modal == {} and not found.any()


def _best_object(labels: np.ndarray, building: np.ndarray) -> tuple[int, float]:
    """The object with the best IoU with ``building``, and that IoU (0, 0.0 when none touches it)."""
    ids = np.unique(labels[building])
    ids = ids[ids > 0]
    if ids.size == 0:
        return 0, 0.0
    ious = [((labels == i) & building).sum() / ((labels == i) | building).sum() for i in ids]
    return int(ids[int(np.argmax(ious))]), float(max(ious))


def test_the_demo_glare_roof_is_an_object_only_by_its_outline():
    # demo 'mixed' seed 3 at 512 px: the over-exposed roof (the paper's Object 1) is clipped
    # whole in the target; census finds at best its furniture
    pair = generate(size=512, seed=3, scenario="mixed")
    meta = pair.metadata
    building = pair.reference_objects == meta["overexposed_object"]
    truth = pair.disparity[building]
    truth = modal_disparity(truth[np.isfinite(truth)])
    found = {}
    for flag in (False, True):
        objects = height_objects(
            pair.reference.as_float32(), pair.target.as_float32(), ObjectsParams(method="height", find_clipped=flag),
            gsd_m=meta["gsd_m"], base_to_height=meta["base_to_height"],
        )
        best, iou = _best_object(objects.reference, building)
        found[flag] = (iou, objects.modal_disparity.get(best))
        assert objects.by_outline == ((best,) if flag else ())
    assert found[False][0] < 0.5
    iou, shift = found[True]
    assert iou > 0.8
    assert abs(shift - truth) <= 1.0
