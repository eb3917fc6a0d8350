"""Measurement-to-track association: Mahalanobis cost, χ² gate, Hungarian and greedy assignment.

For predicted measurements ``N(ŷ_i, S_i)`` of tracks ``i`` and detections ``z_j`` the cost is the
squared Mahalanobis distance

.. math::

    d_{ij}^2 = (z_j - ŷ_i)^\\top S_i^{-1} (z_j - ŷ_i),

which is χ²-distributed with ``D`` degrees of freedom when track ``i`` produced ``z_j``. A pair is
admissible when ``d_{ij}^2 \\le γ = F^{-1}_{χ^2_D}(p_{gate})`` (``p_gate = 0.999`` as in paper
000). The global nearest neighbour assignment minimises the summed cost over admissible pairs,
where leaving a track unassigned costs ``γ``.

Hungarian assignment solves the rectangular problem ``[C | M]`` with per-track miss columns: ``M``
holds ``γ`` on its diagonal, and every inadmissible entry (gated pairs and the off-diagonal of
``M``) holds one finite stand-in ``B`` larger than any feasible total. Each row can always take
its miss column, so the problem stays feasible when a row or the whole frame is gated out —
``linear_sum_assignment`` never sees ``inf`` (the failure of Stone Soup issue 824).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

from track_envs.assignment import EMPTY_PAIRS, Pairs, min_cost_with_misses
from track_envs.types import Gaussian

_EMPTY: Pairs = EMPTY_PAIRS


def chi2_gate(p_gate: float, dim: int) -> float:
    """Gate ``γ = F^{-1}_{χ²_D}(p_gate)`` on squared Mahalanobis distances.

    Raises:
        ValueError: if ``p_gate`` is not in (0, 1) or ``dim < 1``.
    """
    if not 0.0 < p_gate < 1.0:
        raise ValueError(f"p_gate must be a probability in (0, 1), got {p_gate!r}")
    if dim < 1:
        raise ValueError(f"dim must be >= 1, got {dim!r}")
    return float(chi2.ppf(p_gate, dim))


def mahalanobis_cost(prediction: Gaussian, z: NDArray[np.floating]) -> NDArray[np.float64]:
    """Squared Mahalanobis distances (n, m) of detections ``z`` (m, D) to ``n`` predicted measurements."""
    mean = np.asarray(prediction.mean, dtype=np.float64)
    z = np.asarray(z, dtype=np.float64)
    if len(mean) == 0 or len(z) == 0:
        return np.zeros((len(mean), len(z)))
    # S = L Lᵀ, d² = |L⁻¹ (z − ŷ)|²: one small triangular inverse per track; then, for each of
    # the D² entries of L⁻¹, one multiply-add over all (n, m) pairs (D is 2 or 3)
    chol_inv = np.linalg.inv(np.linalg.cholesky(np.asarray(prediction.cov, dtype=np.float64)))
    dim = mean.shape[1]
    diff = [z[None, :, k] - mean[:, k, None] for k in range(dim)]  # D arrays (n, m)
    d2 = np.zeros((len(mean), len(z)))
    for i in range(dim):
        y = chol_inv[:, i, 0, None] * diff[0]
        for k in range(1, i + 1):  # L⁻¹ is lower triangular
            y += chol_inv[:, i, k, None] * diff[k]
        d2 += y * y
    return d2


def assign_hungarian(cost: NDArray[np.floating], gate: float) -> Pairs:
    """Optimal assignment of tracks (rows) to detections (columns) with a per-track miss cost ``gate``.

    See :func:`track_envs.assignment.min_cost_with_misses` (lone pairs first, then Hungarian on
    ``[C | M]`` with finite stand-ins for gated pairs).

    Returns:
        ``(rows, cols)`` of the assigned admissible pairs (``cost <= gate``), sorted by row.
    """
    return min_cost_with_misses(cost, gate)


def assign_greedy(cost: NDArray[np.floating], gate: float) -> Pairs:
    """Greedy assignment: repeatedly take the cheapest admissible pair whose row and column are free.

    Vectorised as rounds of mutual best matches: a pair that is the cheapest of both its row and
    its column among the free ones is exactly the pair greedy takes next in its neighbourhood, so
    the rounds give the greedy matching (ties broken by index).
    """
    cost = np.asarray(cost, dtype=np.float64)
    n, m = cost.shape
    if n == 0 or m == 0:
        return _EMPTY
    work = np.where(cost <= gate, cost, np.inf)
    rows_out, cols_out = [], []
    while True:
        best_col = np.argmin(work, axis=1)
        best_val = work[np.arange(n), best_col]
        best_row = np.argmin(work, axis=0)
        rows = np.flatnonzero(np.isfinite(best_val) & (best_row[best_col] == np.arange(n)))
        if len(rows) == 0:
            break
        cols = best_col[rows]
        rows_out.append(rows)
        cols_out.append(cols)
        work[rows, :] = np.inf
        work[:, cols] = np.inf
    if not rows_out:
        return _EMPTY
    rows = np.concatenate(rows_out).astype(np.int64)
    cols = np.concatenate(cols_out).astype(np.int64)
    order = np.argsort(rows)
    return rows[order], cols[order]


ASSIGNERS = {"hungarian": assign_hungarian, "greedy": assign_greedy}
