"""Measurement-to-track association: Mahalanobis cost, χ² gate, Hungarian and greedy assignment.

For predicted measurements ``N(ŷ_i, S_i)`` of tracks ``i`` and detections ``z_j`` the cost is the
squared Mahalanobis distance

.. math::

    d_{ij}^2 = (z_j - ŷ_i)^\\top S_i^{-1} (z_j - ŷ_i),

which is χ²-distributed with ``D`` degrees of freedom when track ``i`` produced ``z_j``. A pair is
admissible when ``d_{ij}^2 \\le γ = F^{-1}_{χ^2_D}(p_{gate})`` (``p_gate = 0.999`` as in paper
000). The global nearest neighbour assignment minimises the summed cost over admissible pairs,
where leaving a track unassigned costs ``γ``.

Hungarian assignment is :mod:`track_envs.infra.assignment.lone_pairs`: lone pairs (alone in their row
and column)
directly, the rest as the rectangular problem ``[C | M]`` with per-track miss columns (``γ`` on
the diagonal of ``M``, one finite stand-in for every inadmissible entry), so it stays feasible
when a row or the whole frame is gated out and ``linear_sum_assignment`` never sees ``inf`` (the
failure of Stone Soup issue 824).

The trackers call the one-pass :data:`ASSOCIATORS` (prediction, detections, gate → pairs): the
costs, the gate and the split into lone pairs and competing rows and columns come from one
compiled loop (:mod:`agents.tracking._kernels`); :data:`ASSIGNERS` take a cost matrix.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

from agents.tracking import _kernels
from track_envs.infra.assignment.lone_pairs import EMPTY_PAIRS, Pairs, min_cost_with_misses, solve_split
from track_envs.values.types import FloatArray, Gaussian

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


def _f64(a: NDArray[np.floating]) -> NDArray[np.float64]:
    return np.ascontiguousarray(a, dtype=np.float64)


def _prepared(prediction: Gaussian, z: NDArray[np.floating]) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Means, covariances and detections for the kernels (float64, C order), shapes checked."""
    mean, cov, zz = _f64(prediction.mean), _f64(prediction.cov), _f64(z)
    D = mean.shape[1]
    if zz.ndim != 2 or zz.shape[1] != D:
        raise ValueError(f"z must have shape (m, D={D}) like the predictions, got {zz.shape}")
    return mean, cov, zz


def _checked(bad: int) -> None:
    if bad >= 0:
        raise np.linalg.LinAlgError(f"predicted covariance S of track {bad} is not positive definite")


def mahalanobis_cost(prediction: Gaussian, z: NDArray[np.floating]) -> NDArray[np.float64]:
    """Squared Mahalanobis distances (n, m) of detections ``z`` (m, D) to ``n`` predicted measurements.

    ``S_i = L_i L_iᵀ`` (Cholesky), ``d²_ij = |L_i⁻¹ (z_j − ŷ_i)|²``: one compiled loop over the
    pairs (:func:`agents.tracking._kernels.mahalanobis_costs`).

    Raises:
        ValueError: if ``z`` is not (m, D).
        numpy.linalg.LinAlgError: if some ``S_i`` is not positive definite.
    """
    cost, bad = _kernels.mahalanobis_costs(*_prepared(prediction, z))
    _checked(bad)
    return cost


def assign_hungarian(cost: NDArray[np.floating], gate: float) -> Pairs:
    """Optimal assignment of tracks (rows) to detections (columns) with a per-track miss cost ``gate``.

    See :func:`track_envs.infra.assignment.lone_pairs.min_cost_with_misses` (lone pairs first, then
    Hungarian on
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


def associate_hungarian(prediction: Gaussian, z: NDArray[np.floating], gate: float) -> Pairs:
    """Gate and assign in one pass; the same pairs as
    ``assign_hungarian(mahalanobis_cost(prediction, z), gate)``.

    The costs and the lone-pair split of the admissible pairs come from one compiled kernel
    (:func:`agents.tracking._kernels.gated_costs`); only the rows and columns that compete go
    to ``scipy.optimize.linear_sum_assignment``, as the problem ``[C | M]``
    (:func:`track_envs.infra.assignment.lone_pairs.solve_split`, the path of
    :func:`track_envs.infra.assignment.lone_pairs.min_cost_with_misses`).

    Returns:
        ``(rows, cols)`` of the assigned admissible pairs, sorted by row.

    Raises:
        ValueError: if ``z`` is not (m, D).
        numpy.linalg.LinAlgError: if some predicted covariance is not positive definite.
    """
    split = _kernels.gated_costs(*_prepared(prediction, z), float(gate))
    _checked(split.bad)
    return solve_split(
        split.cost, float(gate), split.lone_rows, split.lone_cols, split.rest_rows, split.rest_cols
    )


def associate_greedy(prediction: Gaussian, z: NDArray[np.floating], gate: float) -> Pairs:
    """``assign_greedy(mahalanobis_cost(prediction, z), gate)``."""
    return assign_greedy(mahalanobis_cost(prediction, z), gate)


#: Gate-and-assign functions ``(prediction, z, gate) -> (rows, cols)`` by assignment name.
ASSOCIATORS = {"hungarian": associate_hungarian, "greedy": associate_greedy}
