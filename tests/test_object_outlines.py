"""The final objects' outlines: shadows cut off, rims snapped to the edge (radcons.stages.objects.outlines)."""

import cv2
import numpy as np
import pytest

from demo_data_gen import generate
from radcons.stages.objects.outlines import (
    candidate_outlines,
    open_parts,
    snap_rims,
    trim_shadows,
)
from radcons.stages.objects.run import ObjectsParams, height_objects


def _roof_with_spill(shape=(120, 160)):
    """A bright roof (1.0), its shadow (0.2) and a strip of grey ground beyond it (0.6), one object over all."""
    image = np.full(shape, 0.6, np.float32)
    roof = np.zeros(shape, bool)
    roof[20:80, 20:100] = True
    shadow = np.zeros(shape, bool)
    shadow[20:80, 100:115] = True
    image[roof], image[shadow] = 1.0, 0.2
    labels = np.zeros(shape, np.int32)
    labels[18:82, 20:115] = 1  # the roof, its shadow and two rows of ground above and below
    return image, labels, roof, shadow


def test_the_shadow_is_cut_and_the_grey_ground_beside_the_roof_stays():
    image, labels, roof, shadow = _roof_with_spill()
    trimmed = trim_shadows(labels, image, 0.5)
    # everything under the object but the shadow: the ground rows along it stay joined to the roof
    assert np.array_equal(trimmed == 1, (labels == 1) & ~shadow)
    assert np.array_equal(trimmed[labels == 0], labels[labels == 0])


def test_ground_that_the_shadow_cuts_off_from_the_roof_goes_with_it():
    image, labels, roof, shadow = _roof_with_spill()
    labels[18:20, :] = labels[80:82, :] = 0  # no ground rows along the roof and its shadow
    labels[20:80, 115:125] = 1  # ground beyond the shadow, joined to the roof only through it
    trimmed = trim_shadows(labels, image, 0.5)
    assert np.array_equal(trimmed == 1, roof)


def test_dark_furniture_inside_the_roof_stays():
    image, labels, roof, shadow = _roof_with_spill()
    image[40:50, 40:50] = 0.1  # a dark vent enclosed by the roof
    trimmed = trim_shadows(labels, image, 0.5)
    assert (trimmed[40:50, 40:50] == 1).all()
    assert not (trimmed[shadow] == 1).any()


def test_a_roof_mostly_dark_is_left_whole():
    image = np.full((80, 120), 0.6, np.float32)
    labels = np.zeros((80, 120), np.int32)
    labels[10:70, 10:110] = 1
    image[10:70, 10:50] = 1.0  # the sunlit slope, 40 %
    image[10:70, 50:110] = 0.2  # the slope in the shade, 60 %: the median is the shade's
    assert np.array_equal(trim_shadows(labels, image, 0.5), labels)
    image[10:70, 10:70] = 1.0  # sunlit 60 %: the shade is under half its median and cut,
    image[10:70, 70:110] = 0.2  # but it is 40 % of the object, within what an object may lose
    trimmed = trim_shadows(labels, image, 0.5)
    assert np.array_equal(trimmed == 1, (labels == 1) & (image == 1.0))


def test_ids_and_other_objects_are_kept_and_zero_is_off():
    image, labels, roof, shadow = _roof_with_spill()
    labels[100:110, 130:150] = 3  # an even object, id 2 unused
    trimmed = trim_shadows(labels, image, 0.5)
    assert set(np.unique(trimmed)) == {0, 1, 3}
    assert np.array_equal(trimmed == 3, labels == 3)
    assert np.array_equal(trim_shadows(labels, image, 0.0), labels)
    with pytest.raises(ValueError, match="shape"):
        trim_shadows(labels, image[:-1], 0.5)


def test_on_a_demo_pair_the_shadows_cut_are_mostly_not_building_and_each_step_fits_better():
    pair = generate(size=512, seed=0, scenario="mixed")
    reference, target = pair.reference.as_float32(), pair.target.as_float32()
    geometry = {"gsd_m": pair.metadata["gsd_m"], "base_to_height": pair.metadata["base_to_height"]}
    without = height_objects(reference, target, ObjectsParams(method="height", shadow_trim=0.0, outline_band=0.0), **geometry)
    found = height_objects(reference, target, ObjectsParams(method="height", outline_band=0.0), **geometry)
    snapped = height_objects(reference, target, ObjectsParams(method="height"), **geometry)
    cut = (without.reference > 0) & (found.reference == 0)
    truth = pair.reference_objects
    assert cut.sum() > 500, "the pair was chosen for roofs that spill onto their shadows"
    assert (truth[cut] > 0).mean() < 0.1
    assert (found.reference > 0).sum() < (without.reference > 0).sum()

    def mean_iou(labels):
        ious = []
        for ident in np.unique(truth[truth > 0]):
            building = truth == ident
            under = labels[building]
            under = under[under > 0]
            if not under.size:
                ious.append(0.0)
                continue
            obj = labels == np.bincount(under).argmax()
            ious.append((obj & building).sum() / (obj | building).sum())
        return float(np.mean(ious))

    assert mean_iou(snapped.reference) > mean_iou(found.reference) > mean_iou(without.reference)
    moved = (snapped.reference > 0) != (found.reference > 0)
    assert moved.any() and ((snapped.reference > 0) == (truth > 0))[moved].mean() > 0.5  # more moved pixels end right than wrong


