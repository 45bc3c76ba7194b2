"""Sub-pixel peak of three samples (radcons.numerics.subpixel)."""

import numpy as np
import pytest

from radcons.numerics.subpixel import parabola_peak


@pytest.mark.parametrize("vertex", [-0.45, -0.2, 0.0, 0.3, 0.49])
def test_the_vertex_of_a_sampled_parabola_is_found(vertex):
    values = [-3.0 * (x - vertex) ** 2 + 7.0 for x in (-1, 0, 1)]
    assert parabola_peak(*values) == pytest.approx(vertex, abs=1e-12)
    # a minimum: the same samples negated
    assert parabola_peak(*(-np.array([3.0 * (x - vertex) ** 2 for x in (-1, 0, 1)]))) == pytest.approx(vertex, abs=1e-12)


def test_offsets_are_clipped_and_upward_flat_or_missing_samples_give_none():
    assert parabola_peak(*[-((x - 2.0) ** 2) for x in (-1, 0, 1)]) == 0.5
    assert parabola_peak(1.0, 0.0, 1.0) == 0.0  # opens upwards
    assert parabola_peak(2.0, 2.0, 2.0) == 0.0  # flat
    assert parabola_peak(np.nan, 1.0, 0.5) == 0.0
    assert parabola_peak(-np.inf, 1.0, 0.5) == 0.0
