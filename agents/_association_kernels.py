"""Compiled (numba) kernels of the association: Mahalanobis costs, gate, lone pairs, the rest.

For ``n`` predicted measurements ``N(ŷ_i, S_i)`` and ``m`` detections ``z_j`` (D dimensions),

.. math::

    S_i = L_i L_i^\\top, \\qquad d_{ij}^2 = \\lVert L_i^{-1} (z_j - ŷ_i) \\rVert^2
    = (z_j - ŷ_i)^\\top S_i^{-1} (z_j - ŷ_i):

one Cholesky factor and its triangular inverse per track, then for every pair ``D`` rows of
``L⁻¹`` times the difference. :func:`gated_costs` also splits the admissible pairs
(``d² <= γ``) as :func:`track_envs.assignment.lone_pairs` does, in the same call, so the
assignment only sees the rows and columns that compete: :func:`rest_problem` builds their
``[C | M]`` problem for the solver and :func:`merge_solution` joins its answer to the lone pairs.

The planar case ``D = 2`` has its own closed-form row (its loop over detections vectorises);
other dimensions run a generic Cholesky and triangular inverse. Inputs are float64 C-contiguous
arrays.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from track_envs.assignment import split_lone_pairs
from track_envs.types import FloatArray

IntArray = NDArray[np.int64]


@njit(cache=True)
def _planar_costs(mean: FloatArray, cov: FloatArray, z: FloatArray, cost: FloatArray) -> int:
    """Fill ``cost`` for ``D = 2`` in closed form: ``L = [[l00, 0], [l10, l11]]``,
    ``L⁻¹ = [[1/l00, 0], [−l10/(l00 l11), 1/l11]]``.

    Returns:
        -1, or the first track whose covariance is not positive definite.
    """
    z0 = np.ascontiguousarray(z[:, 0])
    z1 = np.ascontiguousarray(z[:, 1])
    for i in range(mean.shape[0]):
        a = cov[i, 0, 0]
        if not a > 0.0:
            return i
        l00 = np.sqrt(a)
        l10 = cov[i, 1, 0] / l00
        s = cov[i, 1, 1] - l10 * l10
        if not s > 0.0:
            return i
        l11 = np.sqrt(s)
        i00 = 1.0 / l00
        i11 = 1.0 / l11
        i10 = -(l10 * i00) / l11
        mu0 = mean[i, 0]
        mu1 = mean[i, 1]
        row = cost[i]
        for j in range(z0.shape[0]):
            d0 = z0[j] - mu0
            d1 = z1[j] - mu1
            y0 = i00 * d0
            y1 = i10 * d0 + i11 * d1
            row[j] = y0 * y0 + y1 * y1
    return -1


@njit(cache=True)
def _general_costs(mean: FloatArray, cov: FloatArray, z: FloatArray, cost: FloatArray) -> int:
    """Fill ``cost`` in any dimension: Cholesky factor, its triangular inverse, ``|L⁻¹ (z − ŷ)|²``.

    Returns:
        -1, or the first track whose covariance is not positive definite.
    """
    n, D = mean.shape
    m = z.shape[0]
    zt = np.ascontiguousarray(z.T)  # detections by coordinate: contiguous inner loops
    L = np.zeros((D, D))
    inv = np.zeros((D, D))
    y = np.empty(m)
    for i in range(n):
        # S = L Lᵀ
        for c in range(D):
            s = cov[i, c, c]
            for k in range(c):
                s -= L[c, k] * L[c, k]
            if not s > 0.0:
                return i
            lcc = np.sqrt(s)
            L[c, c] = lcc
            for r in range(c + 1, D):
                s = cov[i, r, c]
                for k in range(c):
                    s -= L[r, k] * L[c, k]
                L[r, c] = s / lcc
        # L⁻¹ (lower triangular), column by column
        for c in range(D):
            inv[c, c] = 1.0 / L[c, c]
            for r in range(c + 1, D):
                s = 0.0
                for k in range(c, r):
                    s -= L[r, k] * inv[k, c]
                inv[r, c] = s / L[r, r]
        row = cost[i]
        row[:] = 0.0
        for r in range(D):
            a = inv[r, 0]
            mu = mean[i, 0]
            for j in range(m):
                y[j] = a * (zt[0, j] - mu)
            for k in range(1, r + 1):
                a = inv[r, k]
                mu = mean[i, k]
                for j in range(m):
                    y[j] += a * (zt[k, j] - mu)
            for j in range(m):
                row[j] += y[j] * y[j]
    return -1


@njit(cache=True)
def mahalanobis_costs(mean: FloatArray, cov: FloatArray, z: FloatArray) -> tuple[FloatArray, int]:
    """Squared Mahalanobis distances of detections ``z`` (m, D) to ``N(mean_i, cov_i)``, i < n.

    Args:
        mean: (n, D). cov: (n, D, D), symmetric positive definite. z: (m, D).

    Returns:
        ``(cost (n, m), bad)``: ``bad`` is -1, or the first track whose covariance is not
        positive definite (the costs are then not meaningful).
    """
    n, D = mean.shape
    cost = np.empty((n, z.shape[0]))
    if n == 0 or z.shape[0] == 0:
        return cost, -1
    bad = _planar_costs(mean, cov, z, cost) if D == 2 else _general_costs(mean, cov, z, cost)
    return cost, bad


@njit(cache=True)
def gated_costs(
    mean: FloatArray, cov: FloatArray, z: FloatArray, gate: float
) -> tuple[FloatArray, IntArray, IntArray, IntArray, IntArray, int]:
    """:func:`mahalanobis_costs` and the lone-pair split of the admissible pairs (cost <= gate).

    A *lone pair* is an admissible pair alone in both its row and its column; it belongs to
    every optimal assignment. The rest are the rows and columns with admissible pairs that are
    not in a lone pair (see :func:`track_envs.assignment.lone_pairs`, which this equals).

    Returns:
        ``(cost (n, m), lone_rows, lone_cols, rest_rows, rest_cols, bad)``, indices ascending
        (``lone_rows`` ascending, ``lone_cols`` their partners); ``bad`` as in
        :func:`mahalanobis_costs`.
    """
    n = mean.shape[0]
    m = z.shape[0]
    cost, bad = mahalanobis_costs(mean, cov, z)
    empty = np.zeros(0, dtype=np.int64)
    if bad >= 0:
        return cost, empty, empty, empty, empty, bad
    # admissible pairs per row and column, and the last admissible column of each row (the only
    # one where the row has one)
    row_count = np.zeros(n, dtype=np.int64)
    only_col = np.zeros(n, dtype=np.int64)
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
    partner, rest_rows, rest_cols = split_lone_pairs(row_count, only_col, col_count)
    lone_rows = np.flatnonzero(partner >= 0)
    lone_cols = partner[lone_rows]
    return cost, lone_rows, lone_cols, rest_rows, rest_cols, -1


@njit(cache=True)
def rest_problem(cost: FloatArray, gate: float, rest_rows: IntArray, rest_cols: IntArray) -> FloatArray:
    """The rectangular problem ``[C | M]`` of the competing rows and columns, for the solver.

    ``C`` is the ``rest_rows`` × ``rest_cols`` block of ``cost``; ``M`` (k, k) holds the miss cost
    ``γ`` on its diagonal. Every inadmissible entry (a pair above the gate, the off-diagonal of
    ``M``) holds one finite stand-in ``B = 2 (|γ| + 1)(k + 1) + max |C_admissible|``, larger than
    any feasible total: the matrix of :func:`track_envs.assignment.min_cost_with_misses`.

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
    cost: FloatArray,
    gate: float,
    lone_rows: IntArray,
    lone_cols: IntArray,
    rest_rows: IntArray,
    rest_cols: IntArray,
    rows: IntArray,
    cols: IntArray,
) -> tuple[IntArray, IntArray]:
    """The lone pairs and the solver's admissible pairs of :func:`rest_problem`, rows ascending.

    Args:
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
