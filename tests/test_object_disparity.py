"""An object's D̄m refined by the census cost of its pixels; the census range finds tall roofs."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from radcons.errors import InputError
from radcons.evaluate.census import CensusParams
from radcons.stages.height import coarse_disparity
from radcons.stages.object_disparity import census_descriptors, object_census_disparity


def _textured(shape: tuple[int, int], seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return cv2.GaussianBlur(rng.normal(0.0, 1.0, shape).astype(np.float32), (0, 0), 1.5) * 50.0 + 120.0


def _shifted(image: np.ndarray, shift: float) -> np.ndarray:
    """``out(x - shift, y) = image(x, y)``: the image moved left by ``shift`` px (subpixel, linear)."""
    rows, cols = np.indices(image.shape, dtype=np.float32)
    return cv2.remap(image, cols + np.float32(shift), rows, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)


def test_census_descriptor_bits_are_the_darker_neighbours():
    image = np.arange(9, dtype=np.float32).reshape(3, 3)
    # centre 4: neighbours 0, 1, 2, 3 (row-major, centre skipped) are darker, 5..8 are not
    assert int(census_descriptors(image, 3)[1, 1]) == 0b00001111


@pytest.mark.parametrize("shift", [7.0, 7.5, 12.25])
def test_refined_disparity_is_the_known_shift_under_a_tone_curve(shift):
    reference = _textured((128, 160), 0)
    target = 1000.0 * np.sqrt(_shifted(reference, shift))  # another date's tone curve
    target += np.random.default_rng(1).normal(0.0, 0.3, target.shape).astype(np.float32)
    rows, cols = np.mgrid[40:90, 60:120]
    start = round(shift) + 2.0  # a census mode 2 px off
    found = object_census_disparity(
        census_descriptors(reference), census_descriptors(target), rows.ravel(), cols.ravel(), start, 4
    )
    assert abs(found - shift) < 0.3


def test_the_start_is_kept_when_the_least_cost_lies_on_the_search_edge():
    reference = _textured((96, 128), 2)
    target = _shifted(reference, 20.0)
    rows, cols = np.mgrid[30:60, 40:100]
    found = object_census_disparity(
        census_descriptors(reference), census_descriptors(target), rows.ravel(), cols.ravel(), 10.0, 3
    )
    assert found == 10.0


def test_census_descriptors_refuse_a_window_beyond_64_bits():
    with pytest.raises(InputError, match="window"):
        census_descriptors(np.zeros((8, 8), np.float32), 9)


def test_the_census_range_holds_a_small_tall_roof():
    """A roof on 0.4 % of the image, 14 px, above the 99th percentile (a wide roof at 10 px)."""
    size = 256
    reference = _textured((size, size), 3)
    disparity = np.full((size, size), 4.0, np.float32)
    disparity[20:80, 20:220] = 10.0  # 18 % of the image
    disparity[150:166, 120:136] = 14.0  # 256 px of 65536
    reference[20:80, 20:220] = _textured((60, 200), 4) + 40.0
    reference[150:166, 120:136] = _textured((16, 16), 5) + 60.0
    target = _textured((size, size), 6)
    for value in (4.0, 10.0, 14.0):  # nearer surfaces painted last
        ys, xs = np.nonzero(disparity == value)
        moved = xs - int(value)
        inside = moved >= 0
        target[ys[inside], moved[inside]] = reference[ys[inside], xs[inside]]
    found, searched, _ = coarse_disparity(reference, target, 1, 0.25, CensusParams())
    assert searched[0] <= 4 and searched[1] >= 15
    roof = found[153:163, 123:133]
    assert np.nanmedian(roof) == pytest.approx(14.0, abs=1.0)
