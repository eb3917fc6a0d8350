"""Dense linear sum assignment for numba kernels, step for step as ``scipy.optimize.linear_sum_assignment``.

Minimise ``Σ_i C[i, σ(i)]`` over injective maps from the smaller side of ``C`` (r × c) into the
larger one. The solver is Crouse's shortest augmenting path method (D. F. Crouse, "On implementing
2D rectangular assignment algorithms", IEEE Trans. Aerospace and Electronic Systems 52(4), 2016,
pp. 1685-1686) exactly as scipy implements it (``rectangular_lsap.cpp``): rows are added one at a
time, each by a Dijkstra search over reduced costs ``C[i, j] − u_i − v_j`` that scans the
remaining columns from the last to the first and, among equally short paths, prefers an
unassigned column; a tall matrix is solved transposed. Being the same sequence of floating-point
operations, it returns the same assignment as scipy also where several are optimal, which is
what reproducing py-motmetrics' tie-breaking needs. It is the dense solver under the compiled
metric kernels; [`track_envs.infra.assignment.lone_pairs`][track_envs.infra.assignment.lone_pairs] reduces a
gated problem with misses to such a dense one (see
[`track_envs.infra.assignment`][track_envs.infra.assignment] for why both exist).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.compiled import njit


@njit(cache=True)
def _augmenting_path(
    cost: NDArray[np.float64],
    u: NDArray[np.float64],
    v: NDArray[np.float64],
    path: NDArray[np.int64],
    row4col: NDArray[np.int64],
    shortest: NDArray[np.float64],
    row: int,
    in_rows: NDArray[np.bool_],
    in_cols: NDArray[np.bool_],
    remaining: NDArray[np.int64],
) -> tuple[int, float]:
    """Sink column of the shortest augmenting path from ``row`` and its length (−1 if infeasible)."""
    nc = cost.shape[1]
    min_val = 0.0
    num_remaining = nc
    for it in range(nc):
        remaining[it] = nc - it - 1
    in_rows[:] = False
    in_cols[:] = False
    shortest[:] = np.inf
    i = row
    sink = -1
    while sink == -1:
        index = -1
        lowest = np.inf
        in_rows[i] = True
        for it in range(num_remaining):
            j = remaining[it]
            r = min_val + cost[i, j] - u[i] - v[j]
            if r < shortest[j]:
                path[j] = i
                shortest[j] = r
            if shortest[j] < lowest or (shortest[j] == lowest and row4col[j] == -1):
                lowest = shortest[j]
                index = it
        min_val = lowest
        if min_val == np.inf:
            return -1, min_val
        j = remaining[index]
        if row4col[j] == -1:
            sink = j
        else:
            i = row4col[j]
        in_cols[j] = True
        num_remaining -= 1
        remaining[index] = remaining[num_remaining]
    return sink, min_val


@njit(cache=True)
def _solve_wide(cost: NDArray[np.float64]) -> NDArray[np.int64]:
    """Column of each row of a matrix with rows <= columns (−1 everywhere if infeasible)."""
    nr, nc = cost.shape
    u = np.zeros(nr)
    v = np.zeros(nc)
    shortest = np.empty(nc)
    path = np.full(nc, -1, dtype=np.int64)
    col4row = np.full(nr, -1, dtype=np.int64)
    row4col = np.full(nc, -1, dtype=np.int64)
    in_rows = np.zeros(nr, dtype=np.bool_)
    in_cols = np.zeros(nc, dtype=np.bool_)
    remaining = np.empty(nc, dtype=np.int64)
    for cur in range(nr):
        sink, min_val = _augmenting_path(
            cost, u, v, path, row4col, shortest, cur, in_rows, in_cols, remaining
        )
        if sink < 0:
            return np.full(nr, -1, dtype=np.int64)
        u[cur] += min_val
        for i in range(nr):
            if in_rows[i] and i != cur:
                u[i] += min_val - shortest[col4row[i]]
        for j in range(nc):
            if in_cols[j]:
                v[j] -= min_val - shortest[j]
        j = sink
        while True:
            i = path[j]
            row4col[j] = i
            col4row[i], j = j, col4row[i]
            if i == cur:
                break
    return col4row


@njit(cache=True)
def linear_sum_assignment(cost: NDArray[np.float64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Min-cost assignment of a finite (r, c) matrix: row and column indices, rows ascending.

    Same result as ``scipy.optimize.linear_sum_assignment(cost)``; the caller guarantees finite
    entries (NaN or −inf make scipy raise; here they give an empty assignment).
    """
    nr, nc = cost.shape
    if nr == 0 or nc == 0 or not np.all(np.isfinite(cost) | (cost == np.inf)):
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    if nc < nr:
        col4row = _solve_wide(np.ascontiguousarray(cost.T))
        if nc and col4row[0] < 0:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        order = np.argsort(col4row)
        return col4row[order], order.astype(np.int64)
    col4row = _solve_wide(cost)
    if col4row[0] < 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    return np.arange(nr, dtype=np.int64), col4row
