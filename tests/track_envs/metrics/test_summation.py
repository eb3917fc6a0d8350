"""numpy_sum adds in numpy's pairwise order (bit-identical); the compensated sum is exact to a rounding."""

from __future__ import annotations

import math

import numpy as np
import pytest

from track_envs.metrics.summation import neumaier_add, numpy_sum


@pytest.mark.parametrize("n", [0, 1, 7, 8, 9, 127, 128, 129, 255, 256, 1000, 4099, 70_001])
def test_numpy_sum_is_bit_identical_to_numpy(n):
    rng = np.random.default_rng(n)
    for _ in range(5):
        values = rng.random(n) * 10.0 ** rng.integers(-8, 8, n) * rng.choice([-1.0, 1.0], n)
        assert numpy_sum(values) == values.sum()


def test_compensated_running_sum_is_exact_to_a_rounding():
    values = np.random.default_rng(1).random(100_000) * 1e-4
    values[::3] *= 1e8  # mixed magnitudes: a plain running sum drifts
    acc = np.zeros(2)
    for v in values:
        neumaier_add(acc, v)
    exact = math.fsum(values)
    assert abs((acc[0] + acc[1]) - exact) <= 2 * np.spacing(exact)
