"""Compiled (numba) kernels of the association: Mahalanobis costs, gate, lone pairs, the rest, blobs.

For ``n`` predicted measurements ``N(ŷ_i, S_i)`` and ``m`` detections ``z_j`` (D dimensions),

.. math::

    S_i = L_i L_i^\\top, \\qquad d_{ij}^2 = \\lVert L_i^{-1} (z_j - ŷ_i) \\rVert^2
    = (z_j - ŷ_i)^\\top S_i^{-1} (z_j - ŷ_i):

one Cholesky factor and its triangular inverse per track, then for every pair ``D`` rows of
``L⁻¹`` times the difference. :func:`gated_costs` also splits the admissible pairs
(``d² <= γ``) into lone pairs and the rest in the same call
(:func:`track_envs.infra.assignment.lone_pairs.split_dense`), so the assignment only sees the rows and columns
that compete: :func:`track_envs.infra.assignment.lone_pairs.rest_problem` builds their ``[C | M]`` problem for
the solver and :func:`track_envs.infra.assignment.lone_pairs.merge_solution` joins its answer to
the lone pairs (both also importable from here, for compiled callers).

The planar case ``D = 2`` has its own closed-form row (its loop over detections vectorises);
other dimensions run a generic Cholesky and triangular inverse.

:func:`blob_measurements` is the compiled pass of :func:`agents.tracking.merges.share_blobs`:
the tracks that join a merged detection's blob and the rigid-group measurement of each.

Kernels and their results (inputs are float64 / int64 C-contiguous arrays):

* :func:`mahalanobis_costs` → ``(cost, bad)``: the (n, m) squared distances.
* :func:`gated_costs` → :class:`GatedCosts` ``(cost, lone_rows, lone_cols, rest_rows, rest_cols,
  bad)``: the costs and the split of the admissible pairs.
* :func:`blob_measurements` → ``(det_of_track, z_tracks)``: blob members added, the measurement
  of each track.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.assignment.lone_pairs import merge_solution, partner_pairs, rest_problem, split_dense
from track_envs.infra.compiled import njit
from track_envs.values.types import FloatArray

IntArray = NDArray[np.int64]

__all__ = [
    "GatedCosts",
    "blob_measurements",
    "cholesky_lower",
    "gated_costs",
    "mahalanobis_costs",
    "merge_solution",
    "rest_problem",
]


class GatedCosts(NamedTuple):
    """Result of :func:`gated_costs`: the costs of a frame and the split of its admissible pairs.

    Attributes:
        cost: (n, m) squared Mahalanobis distances ``d²_ij``.
        lone_rows: Tracks of the lone pairs (admissible and alone in their row and column), ascending.
        lone_cols: The detection of each lone row.
        rest_rows: Tracks with admissible pairs that are not lone, ascending.
        rest_cols: Detections with admissible pairs that are not lone, ascending.
        bad: −1, or the first track whose covariance is not positive definite (the other fields
            are then not meaningful).
    """

    cost: FloatArray
    lone_rows: IntArray
    lone_cols: IntArray
    rest_rows: IntArray
    rest_cols: IntArray
    bad: int


@njit(cache=True)
def cholesky_lower(a: FloatArray, out: FloatArray) -> bool:
    """Lower Cholesky factor ``L`` (``a = L Lᵀ``) of the small symmetric matrix ``a`` (D, D) into
    ``out``, row by row; False (``out`` then partial) when ``a`` is not positive definite."""
    d = a.shape[0]
    for r in range(d):
        for c in range(r + 1):
            s = a[r, c]
            for k in range(c):
                s -= out[r, k] * out[c, k]
            if r == c:
                if not s > 0.0:
                    return False
                out[r, r] = np.sqrt(s)
            else:
                out[r, c] = s / out[c, c]
        for c in range(r + 1, d):
            out[r, c] = 0.0
    return True


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
def gated_costs(mean: FloatArray, cov: FloatArray, z: FloatArray, gate: float) -> GatedCosts:
    """:func:`mahalanobis_costs` and the lone-pair split of the admissible pairs (cost <= gate).

    A *lone pair* is an admissible pair alone in both its row and its column; it belongs to an
    optimal assignment. The rest are the rows and columns with admissible pairs that are not in a
    lone pair (:func:`track_envs.infra.assignment.lone_pairs.split_dense`).

    Returns:
        :class:`GatedCosts` ``(cost (n, m), lone_rows, lone_cols, rest_rows, rest_cols, bad)``,
        indices ascending (``lone_rows`` ascending, ``lone_cols`` their partners); ``bad`` as in
        :func:`mahalanobis_costs`.
    """
    cost, bad = mahalanobis_costs(mean, cov, z)
    if bad >= 0:
        empty = np.zeros(0, dtype=np.int64)
        return GatedCosts(cost, empty, empty, empty, empty, bad)
    partner, rest_rows, rest_cols = split_dense(cost, gate)
    lone_rows, lone_cols = partner_pairs(partner)
    return GatedCosts(cost, lone_rows, lone_cols, rest_rows, rest_cols, -1)


@njit(cache=True)
def blob_measurements(
    predicted: FloatArray,
    z: FloatArray,
    det_of_track: IntArray,
    extent: float,
    low: FloatArray,
    high: FloatArray,
) -> tuple[IntArray, FloatArray]:
    """The blob members of every track and the measurement each is updated with (the compiled pass
    of :func:`agents.tracking.merges.share_blobs`, whose docstring has the equations).

    A track ``j`` without a detection and predicted inside ``[low, high]`` joins the detection
    ``d`` taken by another track ``i`` for which ``‖ŷ_j − z_d‖ ≤ extent`` (the nearest such ``d``)
    and ``‖ŷ_i − z_d‖ ≤ extent``. A blob of ``|G| ≥ 2`` tracks gives member ``j`` the measurement
    ``z_d + ŷ_j − mean_{k∈G} ŷ_k``; a lone track gets ``z_d``.

    Args:
        predicted: (n, D) predicted measurements ``ŷ``.
        z: (m, D) detections.
        det_of_track: (n,) detection of each track after association, −1 for none.
        extent: Largest distance of a member's prediction from the blob's centroid.
        low, high: (D,) corners of the observed region.

    Returns:
        ``(det_of_track (n,), z_tracks (n, D))``: a new detection array with the blob members
        added, and the measurement of each track (zero rows for tracks without a detection).
    """
    n, dim = predicted.shape
    m = z.shape[0]
    out = det_of_track.copy()
    owner = np.full(m, -1, np.int64)
    for i in range(n):
        if det_of_track[i] >= 0:
            owner[det_of_track[i]] = i
    e2 = extent * extent
    for j in range(n):
        if det_of_track[j] >= 0:
            continue
        inside = True
        for k in range(dim):
            inside = inside and low[k] <= predicted[j, k] <= high[k]
        if not inside:  # a particle that left the view is no blob member
            continue
        best, best_d = -1, e2
        for d in range(m):
            i = owner[d]
            if i < 0:
                continue
            dj = 0.0
            di = 0.0
            for k in range(dim):
                dj += (predicted[j, k] - z[d, k]) ** 2
                di += (predicted[i, k] - z[d, k]) ** 2
            if dj <= best_d and di <= e2:
                best, best_d = d, dj
        out[j] = best
    # rigid-group measurements for every blob with two or more tracks
    z_tracks = np.zeros((n, dim))
    count = np.zeros(m, np.int64)
    centre = np.zeros((m, dim))
    for i in range(n):
        d = out[i]
        if d >= 0:
            count[d] += 1
            for k in range(dim):
                centre[d, k] += predicted[i, k]
    for i in range(n):
        d = out[i]
        if d < 0:
            continue
        for k in range(dim):
            if count[d] > 1:
                z_tracks[i, k] = z[d, k] + predicted[i, k] - centre[d, k] / count[d]
            else:
                z_tracks[i, k] = z[d, k]
    return out, z_tracks
