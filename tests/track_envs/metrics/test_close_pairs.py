"""Sparse close pairs equal the dense scipy ``cdist`` matrix thresholded at the radius, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.distance import cdist

from track_envs.metrics.close_pairs import close_pairs, finite_entries


def dense_pairs(x: np.ndarray, y: np.ndarray, radius: float):
    """Oracle: every (i, j, d) of the full cdist matrix with d <= radius, row-major."""
    if len(x) == 0 or len(y) == 0:
        return []
    d = cdist(x, y)
    return [(i, j, d[i, j]) for i, j in zip(*np.nonzero(d <= radius), strict=True)]


def sparse_pairs(ptr, cols, dist):
    return [(i, int(cols[e]), dist[e]) for i in range(len(ptr) - 1) for e in range(ptr[i], ptr[i + 1])]


def point_sets(rng: np.random.Generator, kind: int):
    m, n, dims = rng.integers(0, 40), rng.integers(0, 40), rng.integers(1, 4)
    if kind == 0:  # a grid: many pairs exactly at the radius
        return rng.integers(0, 5, (m, dims)) * 0.5, rng.integers(0, 5, (n, dims)) * 0.5
    if kind == 1:  # widely spread with close partners (many cells, wider than the radius)
        x = rng.uniform(-1e4, 1e4, (m, dims))
        partners = x[rng.integers(0, max(m, 1), n)] if m else rng.uniform(-1e4, 1e4, (n, dims))
        return x, partners + rng.normal(0, 0.5, (n, dims))
    if kind == 2:  # non-finite coordinates never pair
        x, y = rng.uniform(0, 3, (m, dims)), rng.uniform(0, 3, (n, dims))
        x[rng.random(x.shape) < 0.1] = np.nan
        y[rng.random(y.shape) < 0.1] = rng.choice([np.inf, -np.inf, np.nan])
        return x, y
    return rng.uniform(0, 3, (m, dims)), rng.uniform(0, 3, (n, dims))  # all at one spot


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 3), st.sampled_from([0.5, 1.0, 2.5, 1e9]))
def test_close_pairs_equal_the_thresholded_cdist_matrix(seed, kind, radius):
    x, y = point_sets(np.random.default_rng(seed), kind)
    ptr, cols, dist = close_pairs(np.ascontiguousarray(x), np.ascontiguousarray(y), radius)
    assert sparse_pairs(ptr, cols, dist) == dense_pairs(x, y, radius)  # same pairs, same bits


def test_identical_coordinates_in_one_cell_and_empty_sets():
    x = np.zeros((3, 2))
    ptr, cols, dist = close_pairs(x, np.zeros((4, 2)), 1.0)
    assert ptr.tolist() == [0, 4, 8, 12] and cols.tolist() == [0, 1, 2, 3] * 3 and not dist.any()
    for a, b in [(np.zeros((0, 2)), x), (x, np.zeros((0, 2)))]:
        ptr, cols, _ = close_pairs(a, b, 1.0)
        assert ptr.tolist() == [0] * (len(a) + 1) and len(cols) == 0


@pytest.mark.parametrize("shape", [(0, 0), (3, 0), (0, 2), (4, 5)])
def test_finite_entries_of_a_dense_matrix(shape):
    rng = np.random.default_rng(0)
    matrix = rng.random(shape)
    matrix[rng.random(shape) < 0.4] = np.nan
    matrix[rng.random(shape) < 0.1] = np.inf
    ptr, cols, dist = finite_entries(matrix)
    rows, expected_cols = np.nonzero(np.isfinite(matrix))
    assert sparse_pairs(ptr, cols, dist) == [
        (i, j, matrix[i, j]) for i, j in zip(rows, expected_cols, strict=True)
    ]
