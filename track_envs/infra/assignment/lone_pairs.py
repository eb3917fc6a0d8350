"""Sparse-aware linear assignment with misses: the lone-pair split and the ``[C | M]`` problem.

The trackers' association and the GOSPA metric solve the same problem: rows (tracks, truths) and
columns (detections, estimates), a cost ``C_ij`` per pair, a pair admissible when
``C_ij <= γ``, and

.. math::

    \\min_{\\pi} \\sum_{(i, j) \\in \\pi} C_{ij} + γ \\, (n - |\\pi|)

over matchings ``π`` of admissible pairs (every unassigned row pays the miss cost ``γ``);
equivalently ``\\max_\\pi \\sum_{(i,j) \\in \\pi} (γ - C_{ij})``.

1. **Lone pairs** ([`split_lone_pairs`][track_envs.infra.assignment.lone_pairs.split_lone_pairs]). Tracking
problems are sparse: after gating, most
   rows have one admissible column and most of those columns only that row. A pair alone in both
   its row and its column gains ``γ − C_ij >= 0`` and blocks nothing, so it belongs to an
   optimal assignment and is taken directly; only the *rest*, the rows and columns with admissible
   pairs outside lone pairs, compete. [`split_dense`][track_envs.infra.assignment.lone_pairs.split_dense] (a
   cost matrix) and [`split_sparse`][track_envs.infra.assignment.lone_pairs.split_sparse] (a row-major list of
   the admissible pairs) count the pairs and split them.
2. **The rest** ([`rest_problem`][track_envs.infra.assignment.lone_pairs.rest_problem]): the ``k`` competing
rows and ``l`` columns become the
   rectangular problem ``[C | M]`` with per-row miss columns, ``M`` (k × k) holding ``γ`` on its
   diagonal and every inadmissible entry (a pair above the gate, the off-diagonal of ``M``) one
   finite stand-in ``B = 2 (|γ| + 1)(k + 1) + max |C_admissible|``, larger than any feasible
   total of non-negative costs. Every row can take its miss column, so the problem stays feasible
   when a row or the whole matrix is gated out, and the solver never sees ``inf`` (the failure of
   Stone Soup issue 824).
3. **Merge** ([`merge_solution`][track_envs.infra.assignment.lone_pairs.merge_solution]): the solver's pairs
on real columns that are admissible,
   joined to the lone pairs, rows ascending.

The result is an optimum of the full problem; where several assignments are equally good, the
one returned may differ from solving the dense matrix. The split, the problem and the merge are
compiled (numba), so compiled kernels call them directly;
[`min_cost_with_misses`][track_envs.infra.assignment.lone_pairs.min_cost_with_misses] and
[`solve_split`][track_envs.infra.assignment.lone_pairs.solve_split] run them around
``scipy.optimize.linear_sum_assignment``; compiled callers (the GOSPA kernel) solve the rest with its compiled
twin,
[`track_envs.infra.assignment.shortest_augmenting_path.linear_sum_assignment`][track_envs.infra.assignment.shortest_augmenting_path.linear_sum_assignment].
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from track_envs.infra.compiled import njit

IntArray = NDArray[np.int64]
Pairs = tuple[IntArray, IntArray]
EMPTY_PAIRS: Pairs = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))


@njit(cache=True)
def split_lone_pairs(
    row_count: IntArray, only_col: IntArray, col_count: IntArray
) -> tuple[IntArray, IntArray, IntArray]:
    """Split the admissible pairs, given by their counts, into lone pairs and the rest.

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
    rest_rows = np.empty(n, dtype=np.int64)
    col_lone = np.zeros(m, dtype=np.bool_)
    n_rest_rows = 0
    for i in range(n):
        if row_count[i] == 1 and col_count[only_col[i]] == 1:
            partner[i] = only_col[i]
            col_lone[only_col[i]] = True
        elif row_count[i] > 0:
            rest_rows[n_rest_rows] = i
            n_rest_rows += 1
    rest_cols = np.empty(m, dtype=np.int64)
    n_rest_cols = 0
    for j in range(m):
        if col_count[j] > 0 and not col_lone[j]:
            rest_cols[n_rest_cols] = j
            n_rest_cols += 1
    return partner, rest_rows[:n_rest_rows], rest_cols[:n_rest_cols]


