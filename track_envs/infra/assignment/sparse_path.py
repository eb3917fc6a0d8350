"""Shortest augmenting paths on a sparse problem with misses: exact, without a dense matrix.

The problem is one connected component of
[`track_envs.infra.assignment.components`][track_envs.infra.assignment.components]: ``k`` rows, ``l`` columns,
the admissible pairs as compressed sparse rows with costs ``C_ij``, and a private miss column ``l + i`` of
cost ``γ`` for every row ``i``, so that every row is matched (to a real column or to its miss) in

.. math::

    \\min_{\\pi} \\sum_{(i, j) \\in \\pi} C_{ij} + γ \\, (k - |\\pi|).

It is the method of
[`track_envs.infra.assignment.shortest_augmenting_path`][track_envs.infra.assignment.shortest_augmenting_path]
(Crouse; scipy's ``rectangular_lsap``) with the dense scan replaced by a graph search: rows are added one at a
time; from the new row a Dijkstra search over the reduced costs ``C_ij − u_i − v_j >= 0`` (``u``, ``v`` the
dual potentials) follows the row's edges and, through each column already matched, the edges of its row, until
it settles a free column (every miss column but the row's own is reachable only from its row, so a search ends
at the latest at the first miss column it settles). The path is flipped and the potentials of the settled rows
and columns are updated as in the dense method, which keeps every reduced cost non-negative, so each search is
a valid Dijkstra and the final matching optimal. A binary heap with lazy deletion holds the tentative
distances; a search resets only what it touched, so it costs ``O(E_s log E_s)`` for the ``E_s`` edges it
scanned — in a sparse scene the neighbourhood of the new row, not the whole component.

Where several matchings are optimal the one returned may differ from the dense solver's; it is
used for the components too large for a dense ``[C | M]`` matrix.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.compiled import njit

IntArray = NDArray[np.int64]
FloatArray = NDArray[np.float64]

__all__ = ["solve_with_misses"]


@njit(cache=True)
def _push(keys: FloatArray, items: IntArray, size: int, key: float, item: int) -> int:
    """Insert ``(key, item)`` into the binary min-heap of ``size`` entries; the new size."""
    at = size
    keys[at] = key
    items[at] = item
    while at > 0:
        up = (at - 1) // 2
        if keys[up] <= keys[at]:
            break
        keys[up], keys[at] = keys[at], keys[up]
        items[up], items[at] = items[at], items[up]
        at = up
    return size + 1


@njit(cache=True)
def _pop(keys: FloatArray, items: IntArray, size: int) -> int:
    """Remove the root of the heap (read it first); the new size."""
    size -= 1
    keys[0] = keys[size]
    items[0] = items[size]
    at = 0
    while True:
        low = at
        a = 2 * at + 1
        b = a + 1
        if a < size and keys[a] < keys[low]:
            low = a
        if b < size and keys[b] < keys[low]:
            low = b
        if low == at:
            return size
        keys[low], keys[at] = keys[at], keys[low]
        items[low], items[at] = items[at], items[low]
        at = low


@njit(cache=True)
def solve_with_misses(ptr: IntArray, cols: IntArray, cost: FloatArray, n_cols: int, gate: float) -> IntArray:
    """The optimal column of every row of a sparse problem with misses (module docstring).

    Args:
        ptr, cols, cost: Row ``i``'s admissible columns ``cols[ptr[i]:ptr[i + 1]]`` (no repeats)
            and their finite costs.
        n_cols: ``l``, the number of real columns.
        gate: ``γ``, the cost of a miss.

    Returns:
        (k,) the column of each row, −1 for a miss.
    """
    k = ptr.shape[0] - 1
    n_all = n_cols + k  # real columns, then the miss column of each row
    u = np.zeros(k)
    v = np.zeros(n_all)
    shortest = np.full(n_all, np.inf)
    path = np.full(n_all, -1, dtype=np.int64)
    row4col = np.full(n_all, -1, dtype=np.int64)
    col4row = np.full(k, -1, dtype=np.int64)
    settled = np.zeros(n_all, dtype=np.bool_)
    touched = np.empty(n_all, dtype=np.int64)  # columns given a tentative distance this search
    rows_seen = np.empty(k, dtype=np.int64)
    heap_keys = np.empty(ptr[k] + 2 * k + 1)
    heap_items = np.empty(ptr[k] + 2 * k + 1, dtype=np.int64)
    for cur in range(k):
        n_touched = 0
        n_rows = 0
        size = 0
        min_val = 0.0
        i = cur
        sink = -1
        while sink < 0:
            rows_seen[n_rows] = i
            n_rows += 1
            for e in range(ptr[i], ptr[i + 1] + 1):  # the row's pairs, then its miss column
                if e < ptr[i + 1]:
                    j = cols[e]
                    c = cost[e]
                else:
                    j = n_cols + i
                    c = gate
                if settled[j]:
                    continue
                r = min_val + c - u[i] - v[j]
                if r < shortest[j]:
                    if shortest[j] == np.inf:
                        touched[n_touched] = j
                        n_touched += 1
                    shortest[j] = r
                    path[j] = i
                    size = _push(heap_keys, heap_items, size, r, j)
            j = -1
            while size > 0:  # the nearest column not settled yet (stale entries skipped)
                top_key = heap_keys[0]
                top = heap_items[0]
                size = _pop(heap_keys, heap_items, size)
                if not settled[top] and top_key == shortest[top]:
                    j = top
                    break
            min_val = shortest[j]
            settled[j] = True
            if row4col[j] < 0:
                sink = j
            else:
                i = row4col[j]
        # potentials of the settled rows and columns, as in the dense method
        u[cur] += min_val
        for a in range(1, n_rows):
            r = rows_seen[a]
            u[r] += min_val - shortest[col4row[r]]
        for t in range(n_touched):
            j = touched[t]
            if settled[j]:
                v[j] -= min_val - shortest[j]
        j = sink
        while True:  # flip the path
            i = path[j]
            row4col[j] = i
            col4row[i], j = j, col4row[i]
            if i == cur:
                break
        for t in range(n_touched):
            j = touched[t]
            shortest[j] = np.inf
            settled[j] = False
    out = np.full(k, -1, dtype=np.int64)
    for i in range(k):
        if col4row[i] < n_cols:
            out[i] = col4row[i]
    return out