def _blurred_roof(shape=(100, 120), roof=(30, 70, 30, 90), level=1.0, ground=0.4):
    image = np.full(shape, ground, np.float32)
    r0, r1, c0, c1 = roof
    image[r0:r1, c0:c1] = level
    image = cv2.GaussianBlur(image, (0, 0), 0.8)
    image += np.random.default_rng(0).normal(0.0, 0.01, shape).astype(np.float32)
    truth = np.zeros(shape, bool)
    truth[r0:r1, c0:c1] = True
    return image, truth


def test_an_outline_two_pixels_off_snaps_to_the_edge():
    image, truth = _blurred_roof()
    labels = np.zeros(truth.shape, np.int32)
    labels[32:72, 28:88] = 5  # 2 px low, 2 px left: two rows and two columns short, as many over
    snapped = snap_rims(labels, image, 2.0)
    assert ((labels == 5) != truth).sum() == 2 * (40 * 60 - 38 * 58)
    assert ((snapped == 5) != truth).sum() <= 4  # at most a corner's pixels, where both sides mix
    assert set(np.unique(snapped)) == {0, 5}


def test_only_the_band_moves():
    image, truth = _blurred_roof()
    labels = np.zeros(truth.shape, np.int32)
    labels[34:74, 30:90] = 1  # 4 px low: two of the four rows each way are within a 2 px band
    snapped = snap_rims(labels, image, 2.0)
    assert (snapped[32:34, 30:90] == 1).all()  # roof rows beside the outline join
    assert not snapped[72:74].any()  # ground rows inside the outline leave
    assert not snapped[30:32].any() and (snapped[70:72, 34:86] == 1).all()  # beyond the band: as they were (corners aside)
    assert np.array_equal(snapped[36:68], labels[36:68])


def test_a_courtyard_stays_out_and_a_neighbour_keeps_its_pixels():
    image, truth = _blurred_roof()
    image[45:55, 50:70] = 0.4  # a courtyard in the roof
    truth[45:55, 50:70] = False
    labels = np.where(truth, 1, 0).astype(np.int32)
    labels[44:56, 49:71] = 0  # the courtyard's hole a pixel too wide
    labels[30:70, 90:100] = 2  # another object along the roof's right side, over ground
    snapped = snap_rims(labels, image, 2.0)
    assert np.array_equal(snapped == 1, truth)
    assert np.array_equal(snapped == 2, labels == 2)


def test_without_contrast_or_band_nothing_moves_and_invalid_pixels_are_never_taken():
    image, truth = _blurred_roof(level=0.42)  # 5 % brighter than the ground
    labels = np.zeros(truth.shape, np.int32)
    labels[32:72, 30:90] = 1
    assert np.array_equal(snap_rims(labels, image, 2.0), labels)
    image, truth = _blurred_roof()
    assert np.array_equal(snap_rims(labels, image, 0.0), labels)
    image[30:32, :] = np.nan  # the roof's top rows, outside the outline, unseen
    snapped = snap_rims(labels, image, 2.0)
    assert not snapped[30:32].any()
    assert not snapped[70:72].any()  # the ground rows inside it still leave


def test_opening_cuts_strips_and_spurs_off_and_keeps_the_body():
    body = np.zeros((60, 90), bool)
    body[10:40, 10:50] = True  # 30 x 40
    labels = np.where(body, 2, 0).astype(np.int32)
    labels[20, 50:80] = 2  # a spur a pixel wide, out to the right
    labels[38:40, 50:70] = 2  # a strip 2 px wide, on along the body's lower side
    labels[45:55, 70:85] = 4  # another object, a plain rectangle
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5))
    opened = open_parts(labels, 2)  # a disc 5 px across
    # as if the spur and the strip had never been there; the body loses only its corners
    assert np.array_equal(opened == 2, cv2.morphologyEx(body.astype(np.uint8), cv2.MORPH_OPEN, disc) > 0)
    assert not (opened == 2)[~body].any() and (body & (opened != 2)).sum() == 4 * 2
    assert (opened == 4).sum() == (labels == 4).sum() - 4 * 2
    assert np.array_equal(open_parts(labels, 0), labels)


def test_opening_keeps_the_larger_of_two_parts_a_neck_joined():
    labels = np.zeros((40, 100), np.int32)
    labels[5:35, 5:45] = 1  # 30 x 40
    labels[10:30, 60:80] = 1  # 20 x 20
    labels[19:21, 45:60] = 1  # a neck 2 px wide
    opened = open_parts(labels, 2)
    assert (opened[5:35, 5:45] == 1).sum() == 30 * 40 - 4 * 2
    assert not opened[:, 45:].any()


def test_a_candidate_loses_its_shadow_facade_strip_and_the_pixels_already_taken():
    image, labels, roof, shadow = _roof_with_spill()
    labels[18:20, :] = labels[80:82, :] = 0
    labels[80:82, 100:130] = 1  # a strip 2 px wide on from the roof's corner, past the shadow, over ground
    taken = np.zeros(labels.shape, bool)
    taken[20:30, 20:30] = True  # a corner of the roof already under another object
    params = ObjectsParams(method="height", shadow_trim=0.5, outline_band=0.0)
    outlined = candidate_outlines(labels, taken, image, image, params, gsd=0.5)  # a disc 5 px across
    kept = roof & ~taken
    assert not (outlined == 1)[~kept].any()
    assert (kept & (outlined != 1)).sum() <= 6 * 2  # the corners of the roof less the taken corner
