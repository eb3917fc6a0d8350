"""Measurement-to-track association: Mahalanobis cost, χ² gate, Hungarian and greedy assignment.

For predicted measurements ``N(ŷ_i, S_i)`` of tracks ``i`` and detections ``z_j`` the cost is the
squared Mahalanobis distance

.. math::

    d_{ij}^2 = (z_j - ŷ_i)^\\top S_i^{-1} (z_j - ŷ_i),

which is χ²-distributed with ``D`` degrees of freedom when track ``i`` produced ``z_j``. A pair is
admissible when ``d_{ij}^2 \\le γ = F^{-1}_{χ^2_D}(p_{gate})`` (``p_gate = 0.999`` as in paper
000). The global nearest neighbour assignment minimises the summed cost over admissible pairs,
where leaving a track unassigned costs ``γ``.

The trackers call the one-pass [`ASSOCIATORS`][agents.tracking.assign.ASSOCIATORS] (prediction, detections,
gate → pairs), which never build an (n, m) array: the spatial index lists the detections inside a box around
each track's gate and the exact test keeps the admissible pairs
([`gated_pairs`][agents.tracking.assign.gated_pairs], [`agents.tracking._kernels`][agents.tracking._kernels]),
as compressed sparse rows. The optimal assignment then takes the lone pairs (alone in their row and column)
directly and solves every other connected component of the pairs exactly as its own ``[C | M]`` problem, with
per-track miss columns (``γ`` on the diagonal of ``M``, one finite stand-in for every inadmissible entry, so
it stays feasible when a row is gated out and the solver never sees ``inf``, the failure of Stone Soup issue
824):
[`track_envs.infra.assignment.components`][track_envs.infra.assignment.components]. Greedy takes the
admissible pairs by ascending cost
([`track_envs.infra.assignment.greedy`][track_envs.infra.assignment.greedy]). A frame costs ``O(n + m)`` for
gates and components of bounded size. [`SPARSE_ASSIGNERS`][agents.tracking.assign.SPARSE_ASSIGNERS] assign
such a list (the second chance).

[`ASSIGNERS`][agents.tracking.assign.ASSIGNERS] take a dense cost matrix (the pose tracker's, and the
reference of the tests):
[`assign_hungarian`][agents.tracking.assign.assign_hungarian] is
[`track_envs.infra.assignment.lone_pairs.min_cost_with_misses`][track_envs.infra.assignment.lone_pairs.min_cost_with_misses]
(lone pairs, then the rest as one ``[C | M]`` problem),
[`assign_greedy`][agents.tracking.assign.assign_greedy] the rounds of mutual best matches.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

from agents.tracking import _kernels
from track_envs.infra.assignment.components import solve_sparse
from track_envs.infra.assignment.greedy import greedy_sparse
from track_envs.infra.assignment.lone_pairs import EMPTY_PAIRS, Pairs, min_cost_with_misses
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
    pairs (`agents.tracking._kernels.mahalanobis_costs`).

    Raises:
        ValueError: if ``z`` is not (m, D).
        numpy.linalg.LinAlgError: if some ``S_i`` is not positive definite.
    """
    cost, bad = _kernels.mahalanobis_costs(*_prepared(prediction, z))
    _checked(bad)
    return cost


def assign_hungarian(cost: NDArray[np.floating], gate: float) -> Pairs:
    """Optimal assignment of tracks (rows) to detections (columns) with a per-track miss cost ``gate``.

    See
    [`track_envs.infra.assignment.lone_pairs.min_cost_with_misses`][track_envs.infra.assignment.lone_pairs.min_cost_with_misses]
    (lone pairs first, then Hungarian on ``[C | M]`` with finite stand-ins for gated pairs).

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


def gated_pairs(prediction: Gaussian, z: NDArray[np.floating], gate: float) -> _kernels.GatedPairs:
    """The admissible pairs ``d²_ij <= gate`` of a frame and their costs, as compressed sparse rows
    ([`agents.tracking._kernels.gated_pairs`][agents.tracking._kernels.gated_pairs]: spatial index, then the
    exact test).

    Raises:
        ValueError: if ``z`` is not (m, D), or a track's gate half-width ``sqrt(γ S_kk)`` is not
            finite (naming the track and the value).
        numpy.linalg.LinAlgError: if some predicted covariance is not positive definite.
    """
    mean, cov, zz = _prepared(prediction, z)
    pairs = _kernels.gated_pairs(mean, cov, zz, float(gate))
    _checked(pairs.bad)
    if pairs.wide >= 0:
        with np.errstate(over="ignore", invalid="ignore"):
            half = np.sqrt(float(gate) * np.diagonal(cov[pairs.wide])[: min(cov.shape[1], 2)])
        raise ValueError(
            f"track {pairs.wide}: gate half-width sqrt(gate * S_kk) = {half.tolist()} is not finite "
            f"(gate {float(gate)!r}, predicted covariance diagonal {np.diagonal(cov[pairs.wide]).tolist()}); "
            "a gate must be bounded"
        )
    return pairs


def associate_hungarian(prediction: Gaussian, z: NDArray[np.floating], gate: float) -> Pairs:
    """Gate and assign in one pass; the optimum of
    ``assign_hungarian(mahalanobis_cost(prediction, z), gate)`` (the same pairs where the optimum
    is unique).

    The admissible pairs come from the spatial index and the exact test
    ([`gated_pairs`][agents.tracking.assign.gated_pairs]), never an (n, m) array; lone pairs are taken
    directly and every other connected component of the pairs is solved exactly as its own ``[C | M]`` problem
    ([`track_envs.infra.assignment.components.solve_sparse`][track_envs.infra.assignment.components.solve_sparse]).

    Returns:
        ``(rows, cols)`` of the assigned admissible pairs, sorted by row.

    Raises:
        ValueError: if ``z`` is not (m, D), or a gate half-width is not finite.
        numpy.linalg.LinAlgError: if some predicted covariance is not positive definite.
    """
    pairs = gated_pairs(prediction, z, gate)
    return solve_sparse(pairs.ptr, pairs.cols, pairs.cost, len(z), float(gate))


def associate_greedy(prediction: Gaussian, z: NDArray[np.floating], gate: float) -> Pairs:
    """``assign_greedy(mahalanobis_cost(prediction, z), gate)``, on the list of admissible pairs
    ([`gated_pairs`][agents.tracking.assign.gated_pairs],
    [`track_envs.infra.assignment.greedy.greedy_sparse`][track_envs.infra.assignment.greedy.greedy_sparse])."""
    pairs = gated_pairs(prediction, z, gate)
    return greedy_sparse(pairs.ptr, pairs.cols, pairs.cost, len(z), float(gate))


#: Gate-and-assign functions ``(prediction, z, gate) -> (rows, cols)`` by assignment name.
ASSOCIATORS = {"hungarian": associate_hungarian, "greedy": associate_greedy}

#: Assignments of a sparse list of pairs ``(ptr, cols, cost, n_cols, gate) -> (rows, cols)``
#: (compressed sparse rows; pairs above the gate are not admissible) by assignment name.
SPARSE_ASSIGNERS = {"hungarian": solve_sparse, "greedy": greedy_sparse}