@njit(cache=True)
def split_dense(cost: NDArray[np.float64], gate: float) -> tuple[IntArray, IntArray, IntArray]:
    """[`split_lone_pairs`][track_envs.infra.assignment.lone_pairs.split_lone_pairs] of the admissible pairs
    ``cost <= gate`` of a matrix (n, m)."""
    n, m = cost.shape
    row_count = np.zeros(n, dtype=np.int64)
    only_col = np.zeros(n, dtype=np.int64)  # the last admissible column: the only one where one
    col_count = np.zeros(m, dtype=np.int64)
    for i in range(n):
        row = cost[i]
        count = 0
        last = 0
        for j in range(m):
            hit = row[j] <= gate
            count += hit
            col_count[j] += hit
            last = max(last, j if hit else 0)
        row_count[i] = count
        only_col[i] = last
    return split_lone_pairs(row_count, only_col, col_count)


@njit(cache=True)
def split_sparse(ptr: IntArray, cols: IntArray, n_cols: int) -> tuple[IntArray, IntArray, IntArray]:
    """[`split_lone_pairs`][track_envs.infra.assignment.lone_pairs.split_lone_pairs] of admissible pairs
    listed row-major.

    Args:
        ptr, cols: Row ``i``'s admissible columns are ``cols[ptr[i]:ptr[i + 1]]`` (no repeats).
        n_cols: Number of columns.
    """
    n = len(ptr) - 1
    row_count = np.zeros(n, dtype=np.int64)
    only_col = np.zeros(n, dtype=np.int64)
    col_count = np.zeros(n_cols, dtype=np.int64)
    for i in range(n):
        row_count[i] = ptr[i + 1] - ptr[i]
        if row_count[i] == 1:
            only_col[i] = cols[ptr[i]]
        for e in range(ptr[i], ptr[i + 1]):
            col_count[cols[e]] += 1
    return split_lone_pairs(row_count, only_col, col_count)


@njit(cache=True)
def partner_pairs(partner: IntArray) -> Pairs:
    """``(rows, cols)`` of the rows with a partner (``partner >= 0``), rows ascending."""
    rows = np.flatnonzero(partner >= 0)
    return rows, partner[rows]


@njit(cache=True)
def rest_problem(
    cost: NDArray[np.float64], gate: float, rest_rows: IntArray, rest_cols: IntArray
) -> NDArray[np.float64]:
    """The rectangular problem ``[C | M]`` of the competing rows and columns, for the solver.

    ``C`` is the ``rest_rows`` × ``rest_cols`` block of ``cost`` (entries above ``gate``, and NaN,
    inadmissible); ``M`` (k, k) holds the miss cost ``γ = gate`` on its diagonal. Every
    inadmissible entry holds the stand-in ``B = 2 (|γ| + 1)(k + 1) + max |C_admissible|``.

    Returns:
        ``[C | M]``, shape (k, l + k) for ``k`` rows and ``l`` columns.
    """
    k = rest_rows.shape[0]
    n_cols = rest_cols.shape[0]
    largest = 0.0
    for a in range(k):
        for b in range(n_cols):
            c = cost[rest_rows[a], rest_cols[b]]
            if c <= gate and abs(c) > largest:
                largest = abs(c)
    big = 2.0 * (abs(gate) + 1.0) * (k + 1) + largest
    problem = np.full((k, n_cols + k), big)
    for a in range(k):
        for b in range(n_cols):
            c = cost[rest_rows[a], rest_cols[b]]
            if c <= gate:
                problem[a, b] = c
        problem[a, n_cols + a] = gate
    return problem


