"""Gabled roofs split at their ridge are joined again (radcons.stages.objects.joins.halves)."""

import numpy as np
import pytest

from radcons.stages.objects.joins.halves import join_roof_halves
from radcons.stages.objects.run import ObjectsParams


def _two(first, second, shape=(120, 160)):
    """Label raster with objects 1 and 2 on the given (row0, row1, col0, col1) boxes."""
    labels = np.zeros(shape, np.int32)
    for ident, (r0, r1, c0, c1) in ((1, first), (2, second)):
        labels[r0:r1, c0:c1] = ident
    return labels


def test_the_two_planes_of_a_roof_become_one_object_with_the_line_between_them():
    labels = _two((20, 44, 30, 110), (45, 70, 30, 110))  # a roof 50 x 80 px, its ridge the one-pixel line at row 44
    labels[90:110, 10:30] = 3  # another object, left alone
    joined, modal, scores = join_roof_halves(labels, {1: 10.0, 2: 11.0, 3: 4.0}, {1: 0.8, 2: 0.9, 3: 0.5})
    assert int(joined.max()) == 2
    roof = joined == joined[50, 60]
    assert roof.sum() == 50 * 80  # both planes and the ridge line
    assert np.array_equal(joined[90:110, 10:30] > 0, np.ones((20, 20), bool))
    assert sorted(modal.values()) == [4.0, 11.0]  # the larger plane's D̄m and score
    assert scores[int(joined[50, 60])] == 0.9


@pytest.mark.parametrize(
    "first, second, modal, why",
    [
        ((20, 44, 30, 110), (45, 70, 30, 110), {1: 10.0, 2: 13.0}, "two heights"),
        ((20, 64, 30, 110), (65, 70, 30, 110), {1: 10.0, 2: 10.0}, "a strip beside a roof"),
        ((20, 70, 10, 70), (20, 70, 71, 150), {1: 10.0, 2: 10.0}, "end to end along the short side"),
        ((20, 44, 30, 110), (45, 100, 30, 60), {1: 10.0, 2: 10.0}, "an L, no rectangle"),
        ((20, 44, 30, 110), (45, 70, 30, 110), {1: 10.0}, "no D̄m for one"),
    ],
)
def test_other_neighbours_stay_apart(first, second, modal, why):
    labels = _two(first, second)
    joined, kept, _ = join_roof_halves(labels, modal, {})
    assert int(joined.max()) == 2, why
    assert np.array_equal(joined, labels)
    assert kept == modal


def test_each_object_joins_one_other_at_most():
    labels = np.zeros((120, 160), np.int32)
    labels[20:44, 30:110], labels[45:69, 30:110], labels[70:94, 30:110] = 1, 2, 3  # three equal strips
    joined, modal, _ = join_roof_halves(labels, {1: 10.0, 2: 10.0, 3: 10.0}, {})
    assert int(joined.max()) == 2 and len(modal) == 2


def test_the_height_method_joins_by_default():
    assert ObjectsParams().join_roof_halves is True
