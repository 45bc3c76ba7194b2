"""An object's D̄m refined by the census cost of its pixels; the census range finds tall roofs."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from radcons.errors import InputError
from radcons.numerics.census import CensusParams
from radcons.numerics.coarse_disparity import (
    MAX_CENSUS_VOLUME,
    bounded_factor,
    coarse_disparity,
)
from radcons.stages.objects.disparity import (
    census_descriptors,
    matches_back,
    object_census_costs,
    object_census_disparity,
)


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


def test_object_census_costs_are_the_mean_hamming_distance_over_the_pixels_inside_the_target():
    rng = np.random.default_rng(4)
    reference = census_descriptors(_textured((20, 30), 1))
    target = census_descriptors(_textured((20, 30), 2))
    rows, cols = rng.integers(0, 20, 60), rng.integers(0, 30, 60)
    cols[:5] = (0, 1, 28, 29, 15)  # at the edges, some disparities take them out of the target
    disparities = np.arange(-26, 27, 5)
    costs = object_census_costs(reference, target, rows, cols, disparities)
    for disparity, cost in zip(disparities, costs):
        distances = [
            bin(int(reference[r, c]) ^ int(target[r, c - disparity])).count("1")
            for r, c in zip(rows, cols) if 0 <= c - disparity < 30
        ]
        expected = sum(distances) / (24 * len(distances)) if len(distances) >= 10 else np.inf
        assert cost == pytest.approx(expected)


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
    found, searched, _, _ = coarse_disparity(reference, target, 1, 0.25, CensusParams())
    assert searched[0] <= 4 and searched[1] >= 15
    roof = found[153:163, 123:133]
    assert np.nanmedian(roof) == pytest.approx(14.0, abs=1.0)


def test_a_wide_range_on_a_large_image_takes_a_coarser_grid():
    """The cost volume stays bounded: a range of 4000 px over 2048 x 2048 px (a Sentinel-2 pair's false matches)."""
    shape = (2048, 2048)
    factor = bounded_factor(shape, 2, 4000.0)
    assert shape[0] * shape[1] * 4000.0 / factor**3 <= MAX_CENSUS_VOLUME
    assert shape[0] * shape[1] * 4000.0 / (factor - 1) ** 3 > MAX_CENSUS_VOLUME
    assert bounded_factor((256, 256), 1, 40.0) == 1  # a demo-sized run is left as asked
    reference = _textured((1024, 1024), 3)
    target = np.roll(reference, -6, axis=1)
    found, searched, _, used = coarse_disparity(reference, target, 2, 0.25, CensusParams(), (-3000.0, 3000.0))
    assert used == bounded_factor((1024, 1024), 2, 6000.0 + 2 * (0.25 * 6000.0 + 2.0)) > 2
    assert found.shape == (1024 // used, 1024 // used) and searched[0] <= -3000 and searched[1] >= 3000


def _roof_pair(roof: int, ground: int) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """A textured ground at disparity ``ground`` with a textured roof at ``roof`` (rows 30-70, columns 60-110)."""
    reference = _textured((100, 200), 3)
    reference[30:70, 60:110] = _textured((40, 50), 4)
    target = np.empty_like(reference)  # target(x - d) = reference(x)
    target[:, : -ground] = reference[:, ground:]
    target[:, -ground:] = reference[:, -1:]
    target[30:70, 60 - roof : 110 - roof] = reference[30:70, 60:110]
    target = 0.5 * target + 20.0  # another sensor's gain and offset
    rows, cols = np.mgrid[30:70, 60:110]
    return reference, target, (rows.ravel(), cols.ravel())


def test_a_roof_at_its_disparity_matches_back_and_a_wrong_disparity_does_not():
    reference, target, (rows, cols) = _roof_pair(roof=14, ground=4)
    census = census_descriptors(reference), census_descriptors(target)
    disparities = np.arange(0, 30)
    assert matches_back(*census, rows, cols, 14.0, disparities)
    assert matches_back(*census, rows, cols, 15.4, disparities)  # within 2 px of the least cost
    # the ground beside the roof, given the roof's disparity: its copy is the ground
    # further right, which matches back at the ground's disparity
    ground_rows, ground_cols = np.mgrid[30:70, 120:170]
    assert not matches_back(*census, ground_rows.ravel(), ground_cols.ravel(), 14.0, disparities)
    assert matches_back(*census, ground_rows.ravel(), ground_cols.ravel(), 4.0, disparities)
    # the roof given a disparity 8 px off: its copy lies on the ground and matches back there
    assert not matches_back(*census, rows, cols, 22.0, disparities)


def test_a_copy_outside_the_target_does_not_match_back():
    reference, target, _ = _roof_pair(roof=14, ground=4)
    census = census_descriptors(reference), census_descriptors(target)
    rows, cols = np.mgrid[10:40, 0:12]
    assert not matches_back(*census, rows.ravel(), cols.ravel(), 14.0, np.arange(0, 30))