@njit(cache=True)
def merge_solution(
    cost: NDArray[np.float64],
    gate: float,
    lone_rows: IntArray,
    lone_cols: IntArray,
    rest_rows: IntArray,
    rest_cols: IntArray,
    rows: IntArray,
    cols: IntArray,
) -> Pairs:
    """The lone pairs and the solver's admissible pairs of
    [`rest_problem`][track_envs.infra.assignment.lone_pairs.rest_problem], rows ascending.

    Args:
        cost, gate, rest_rows, rest_cols: As given to
            [`rest_problem`][track_envs.infra.assignment.lone_pairs.rest_problem].
        lone_rows, lone_cols: The lone pairs, rows ascending.
        rows, cols: The solver's assignment of ``[C | M]`` (rows ascending); a column past ``C``
            is a miss, and a pair above the gate is dropped.

    Returns:
        ``(rows, cols)`` in the indices of ``cost``.
    """
    n_cols = rest_cols.shape[0]
    keep = np.zeros(rows.shape[0], dtype=np.bool_)
    n_keep = 0
    for t in range(rows.shape[0]):
        if cols[t] < n_cols and cost[rest_rows[rows[t]], rest_cols[cols[t]]] <= gate:
            keep[t] = True
            n_keep += 1
    n_lone = lone_rows.shape[0]
    out_rows = np.empty(n_lone + n_keep, dtype=np.int64)
    out_cols = np.empty(n_lone + n_keep, dtype=np.int64)
    a = 0  # next lone pair
    t = 0  # next solver pair
    for k in range(n_lone + n_keep):
        while t < rows.shape[0] and not keep[t]:
            t += 1
        if t == rows.shape[0] or (a < n_lone and lone_rows[a] < rest_rows[rows[t]]):
            out_rows[k] = lone_rows[a]
            out_cols[k] = lone_cols[a]
            a += 1
        else:
            out_rows[k] = rest_rows[rows[t]]
            out_cols[k] = rest_cols[cols[t]]
            t += 1
    return out_rows, out_cols


def solve_split(
    cost: NDArray[np.float64],
    gate: float,
    lone_rows: IntArray,
    lone_cols: IntArray,
    rest_rows: IntArray,
    rest_cols: IntArray,
) -> Pairs:
    """Steps 2 and 3 after a split: the rest by ``scipy.optimize.linear_sum_assignment`` on
    [`rest_problem`][track_envs.infra.assignment.lone_pairs.rest_problem], merged with the lone pairs.

    Returns:
        ``(rows, cols)`` of the assigned admissible pairs, rows ascending.
    """
    if len(rest_rows) == 0:
        return lone_rows, lone_cols
    rows, cols = linear_sum_assignment(rest_problem(cost, gate, rest_rows, rest_cols))
    return merge_solution(
        cost, gate, lone_rows, lone_cols, rest_rows, rest_cols, rows.astype(np.int64), cols.astype(np.int64)
    )


def min_cost_with_misses(cost: NDArray[np.floating], gate: float) -> Pairs:
    """Minimise Σ cost over assigned pairs + ``gate`` per unassigned row, over pairs with cost <= gate.

    Lone pairs directly, the rest as ``[C | M]``
    ([`split_dense`][track_envs.infra.assignment.lone_pairs.split_dense],
    [`solve_split`][track_envs.infra.assignment.lone_pairs.solve_split]).

    Returns:
        ``(rows, cols)`` of the assigned pairs, rows ascending.
    """
    matrix = np.ascontiguousarray(cost, dtype=np.float64)
    if matrix.ndim != 2:
        raise ValueError(f"cost must be a matrix (n, m), got shape {matrix.shape}")
    gamma = float(gate)
    partner, rest_rows, rest_cols = split_dense(matrix, gamma)
    lone_rows, lone_cols = partner_pairs(partner)
    return solve_split(matrix, gamma, lone_rows, lone_cols, rest_rows, rest_cols)
