"""Greedy assignment on a sparse list of admissible pairs: the cheapest free pair first.

Given the admissible pairs as compressed sparse rows (row ``i``'s columns
``cols[ptr[i]:ptr[i + 1]]``, ascending, with costs ``cost[ptr[i]:ptr[i + 1]]``), greedy takes the
pairs in the total order of the key ``(C_ij, i, j)`` (ascending cost, ties by row, then column)
and keeps a pair when its row and its column are still free. A stable sort of the row-major list
by cost gives that order, so a frame costs ``O(E log E)`` for ``E`` pairs.

This is the matching of the dense rounds of mutual best matches
([`agents.tracking.assign.assign_greedy`][agents.tracking.assign.assign_greedy]): a pair that is the first
minimum of its row (ties: lowest column) and the first minimum of its column (ties: lowest row) among the free
entries is the least pair under ``(C, i, j)`` of every pair that shares its row or its column,
so greedy in that order takes it whatever it took before; removing those pairs' rows and
columns leaves the same problem to both.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.assignment.lone_pairs import partner_pairs
from track_envs.infra.compiled import njit

IntArray = NDArray[np.int64]
FloatArray = NDArray[np.float64]

__all__ = ["greedy_sparse"]


@njit(cache=True)
def greedy_sparse(
    ptr: IntArray, cols: IntArray, cost: FloatArray, n_cols: int, gate: float
) -> tuple[IntArray, IntArray]:
    """Greedy matching of the pairs with ``cost <= gate`` (module docstring).

    Args:
        ptr, cols, cost: The pairs as compressed sparse rows, columns ascending within a row.
        n_cols: Number of columns.
        gate: Pairs above it (and NaN) are not admissible.

    Returns:
        ``(rows, cols)`` of the matching, rows ascending.
    """
    n = ptr.shape[0] - 1
    n_ok = 0
    for e in range(cost.shape[0]):
        n_ok += cost[e] <= gate
    pair_row = np.empty(n_ok, dtype=np.int64)
    pair_col = np.empty(n_ok, dtype=np.int64)
    key = np.empty(n_ok)
    t = 0
    for i in range(n):  # the admissible pairs in row-major order
        for e in range(ptr[i], ptr[i + 1]):
            if cost[e] <= gate:
                pair_row[t] = i
                pair_col[t] = cols[e]
                key[t] = cost[e]
                t += 1
    order = np.argsort(key, kind="mergesort")  # stable: equal costs stay row-major
    partner = np.full(n, -1, dtype=np.int64)
    col_taken = np.zeros(n_cols, dtype=np.bool_)
    for t in range(n_ok):
        i = pair_row[order[t]]
        j = pair_col[order[t]]
        if partner[i] < 0 and not col_taken[j]:
            partner[i] = j
            col_taken[j] = True
    return partner_pairs(partner)
