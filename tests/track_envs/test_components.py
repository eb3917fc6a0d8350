"""Assignment on a sparse list of pairs: components and sparse augmenting paths against the dense
optimum, greedy against the dense rounds of mutual best matches (ties included)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linear_sum_assignment

from agents.tracking.assign import assign_greedy
from track_envs.infra.assignment.components import DENSE_LIMIT, component_labels, solve_sparse
from track_envs.infra.assignment.greedy import greedy_sparse
from track_envs.infra.assignment.lone_pairs import min_cost_with_misses
from track_envs.infra.assignment.sparse_path import solve_with_misses


def sparse_problem(seed: int, ties: bool) -> tuple[np.ndarray, float]:
    """A dense (n, m) view of a random sparse problem: most entries inadmissible (inf or above the
    gate), some rows and columns empty, some rows with pairs above the gate only; with ``ties``
    the costs come from a few values."""
    rng = np.random.default_rng(seed)
    n, m = (int(v) for v in rng.integers(0, 14, size=2))
    gate = float(rng.uniform(0.5, 3.0))
    density = rng.uniform(0.05, 0.6)
    values = rng.choice([0.0, 0.25, 0.5, 1.0, 2.0], size=(n, m)) if ties else rng.random((n, m)) * 2 * gate
    cost = np.where(rng.random((n, m)) < density, values, np.inf)
    if n:
        cost[rng.integers(n)] = gate * 1.5  # a row with every pair gated out
    return cost, gate


def as_csr(cost: np.ndarray, keep: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rows, cols = np.nonzero(keep)
    ptr = np.concatenate([[0], np.cumsum(keep.sum(axis=1))]).astype(np.int64)
    return ptr, cols.astype(np.int64), cost[rows, cols].astype(np.float64)


def dense_optimum(cost: np.ndarray, gate: float) -> float:
    """min Σ cost + gate · misses by scipy on the whole [C | M] matrix (inadmissible: 1e9)."""
    n, m = cost.shape
    full = np.full((n, m + n), 1e9)
    full[:, :m] = np.where(cost <= gate, cost, 1e9)
    full[np.arange(n), m + np.arange(n)] = gate
    rows, cols = linear_sum_assignment(full)
    return float(full[rows, cols].sum())


def check_matching(cost: np.ndarray, gate: float, rows: np.ndarray, cols: np.ndarray) -> None:
    assert rows.dtype == cols.dtype == np.int64
    assert np.all(np.diff(rows) > 0) and len(set(cols.tolist())) == len(cols)
    assert np.all(cost[rows, cols] <= gate)


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 100_000), ties=st.booleans(), listed=st.sampled_from(["admissible", "finite"]))
def test_components_reach_the_dense_optimum(seed: int, ties: bool, listed: str) -> None:
    cost, gate = sparse_problem(seed, ties)
    # the list may hold pairs above the gate too: they are never assigned
    ptr, cols, values = as_csr(cost, cost <= gate if listed == "admissible" else np.isfinite(cost))
    rows, got = solve_sparse(ptr, cols, values, cost.shape[1], gate)
    check_matching(cost, gate, rows, got)
    total = cost[rows, got].sum() + gate * (cost.shape[0] - len(rows))
    assert total == pytest.approx(dense_optimum(cost, gate), rel=1e-12, abs=1e-12)
    if not ties:  # a unique optimum: the pairs of the dense path
        ref_rows, ref_cols = min_cost_with_misses(cost, gate)
        np.testing.assert_array_equal(rows, ref_rows)
        np.testing.assert_array_equal(got, ref_cols)


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 100_000), ties=st.booleans())
def test_sparse_greedy_is_the_dense_greedy(seed: int, ties: bool) -> None:
    cost, gate = sparse_problem(seed, ties)
    ptr, cols, values = as_csr(cost, np.isfinite(cost))
    rows, got = greedy_sparse(ptr, cols, values, cost.shape[1], gate)
    ref_rows, ref_cols = assign_greedy(cost, gate)
    np.testing.assert_array_equal(rows, ref_rows)
    np.testing.assert_array_equal(got, ref_cols)
    check_matching(cost, gate, rows, got)


def test_greedy_breaks_ties_by_row_then_column() -> None:
    # all four pairs cost the same: the dense rounds take (0, 0) (first minimum of row 0 and of
    # column 0), then (1, 1); a tie between rows goes to the lower row, between columns to the lower one
    cost = np.array([[1.0, 1.0], [1.0, 1.0]])
    ptr, cols, values = as_csr(cost, np.ones((2, 2), bool))
    for assign in (lambda: greedy_sparse(ptr, cols, values, 2, 2.0), lambda: assign_greedy(cost, 2.0)):
        rows, got = assign()
        assert rows.tolist() == [0, 1] and got.tolist() == [0, 1]
    # row 1's cheapest column is 0, which row 0 also wants at the same cost: row 0 takes it
    cost = np.array([[0.5, 0.7], [0.5, 0.6]])
    ptr, cols, values = as_csr(cost, np.ones((2, 2), bool))
    for rows, got in (greedy_sparse(ptr, cols, values, 2, 2.0), assign_greedy(cost, 2.0)):
        assert rows.tolist() == [0, 1] and got.tolist() == [0, 1]


def test_empty_and_gated_out_problems() -> None:
    for n, m in [(0, 0), (0, 3), (3, 0)]:
        ptr = np.zeros(n + 1, np.int64)
        for solve in (solve_sparse, greedy_sparse):
            rows, cols = solve(ptr, np.zeros(0, np.int64), np.zeros(0), m, 1.0)
            assert rows.shape == cols.shape == (0,)
    ptr, cols = np.array([0, 2, 3], np.int64), np.array([0, 1, 1], np.int64)
    for solve in (solve_sparse, greedy_sparse):
        rows, got = solve(ptr, cols, np.array([5.0, np.nan, 7.0]), 2, 1.0)
        assert len(rows) == len(got) == 0


def test_components_are_the_connected_pieces_of_the_pairs() -> None:
    # rows 0-1 share column 2; row 2 alone with columns 0, 3; row 3 has no pair; row 4 not counted
    ptr = np.array([0, 1, 3, 5, 5, 6], np.int64)
    cols = np.array([2, 2, 4, 0, 3, 1], np.int64)
    rows_in = np.array([True, True, True, True, False])
    row_label, col_label, count = component_labels(ptr, cols, 5, rows_in)
    assert count == 2
    assert row_label.tolist() == [0, 0, 1, -1, -1]
    assert col_label.tolist() == [1, -1, 0, 1, 0]


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 100_000), ties=st.booleans())
def test_sparse_augmenting_paths_reach_the_dense_optimum(seed: int, ties: bool) -> None:
    cost, gate = sparse_problem(seed, ties)
    ptr, cols, values = as_csr(cost, cost <= gate)
    col_of = solve_with_misses(ptr, cols, values, cost.shape[1], gate)
    rows = np.flatnonzero(col_of >= 0)
    check_matching(cost, gate, rows, col_of[rows])
    total = cost[rows, col_of[rows]].sum() + gate * (cost.shape[0] - len(rows))
    assert total == pytest.approx(dense_optimum(cost, gate), rel=1e-12, abs=1e-12)
    if not ties:
        ref_rows, ref_cols = min_cost_with_misses(cost, gate)
        np.testing.assert_array_equal(rows, ref_rows)
        np.testing.assert_array_equal(col_of[rows], ref_cols)


@pytest.mark.parametrize("seed", range(3))
def test_a_component_too_large_for_a_dense_matrix_is_solved_on_its_pairs(seed: int) -> None:
    # a band of 400 rows, each with pairs to its 3 neighbouring columns: one component whose
    # [C | M] matrix (400 × 800) exceeds DENSE_LIMIT
    rng = np.random.default_rng(seed)
    n = 400
    cost = np.full((n, n), np.inf)
    for i in range(n):
        for j in range(max(0, i - 1), min(n, i + 2)):
            cost[i, j] = rng.random() * 2.0
    assert n * (2 * n) > DENSE_LIMIT
    ptr, cols, values = as_csr(cost, np.isfinite(cost))
    rows, got = solve_sparse(ptr, cols, values, n, 1.0)
    ref_rows, ref_cols = min_cost_with_misses(cost, 1.0)
    np.testing.assert_array_equal(rows, ref_rows)
    np.testing.assert_array_equal(got, ref_cols)
