"""Cast shadows are cut off the objects that spilled onto them (radcons.stages.shadow_rims)."""

import numpy as np
import pytest

from demo_data_gen import generate
from radcons.errors import ParamsError
from radcons.stages.objects import ObjectsParams, height_objects
from radcons.stages.shadow_rims import trim_shadows


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


def test_on_a_demo_pair_what_is_cut_is_mostly_not_building_and_the_objects_fit_better():
    pair = generate(size=512, seed=0, scenario="mixed")
    reference, target = pair.reference.as_float32(), pair.target.as_float32()
    geometry = {"gsd_m": pair.metadata["gsd_m"], "base_to_height": pair.metadata["base_to_height"]}
    without = height_objects(reference, target, ObjectsParams(method="height", shadow_trim=0.0), **geometry)
    found = height_objects(reference, target, ObjectsParams(method="height"), **geometry)
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

    assert mean_iou(found.reference) > mean_iou(without.reference)


@pytest.mark.parametrize("value", [-0.1, 1.5])
def test_shadow_trim_out_of_range_is_refused(value):
    with pytest.raises(ParamsError, match="shadow_trim"):
        ObjectsParams(method="height", shadow_trim=value)
