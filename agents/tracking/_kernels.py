"""Compiled (numba) kernels of the association: Mahalanobis costs, gate, lone pairs, the rest.

For ``n`` predicted measurements ``N(ŷ_i, S_i)`` and ``m`` detections ``z_j`` (D dimensions),

.. math::

    S_i = L_i L_i^\\top, \\qquad d_{ij}^2 = \\lVert L_i^{-1} (z_j - ŷ_i) \\rVert^2
    = (z_j - ŷ_i)^\\top S_i^{-1} (z_j - ŷ_i):

one Cholesky factor and its triangular inverse per track, then for every pair ``D`` rows of
``L⁻¹`` times the difference. :func:`gated_costs` also splits the admissible pairs
(``d² <= γ``) into lone pairs and the rest in the same call
(:func:`track_envs.assignment.split_dense`), so the assignment only sees the rows and columns
that compete: :func:`track_envs.assignment.rest_problem` builds their ``[C | M]`` problem for
the solver and :func:`track_envs.assignment.merge_solution` joins its answer to the lone pairs
(both also importable from here, for compiled callers).

The planar case ``D = 2`` has its own closed-form row (its loop over detections vectorises);
other dimensions run a generic Cholesky and triangular inverse. Inputs are float64 C-contiguous
arrays.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.assignment import merge_solution, partner_pairs, rest_problem, split_dense
from track_envs.compiled import njit
from track_envs.types import FloatArray

IntArray = NDArray[np.int64]

__all__ = ["gated_costs", "mahalanobis_costs", "merge_solution", "rest_problem"]


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

    A *lone pair* is an admissible pair alone in both its row and its column; it belongs to an
    optimal assignment. The rest are the rows and columns with admissible pairs that are not in a
    lone pair (:func:`track_envs.assignment.split_dense`).

    Returns:
        ``(cost (n, m), lone_rows, lone_cols, rest_rows, rest_cols, bad)``, indices ascending
        (``lone_rows`` ascending, ``lone_cols`` their partners); ``bad`` as in
        :func:`mahalanobis_costs`.
    """
    cost, bad = mahalanobis_costs(mean, cov, z)
    if bad >= 0:
        empty = np.zeros(0, dtype=np.int64)
        return cost, empty, empty, empty, empty, bad
    partner, rest_rows, rest_cols = split_dense(cost, gate)
    lone_rows, lone_cols = partner_pairs(partner)
    return cost, lone_rows, lone_cols, rest_rows, rest_cols, -1
