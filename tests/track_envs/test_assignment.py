"""The lone-pair split against its definition; the assignment with misses against the dense optimum."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from track_envs.infra.assignment.lone_pairs import min_cost_with_misses, split_dense, split_sparse


def lone_pairs_by_definition(admissible: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pairs alone in their row and column; the other rows and columns with admissible pairs."""
    row_count = admissible.sum(axis=1)
    col_count = admissible.sum(axis=0)
    lone = admissible & (row_count[:, None] == 1) & (col_count[None, :] == 1)
    rows, cols = np.nonzero(lone)
    rest_rows = np.flatnonzero((row_count > 0) & ~lone.any(axis=1))
    rest_cols = np.flatnonzero((col_count > 0) & ~lone.any(axis=0))
    return rows, cols, rest_rows, rest_cols


def random_costs(rng: np.random.Generator) -> tuple[np.ndarray, float]:
    n, m = rng.integers(0, 12, size=2)
    cost = (
        rng.choice([0.0, 0.5, 1.0, 2.0, 5.0], size=(n, m)) if rng.random() < 0.3 else rng.random((n, m)) * 4
    )
    cost[rng.random((n, m)) < 0.05] = np.nan
    cost[rng.random((n, m)) < 0.05] = np.inf
    return cost, float(rng.uniform(0.05, 1.5))


def assert_split_is(got: tuple[np.ndarray, np.ndarray, np.ndarray], admissible: np.ndarray) -> None:
    partner, rest_rows, rest_cols = got
    rows, cols, ref_rest_rows, ref_rest_cols = lone_pairs_by_definition(admissible)
    np.testing.assert_array_equal(np.flatnonzero(partner >= 0), rows)
    np.testing.assert_array_equal(partner[rows], cols)
    np.testing.assert_array_equal(rest_rows, ref_rest_rows)
    np.testing.assert_array_equal(rest_cols, ref_rest_cols)


@pytest.mark.parametrize("seed", range(40))
def test_dense_and_sparse_splits_follow_the_definition(seed: int) -> None:
    cost, gate = random_costs(np.random.default_rng(seed))
    admissible = cost <= gate
    assert_split_is(split_dense(cost, gate), admissible)
    counts = admissible.sum(axis=1)
    ptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    cols = np.nonzero(admissible)[1].astype(np.int64)
    assert_split_is(split_sparse(ptr, cols, admissible.shape[1]), admissible)


def dense_optimum(cost: np.ndarray, gate: float) -> float:
    """min Σ cost + gate · misses by scipy on the whole augmented matrix (inadmissible: 1e9)."""
    n, m = cost.shape
    full = np.full((n, m + n), 1e9)
    full[:, :m] = np.where(cost <= gate, cost, 1e9)
    full[np.arange(n), m + np.arange(n)] = gate
    rows, cols = linear_sum_assignment(full)
    return float(full[rows, cols].sum())


@pytest.mark.parametrize("seed", range(60))
def test_assignment_with_misses_reaches_the_dense_optimum(seed: int) -> None:
    cost, gate = random_costs(np.random.default_rng(seed))
    rows, cols = min_cost_with_misses(cost, gate)
    assert rows.dtype == cols.dtype == np.int64
    assert np.all(np.diff(rows) > 0) and len(set(cols.tolist())) == len(cols)
    assert np.all(cost[rows, cols] <= gate)
    total = cost[rows, cols].sum() + gate * (cost.shape[0] - len(rows))
    assert total == pytest.approx(dense_optimum(cost, gate), rel=1e-12, abs=1e-12)


def test_a_cost_that_is_not_a_matrix_is_named() -> None:
    with pytest.raises(ValueError, match=r"cost must be a matrix \(n, m\), got shape \(4,\)"):
        min_cost_with_misses(np.zeros(4), 1.0)
