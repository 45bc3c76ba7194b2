"""Each final object's D̄m refined again on its core (radcons.stages.objects.transfer.refined_disparities)."""

import cv2
import numpy as np

from radcons.stages.objects.disparity import census_descriptors, object_census_disparity
from radcons.stages.objects.transfer import FINAL_RIM, refined_disparities

GROUND, ROOF_SHIFT = 3, 9  # disparities of the ground and of the roof, px
ROOF = (slice(40, 80), slice(60, 110))


def _pair() -> tuple[np.ndarray, np.ndarray]:
    """Textured ground at disparity GROUND, a textured roof at ROOF_SHIFT drawn over it in both views."""
    rng = np.random.default_rng(4)
    shape = (120, 180)
    ground = cv2.GaussianBlur(rng.normal(0, 1, shape).astype(np.float32), (0, 0), 1.2) * 40 + 100
    roof = cv2.GaussianBlur(rng.normal(0, 1, (40, 50)).astype(np.float32), (0, 0), 1.2) * 10 + 180
    reference = ground.copy()
    reference[ROOF] = roof
    target = np.empty_like(ground)
    target[:, : shape[1] - GROUND] = ground[:, GROUND:]
    target[:, shape[1] - GROUND :] = ground[:, -GROUND:]
    target[ROOF[0], ROOF[1].start - ROOF_SHIFT : ROOF[1].stop - ROOF_SHIFT] = roof
    return reference, target


def test_a_wrong_dm_is_refined_to_the_roofs_own_on_its_core():
    reference, target = _pair()
    census = census_descriptors(reference), census_descriptors(target)
    labels = np.zeros(reference.shape, np.int32)
    labels[38:82, 58:112] = 1  # the roof and a 2 px strip of ground around it
    labels[5:20, 5:30] = 2  # ground, without a D̄m: left out
    refined = refined_disparities(labels, {1: ROOF_SHIFT + 2.0}, census, 3)
    assert set(refined) == {1}
    assert abs(refined[1] - ROOF_SHIFT) < 0.3
    # the pixels it used: the object eroded by FINAL_RIM px (a square window)
    core = cv2.erode((labels == 1).astype(np.uint8), np.ones((2 * FINAL_RIM + 1,) * 2, np.uint8)) > 0
    rows, cols = np.nonzero(core)
    assert refined[1] == object_census_disparity(*census, rows, cols, ROOF_SHIFT + 2.0, 3)


def test_radius_zero_keeps_the_dm_and_a_thin_object_uses_all_its_pixels():
    reference, target = _pair()
    census = census_descriptors(reference), census_descriptors(target)
    labels = np.zeros(reference.shape, np.int32)
    labels[50:56, 60:110] = 1  # 6 px thick: its core would be empty
    assert refined_disparities(labels, {1: 11.0}, census, 0) == {1: 11.0}
    rows, cols = np.nonzero(labels == 1)
    assert refined_disparities(labels, {1: 11.0}, census, 3)[1] == object_census_disparity(*census, rows, cols, 11.0, 3)
