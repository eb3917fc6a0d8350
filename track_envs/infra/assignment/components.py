"""Assignment with misses on a sparse list of admissible pairs: lone pairs, then one small exact
problem per connected component.

The problem is that of [`track_envs.infra.assignment.lone_pairs`][track_envs.infra.assignment.lone_pairs],

.. math::

    \\min_{\\pi} \\sum_{(i, j) \\in \\pi} C_{ij} + γ \\, (n - |\\pi|),

over matchings ``π`` of admissible pairs, given here as compressed sparse rows: row ``i``'s
admissible columns are ``cols[ptr[i]:ptr[i + 1]]`` (ascending) with costs
``cost[ptr[i]:ptr[i + 1]]`` (each ``<= γ``). Nothing of size ``n × m`` is ever built.

1. **Lone pairs** ([`split_sparse`][track_envs.infra.assignment.lone_pairs.split_sparse]): a pair alone in
   its row and its column belongs to an optimum and is taken directly.
2. **Components.** The other admissible pairs form a bipartite graph (rows and columns as nodes,
   pairs as edges). The objective is a sum over rows and every pair joins a row and a column of
   the same connected component, so the problem separates: a matching is optimal if and only if
   its restriction to every component is optimal there. A union–find over the pairs (path halving,
   union by index) labels the components in ``O(E α(E))``; the rows and columns of each are
   listed ascending (a counting sort by component).
3. **Each component** of ``k`` rows and ``l`` columns is solved exactly as its own ``[C | M]``
   problem ([`rest_problem`][track_envs.infra.assignment.lone_pairs.rest_problem]'s matrix: ``γ`` on the
   diagonal of the miss block ``M``, the stand-in ``B = 2 (|γ| + 1)(k + 1) + max |C|`` for every
   inadmissible entry) by the compiled shortest augmenting path solver
   ([`linear_sum_assignment`][track_envs.infra.assignment.shortest_augmenting_path.linear_sum_assignment]),
   all components in one compiled loop: ``O(k² (k + l))`` each, linear in the number of rows when
   the components stay small, as they do for gates of bounded size in a scene of bounded
   density. A component whose matrix would exceed
   [`DENSE_LIMIT`][track_envs.infra.assignment.components.DENSE_LIMIT] entries (the giant component of a first
   frame, when new tracks' gates are wide) is solved on its pairs by sparse shortest augmenting paths instead
   ([`solve_with_misses`][track_envs.infra.assignment.sparse_path.solve_with_misses]), in memory linear in its
   pairs.

The summed cost equals the optimum of the one dense ``[C | M]`` problem; where several matchings
are optimal (exactly equal sums), the one returned may differ from the dense solver's.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.assignment.lone_pairs import partner_pairs, split_sparse
from track_envs.infra.assignment.shortest_augmenting_path import linear_sum_assignment
from track_envs.infra.assignment.sparse_path import solve_with_misses
from track_envs.infra.compiled import njit

IntArray = NDArray[np.int64]
FloatArray = NDArray[np.float64]

__all__ = ["DENSE_LIMIT", "admissible_only", "component_labels", "solve_sparse"]

#: A component whose dense ``[C | M]`` matrix would have more entries than this is solved by
#: sparse shortest augmenting paths instead.
DENSE_LIMIT = 1 << 16


@njit(cache=True)
def _root(parent: IntArray, a: int) -> int:
    """The root of node ``a`` (path halving)."""
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    return a


@njit(cache=True)
def component_labels(
    ptr: IntArray, cols: IntArray, n_cols: int, rows_in: NDArray[np.bool_]
) -> tuple[IntArray, IntArray, int]:
    """Connected components of the bipartite graph of the pairs of the rows ``rows_in``.

    Args:
        ptr, cols: The pairs, row ``i``'s columns ``cols[ptr[i]:ptr[i + 1]]``.
        n_cols: Number of columns.
        rows_in: (n,) the rows whose pairs count (the others and their columns get no label).

    Returns:
        ``(row_label (n,), col_label (n_cols,), n_components)``: the component of every row and
            column with a counted pair (−1 for the others), numbered ``0, 1, ...`` in the order of
            their smallest row.
    """
    n = ptr.shape[0] - 1
    parent = np.arange(n + n_cols, dtype=np.int64)  # rows 0..n-1, then columns
    for i in range(n):
        if not rows_in[i]:
            continue
        for e in range(ptr[i], ptr[i + 1]):
            a = _root(parent, i)
            b = _root(parent, n + cols[e])
            if a != b:  # union by index: the smaller root (a row when there is one) stays
                if a < b:
                    parent[b] = a
                else:
                    parent[a] = b
    row_label = np.full(n, -1, dtype=np.int64)
    col_label = np.full(n_cols, -1, dtype=np.int64)
    label_of_root = np.full(n + n_cols, -1, dtype=np.int64)
    count = 0
    for i in range(n):
        if not rows_in[i] or ptr[i + 1] == ptr[i]:
            continue
        r = _root(parent, i)
        if label_of_root[r] < 0:
            label_of_root[r] = count
            count += 1
        row_label[i] = label_of_root[r]
        for e in range(ptr[i], ptr[i + 1]):
            col_label[cols[e]] = row_label[i]
    return row_label, col_label, count


@njit(cache=True)
def _by_label(label: IntArray, n_labels: int) -> tuple[IntArray, IntArray]:
    """Counting sort: ``members[start[c]:start[c + 1]]`` are the indices with label ``c``, ascending."""
    start = np.zeros(n_labels + 1, dtype=np.int64)
    for x in range(label.shape[0]):
        if label[x] >= 0:
            start[label[x] + 1] += 1
    for c in range(n_labels):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    members = np.empty(start[n_labels], dtype=np.int64)
    for x in range(label.shape[0]):
        c = label[x]
        if c >= 0:
            members[fill[c]] = x
            fill[c] += 1
    return start, members


@njit(cache=True)
def admissible_only(
    ptr: IntArray, cols: IntArray, cost: FloatArray, gate: float
) -> tuple[IntArray, IntArray, FloatArray]:
    """The pairs with ``cost <= gate`` of compressed sparse rows (the same arrays when all are)."""
    n_keep = 0
    for e in range(cost.shape[0]):
        n_keep += cost[e] <= gate
    if n_keep == cost.shape[0]:
        return ptr, cols, cost
    n = ptr.shape[0] - 1
    out_ptr = np.zeros(n + 1, dtype=np.int64)
    out_cols = np.empty(n_keep, dtype=np.int64)
    out_cost = np.empty(n_keep)
    t = 0
    for i in range(n):
        for e in range(ptr[i], ptr[i + 1]):
            if cost[e] <= gate:
                out_cols[t] = cols[e]
                out_cost[t] = cost[e]
                t += 1
        out_ptr[i + 1] = t
    return out_ptr, out_cols, out_cost


@njit(cache=True)
def _solve_large(
    ptr: IntArray,
    cols: IntArray,
    cost: FloatArray,
    gate: float,
    rows: IntArray,
    comp_cols: IntArray,
    local: IntArray,
    partner: IntArray,
) -> None:
    """One component too large for a dense ``[C | M]`` matrix, by sparse shortest augmenting paths
    ([`solve_with_misses`][track_envs.infra.assignment.sparse_path.solve_with_misses]); ``partner`` in
    place."""
    k = rows.shape[0]
    sub_ptr = np.zeros(k + 1, dtype=np.int64)
    for a in range(k):
        sub_ptr[a + 1] = sub_ptr[a] + ptr[rows[a] + 1] - ptr[rows[a]]
    sub_cols = np.empty(sub_ptr[k], dtype=np.int64)
    sub_cost = np.empty(sub_ptr[k])
    for a in range(k):
        t = sub_ptr[a]
        for e in range(ptr[rows[a]], ptr[rows[a] + 1]):
            sub_cols[t] = local[cols[e]]
            sub_cost[t] = cost[e]
            t += 1
    col_of = solve_with_misses(sub_ptr, sub_cols, sub_cost, comp_cols.shape[0], gate)
    for a in range(k):
        if col_of[a] >= 0:
            partner[rows[a]] = comp_cols[col_of[a]]


@njit(cache=True)
def solve_sparse(
    ptr: IntArray, cols: IntArray, cost: FloatArray, n_cols: int, gate: float
) -> tuple[IntArray, IntArray]:
    """Minimise Σ cost over assigned pairs + ``gate`` per unassigned row (module docstring).

    Args:
        ptr, cols, cost: The pairs as compressed sparse rows (no repeated column in a row); only
            those with ``cost <= gate`` are admissible (the others, and NaN, are dropped first).
        n_cols: Number of columns.
        gate: The miss cost ``γ``.

    Returns:
        ``(rows, cols)`` of the assigned pairs, rows ascending.
    """
    ptr, cols, cost = admissible_only(ptr, cols, cost, gate)
    n = ptr.shape[0] - 1
    partner, rest_rows, _ = split_sparse(ptr, cols, n_cols)
    if rest_rows.shape[0] > 0:
        rows_in = np.zeros(n, dtype=np.bool_)
        for a in range(rest_rows.shape[0]):
            rows_in[rest_rows[a]] = True
        row_label, col_label, n_comp = component_labels(ptr, cols, n_cols, rows_in)
        row_start, row_members = _by_label(row_label, n_comp)
        col_start, col_members = _by_label(col_label, n_comp)
        local = np.full(n_cols, -1, dtype=np.int64)
        for c in range(n_comp):
            k = row_start[c + 1] - row_start[c]
            n_local = col_start[c + 1] - col_start[c]
            for b in range(n_local):
                local[col_members[col_start[c] + b]] = b
            if k * (n_local + k) > DENSE_LIMIT:
                _solve_large(
                    ptr,
                    cols,
                    cost,
                    gate,
                    row_members[row_start[c] : row_start[c + 1]],
                    col_members[col_start[c] : col_start[c + 1]],
                    local,
                    partner,
                )
                continue
            largest = 0.0
            for a in range(k):
                i = row_members[row_start[c] + a]
                for e in range(ptr[i], ptr[i + 1]):
                    if abs(cost[e]) > largest:
                        largest = abs(cost[e])
            big = 2.0 * (abs(gate) + 1.0) * (k + 1) + largest
            problem = np.full((k, n_local + k), big)
            for a in range(k):
                i = row_members[row_start[c] + a]
                for e in range(ptr[i], ptr[i + 1]):
                    problem[a, local[cols[e]]] = cost[e]
                problem[a, n_local + a] = gate
            sol_rows, sol_cols = linear_sum_assignment(problem)
            for t in range(sol_rows.shape[0]):
                b = sol_cols[t]
                if b < n_local and problem[sol_rows[t], b] <= gate:
                    partner[row_members[row_start[c] + sol_rows[t]]] = col_members[col_start[c] + b]
    return partner_pairs(partner)
