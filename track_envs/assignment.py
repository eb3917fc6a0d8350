"""Sparse-aware linear assignment with misses, for the trackers.

Tracking problems are sparse: after gating, most rows have one admissible column, and most of
those columns have only that row. Such *lone pairs* belong to every optimal assignment (for the
objectives below), so they are taken directly and only the rest goes to
``scipy.optimize.linear_sum_assignment``. The result is an optimum of the full problem; where
several assignments are equally good, the one returned may differ from solving the dense matrix.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

Pairs = tuple[NDArray[np.int64], NDArray[np.int64]]
EMPTY_PAIRS: Pairs = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))


def lone_pairs(admissible: NDArray[np.bool_]) -> tuple[Pairs, NDArray[np.intp], NDArray[np.intp]]:
    """Split an admissibility matrix (n, m) into lone pairs and the rows and columns left to solve.

    Returns:
        ``((rows, cols), rest_rows, rest_cols)``: the pairs alone in both their row and column,
        and the rows and columns that have admissible pairs but are not in a lone pair.
    """
    row_count = np.count_nonzero(admissible, axis=1)
    col_count = np.count_nonzero(admissible, axis=0)
    single = np.flatnonzero(row_count == 1)
    # the one admissible column of those rows
    only_col = np.argmax(admissible[single], axis=1) if len(single) else np.zeros(0, dtype=np.intp)
    alone = col_count[only_col] == 1
    rows, cols = single[alone], only_col[alone]
    row_done = np.zeros(len(row_count), dtype=bool)
    row_done[rows] = True
    col_done = np.zeros(len(col_count), dtype=bool)
    col_done[cols] = True
    rest_rows = np.flatnonzero((row_count > 0) & ~row_done)
    rest_cols = np.flatnonzero((col_count > 0) & ~col_done)
    return (rows.astype(np.int64), cols.astype(np.int64)), rest_rows, rest_cols


@njit(cache=True)
def split_lone_pairs(
    row_count: NDArray[np.int64], only_col: NDArray[np.int64], col_count: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """:func:`lone_pairs` from the admissible-pair counts, for compiled callers.

    Args:
        row_count: Admissible pairs of each row (n,).
        only_col: For each row with one admissible pair, its column (other rows: any value).
        col_count: Admissible pairs of each column (m,).

    Returns:
        ``(partner, rest_rows, rest_cols)``: the column of each row's lone pair (-1 where the row
        is in none), and, ascending, the rows and columns that have admissible pairs but are
        not in a lone pair.
    """
    n, m = len(row_count), len(col_count)
    partner = np.full(n, -1, dtype=np.int64)
    col_lone = np.zeros(m, dtype=np.bool_)
    n_rest_rows = 0
    for i in range(n):
        if row_count[i] == 1 and col_count[only_col[i]] == 1:
            partner[i] = only_col[i]
            col_lone[only_col[i]] = True
        elif row_count[i] > 0:
            n_rest_rows += 1
    rest_rows = np.empty(n_rest_rows, dtype=np.int64)
    k = 0
    for i in range(n):
        if row_count[i] > 0 and partner[i] < 0:
            rest_rows[k] = i
            k += 1
    n_rest_cols = 0
    for j in range(m):
        n_rest_cols += col_count[j] > 0 and not col_lone[j]
    rest_cols = np.empty(n_rest_cols, dtype=np.int64)
    k = 0
    for j in range(m):
        if col_count[j] > 0 and not col_lone[j]:
            rest_cols[k] = j
            k += 1
    return partner, rest_rows, rest_cols


def _merge(first: Pairs, second: Pairs) -> Pairs:
    rows = np.concatenate([first[0], second[0]]).astype(np.int64)
    cols = np.concatenate([first[1], second[1]]).astype(np.int64)
    order = np.argsort(rows, kind="stable")
    return rows[order], cols[order]


def min_cost_with_misses(cost: NDArray[np.floating], gate: float) -> Pairs:
    """Minimise Σ cost over assigned pairs + ``gate`` per unassigned row, over pairs with cost <= gate.

    Equivalently, maximise Σ (gate − cost) over a matching of admissible pairs. Solved as the
    rectangular problem ``[C | M]`` with per-row miss columns (``M`` holds ``gate`` on its diagonal,
    every inadmissible entry one finite stand-in larger than any feasible total), so it stays
    feasible when a row or the whole matrix is gated out (never ``inf`` for the solver).

    Returns:
        ``(rows, cols)`` of the assigned pairs, rows ascending.
    """
    cost = np.asarray(cost, dtype=np.float64)
    n, m = cost.shape
    if n == 0 or m == 0:
        return EMPTY_PAIRS
    admissible = cost <= gate
    lone, rest_rows, rest_cols = lone_pairs(admissible)
    sub = cost[np.ix_(rest_rows, rest_cols)]
    rows, cols = _solve_with_misses(sub, gate)
    return _merge(lone, (rest_rows[rows].astype(np.int64), rest_cols[cols].astype(np.int64)))


def _solve_with_misses(cost: NDArray[np.floating], gate: float) -> Pairs:
    n, m = cost.shape
    admissible = cost <= gate
    if n == 0 or m == 0 or not admissible.any():
        return EMPTY_PAIRS
    big = 2.0 * (abs(gate) + 1.0) * (n + 1) + float(np.abs(cost[admissible]).max())
    full = np.full((n, m + n), big)
    full[:, :m] = np.where(admissible, cost, big)
    full[np.arange(n), m + np.arange(n)] = gate
    rows, cols = linear_sum_assignment(full)
    keep = cols < m
    rows, cols = rows[keep], cols[keep]
    keep = admissible[rows, cols]
    return rows[keep].astype(np.int64), cols[keep].astype(np.int64)
