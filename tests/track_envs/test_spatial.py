"""The grid index returns exactly the points inside each box, as a dense scan would."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from track_envs.infra.spatial import build_grid, candidate_pairs


def dense_scan(centres, half, points):
    """Row by row, the points inside the box on the first K axes (the oracle)."""
    K = half.shape[1]
    return [
        [j for j in range(len(points)) if np.all(np.abs(points[j, :K] - centres[i, :K]) <= half[i])]
        for i in range(len(centres))
    ]


@settings(max_examples=200, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    dim=st.integers(1, 3),
    n=st.integers(0, 30),
    m=st.integers(0, 30),
    scale=st.sampled_from([0.0, 0.01, 1.0, 50.0]),
    snap=st.booleans(),
)
def test_candidates_equal_a_dense_scan(seed, dim, n, m, scale, snap):
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-5, 5, (n, dim))
    points = rng.uniform(-5, 5, (m, dim))
    if snap:  # integer coordinates: duplicates and points on box edges
        centres, points = np.round(centres), np.round(points)
    if m > 2:
        points[0] = np.nan
        points[1] = points[2]
    if n > 1:
        centres[0, 0] = np.inf
    half = np.round(rng.uniform(0, 2, (n, min(dim, 2))) * scale, 2)
    ptr, cols = candidate_pairs(centres, half, points)
    got = [list(cols[ptr[i] : ptr[i + 1]]) for i in range(n)]
    assert got == dense_scan(centres, half, points)


def test_one_number_is_every_half_width():
    rng = np.random.default_rng(1)
    points = rng.uniform(0, 10, (200, 2))
    ptr, cols = candidate_pairs(points, 0.7, points)
    assert got_rows(ptr, cols) == dense_scan(points, np.full((200, 2), 0.7), points)


def got_rows(ptr, cols):
    return [list(cols[ptr[i] : ptr[i + 1]]) for i in range(len(ptr) - 1)]


def test_the_grid_stays_linear_in_the_points():
    """A huge spread with one tiny box width: the cell is enlarged, never more than 4 m + 16 cells."""
    points = np.array([[0.0, 0.0], [1e9, 1e9], [5.0, 5.0]])
    grid = build_grid(points, 2, 1e-9)
    assert int(np.prod(grid.shape)) <= 4 * 3 + 16
    ptr, cols = candidate_pairs(points, 1e-3, points)
    assert got_rows(ptr, cols) == [[0], [1], [2]]


@pytest.mark.parametrize("bad", [np.inf, np.nan, -1.0])
def test_an_unbounded_gate_is_an_error_naming_the_row(bad):
    half = np.array([1.0, bad, 1.0])
    with pytest.raises(ValueError, match=r"track 1: gate half-width \[.*\] is not a finite number"):
        candidate_pairs(np.zeros((3, 2)), half, np.zeros((4, 2)), what="track")


def test_shapes_are_checked():
    with pytest.raises(ValueError, match="share D"):
        candidate_pairs(np.zeros((3, 2)), 1.0, np.zeros((4, 3)))
    with pytest.raises(ValueError, match=r"half must be"):
        candidate_pairs(np.zeros((3, 2)), np.ones((2, 2)), np.zeros((4, 2)))
    ptr, cols = candidate_pairs(np.zeros((0, 2)), 1.0, np.zeros((4, 2)))
    assert ptr.tolist() == [0] and cols.size == 0
    ptr, cols = candidate_pairs(np.zeros((2, 2)), 1.0, np.zeros((0, 2)))
    assert ptr.tolist() == [0, 0, 0] and cols.size == 0
