"""Compiled (numba) kernels of the association: Mahalanobis costs of the gated pairs, blobs.

For ``n`` predicted measurements ``N(ŷ_i, S_i)`` and ``m`` detections ``z_j`` (D dimensions),

.. math::

    S_i = L_i L_i^\\top, \\qquad d_{ij}^2 = \\lVert L_i^{-1} (z_j - ŷ_i) \\rVert^2
    = (z_j - ŷ_i)^\\top S_i^{-1} (z_j - ŷ_i):

one Cholesky factor and its triangular inverse per track, then for every pair ``D`` rows of
``L⁻¹`` times the difference. The planar case ``D = 2`` has its own closed-form factor; other
dimensions run a generic Cholesky and triangular inverse.

**Gating without an n × m array** ([`gated_pairs`][agents.tracking._kernels.gated_pairs]). A pair is
admissible when ``d²_ij <= γ``. Writing ``y = L_i⁻¹ (z_j − ŷ_i)``, the difference is ``z_j − ŷ_i = L_i y`` and
by Cauchy–Schwarz on row ``k`` of ``L_i``

.. math::

    |z_{jk} - ŷ_{ik}| = |(L_i)_{k·} \\, y| \\le \\lVert (L_i)_{k·} \\rVert \\, \\lVert y \\rVert
    \\le \\sqrt{S_{i,kk}} \\sqrt{γ} = h_{ik},

so every admissible detection lies in the axis-aligned box of half-widths ``h_ik`` around
``ŷ_i``. The spatial index
([`track_envs.infra.spatial.box_candidates`][track_envs.infra.spatial.box_candidates], a uniform grid) lists
the detections in each box in ``O(n + m)`` for boxes of bounded size, and only those candidates get the exact
test, with the same floating-point expressions as the dense
[`mahalanobis_costs`][agents.tracking._kernels.mahalanobis_costs] (so the costs are bit-identical). The box is
widened by a relative ``1e-9`` and an absolute ``1e-300``: the computed ``d²`` differs from the exact one by a
few units in the last place of the terms, so a pair the dense code admits is never outside the widened box.
The result is the admissible pairs as compressed sparse rows; the assignment runs on that list
([`track_envs.infra.assignment.components`][track_envs.infra.assignment.components],
[`track_envs.infra.assignment.greedy`][track_envs.infra.assignment.greedy]).

[`blob_measurements`][agents.tracking._kernels.blob_measurements] is the compiled pass of
[`agents.tracking.merges.share_blobs`][agents.tracking.merges.share_blobs]:
the tracks that join a merged detection's blob and the rigid-group measurement of each; the
taken detections near a leftover track come from the same index (a Euclidean ball of radius
``extent`` lies in the box of half-width ``extent``).

Kernels and their results (inputs are float64 / int64 C-contiguous arrays):

* [`mahalanobis_costs`][agents.tracking._kernels.mahalanobis_costs] → ``(cost, bad)``: the dense (n, m)
squared distances (the public
  [`agents.tracking.assign.mahalanobis_cost`][agents.tracking.mahalanobis_cost], and the reference of the
  tests).
* [`gated_pairs`][agents.tracking._kernels.gated_pairs] → [`GatedPairs`][agents.tracking._kernels.GatedPairs]
``(ptr, cols, cost, bad, wide)``: the admissible
  pairs and their costs.
* [`blob_measurements`][agents.tracking._kernels.blob_measurements] → ``(det_of_track, z_tracks)``: blob
members added, the measurement
  of each track.

[`rest_problem`][track_envs.infra.assignment.lone_pairs.rest_problem] and
[`merge_solution`][track_envs.infra.assignment.lone_pairs.merge_solution] are importable from here, for
compiled callers.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.assignment.lone_pairs import merge_solution, rest_problem
from track_envs.infra.compiled import njit
from track_envs.infra.spatial import box_candidates
from track_envs.values.types import FloatArray

IntArray = NDArray[np.int64]

__all__ = [
    "GatedPairs",
    "blob_measurements",
    "cholesky_lower",
    "gate_half_widths",
    "gated_pairs",
    "mahalanobis_costs",
    "merge_solution",
    "rest_problem",
]


class GatedPairs(NamedTuple):
    """Result of [`gated_pairs`][agents.tracking._kernels.gated_pairs]: the admissible pairs of a frame as
    compressed sparse rows.

    Attributes:
        ptr: (n + 1,) track ``i``'s pairs are ``ptr[i]:ptr[i + 1]``.
        cols: The detection of each pair, ascending within a track.
        cost: The squared Mahalanobis distance ``d²_ij <= γ`` of each pair.
        bad: −1, or the first track whose covariance is not positive definite (the other fields
            are then not meaningful).
        wide: −1, or the first track whose gate half-width ``sqrt(γ S_kk)`` is not finite (the
            other fields are then not meaningful).
    """

    ptr: IntArray
    cols: IntArray
    cost: FloatArray
    bad: int
    wide: int


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
    factors, bad = _general_factors(cov)  # every L⁻¹ (S = L Lᵀ)
    if bad >= 0:
        return bad
    zt = np.ascontiguousarray(z.T)  # detections by coordinate: contiguous inner loops
    y = np.empty(m)
    for i in range(n):
        inv = factors[i]
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


#: Relative and absolute slack of a gate's box: rounding never drops a pair that the exact test keeps.
BOX_SLACK = 1e-9
BOX_TINY = 1e-300


@njit(cache=True)
def _planar_factors(cov: FloatArray) -> tuple[FloatArray, int]:
    """``(i00, i10, i11)`` of every ``L⁻¹`` for ``D = 2``
    ([`_planar_costs`][agents.tracking._kernels._planar_costs]'s expressions); and −1, or the first track
    whose covariance is not positive definite."""
    n = cov.shape[0]
    inv = np.empty((n, 3))
    for i in range(n):
        a = cov[i, 0, 0]
        if not a > 0.0:
            return inv, i
        l00 = np.sqrt(a)
        l10 = cov[i, 1, 0] / l00
        s = cov[i, 1, 1] - l10 * l10
        if not s > 0.0:
            return inv, i
        l11 = np.sqrt(s)
        i00 = 1.0 / l00
        i11 = 1.0 / l11
        i10 = -(l10 * i00) / l11
        inv[i, 0] = i00
        inv[i, 1] = i10
        inv[i, 2] = i11
    return inv, -1


@njit(cache=True)
def _general_factors(cov: FloatArray) -> tuple[FloatArray, int]:
    """Every ``L⁻¹`` (n, D, D), lower triangular: the Cholesky factor ``S_i = L Lᵀ`` row by row,
    then its inverse column by column; and −1, or the first track whose covariance is not
    positive definite."""
    n, D = cov.shape[0], cov.shape[1]
    L = np.zeros((D, D))
    inv = np.zeros((n, D, D))
    for i in range(n):
        for c in range(D):
            s = cov[i, c, c]
            for k in range(c):
                s -= L[c, k] * L[c, k]
            if not s > 0.0:
                return inv, i
            lcc = np.sqrt(s)
            L[c, c] = lcc
            for r in range(c + 1, D):
                s = cov[i, r, c]
                for k in range(c):
                    s -= L[r, k] * L[c, k]
                L[r, c] = s / lcc
        for c in range(D):
            inv[i, c, c] = 1.0 / L[c, c]
            for r in range(c + 1, D):
                s = 0.0
                for k in range(c, r):
                    s -= L[r, k] * inv[i, k, c]
                inv[i, r, c] = s / L[r, r]
    return inv, -1


@njit(cache=True)
def gate_half_widths(cov: FloatArray, gate: float) -> FloatArray:
    """(n, K) half-widths ``h_k = sqrt(γ S_kk) (1 + 1e-9) + 1e-300`` of the boxes around the
    χ² gates on the first ``K = min(D, 2)`` axes (module docstring)."""
    n, D = cov.shape[0], cov.shape[1]
    K = min(D, 2)
    half = np.empty((n, K))
    for i in range(n):
        for k in range(K):
            half[i, k] = np.sqrt(gate * cov[i, k, k]) * (1.0 + BOX_SLACK) + BOX_TINY
    return half


@njit(cache=True)
def gated_pairs(mean: FloatArray, cov: FloatArray, z: FloatArray, gate: float) -> GatedPairs:
    """The admissible pairs ``d²_ij <= γ`` (``γ = gate``) and their costs, without an (n, m) array.

    Every covariance is factored first (the first one that is not positive definite is
    ``bad``); the spatial index then gives the detections inside each track's box
    ``|z_k − ŷ_k| <= h_k`` ([`gate_half_widths`][agents.tracking._kernels.gate_half_widths]; a half-width that
    is not finite is ``wide``), and the exact test runs on those with the floating-point expressions of
    [`mahalanobis_costs`][agents.tracking._kernels.mahalanobis_costs], so every cost is bit-identical to the
    dense one. A detection with a non-finite coordinate is no candidate (its dense cost is NaN or inf, never
    admissible); a track with a non-finite mean has none.

    Returns:
        [`GatedPairs`][agents.tracking._kernels.GatedPairs] ``(ptr, cols, cost, bad, wide)``; with no track or
            no detection, no pairs and no check (as
            [`mahalanobis_costs`][agents.tracking._kernels.mahalanobis_costs]).
    """
    n, D = mean.shape
    m = z.shape[0]
    empty_i = np.zeros(0, dtype=np.int64)
    empty_f = np.zeros(0)
    if n == 0 or m == 0:
        return GatedPairs(np.zeros(n + 1, dtype=np.int64), empty_i, empty_f, -1, -1)
    if D == 2:
        planar, bad = _planar_factors(cov)
        general = np.zeros((0, D, D))
    else:
        general, bad = _general_factors(cov)
        planar = np.zeros((0, 3))
    if bad >= 0:
        return GatedPairs(np.zeros(n + 1, dtype=np.int64), empty_i, empty_f, bad, -1)
    if not gate >= 0.0:  # no cost (a sum of squares, or NaN) is admissible
        return GatedPairs(np.zeros(n + 1, dtype=np.int64), empty_i, empty_f, -1, -1)
    found = box_candidates(mean, gate_half_widths(cov, gate), z)
    if found.bad >= 0:
        return GatedPairs(np.zeros(n + 1, dtype=np.int64), empty_i, empty_f, -1, found.bad)
    cand_ptr, cand_cols = found.ptr, found.cols
    ptr = np.zeros(n + 1, dtype=np.int64)
    cols = np.empty(cand_cols.shape[0], dtype=np.int64)
    cost = np.empty(cand_cols.shape[0])
    t = 0
    for i in range(n):
        if D == 2:
            i00 = planar[i, 0]
            i10 = planar[i, 1]
            i11 = planar[i, 2]
            mu0 = mean[i, 0]
            mu1 = mean[i, 1]
            for e in range(cand_ptr[i], cand_ptr[i + 1]):
                j = cand_cols[e]
                d0 = z[j, 0] - mu0
                d1 = z[j, 1] - mu1
                y0 = i00 * d0
                y1 = i10 * d0 + i11 * d1
                c = y0 * y0 + y1 * y1
                if c <= gate:
                    cols[t] = j
                    cost[t] = c
                    t += 1
        else:
            for e in range(cand_ptr[i], cand_ptr[i + 1]):
                j = cand_cols[e]
                c = 0.0
                for r in range(D):
                    y = general[i, r, 0] * (z[j, 0] - mean[i, 0])
                    for k in range(1, r + 1):
                        y += general[i, r, k] * (z[j, k] - mean[i, k])
                    c += y * y
                if c <= gate:
                    cols[t] = j
                    cost[t] = c
                    t += 1
        ptr[i + 1] = t
    return GatedPairs(ptr, cols[:t], cost[:t], -1, -1)


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
    of [`agents.tracking.merges.share_blobs`][agents.tracking.merges.share_blobs], whose docstring has the
    equations).

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
    # the candidates: taken detections within the box |z_k − ŷ_j| <= extent of each leftover track
    n_taken = 0
    for d in range(m):
        n_taken += owner[d] >= 0
    taken = np.empty(n_taken, np.int64)
    t = 0
    for d in range(m):
        if owner[d] >= 0:
            taken[t] = d
            t += 1
    queries = np.empty(n, np.int64)
    n_queries = 0
    for j in range(n):
        if det_of_track[j] >= 0:
            continue
        inside = True
        for k in range(dim):
            inside = inside and low[k] <= predicted[j, k] <= high[k]
        if inside:  # a particle that left the view is no blob member
            queries[n_queries] = j
            n_queries += 1
    if n_queries == 0 or n_taken == 0:
        out[queries[:n_queries]] = -1
    else:
        points = np.empty((n_taken, dim))
        for t in range(n_taken):
            for k in range(dim):
                points[t, k] = z[taken[t], k]
        centres = np.empty((n_queries, dim))
        for q in range(n_queries):
            for k in range(dim):
                centres[q, k] = predicted[queries[q], k]
        half = np.full((n_queries, min(dim, 2)), extent * (1.0 + BOX_SLACK) + BOX_TINY)
        found = box_candidates(centres, half, points)
        for q in range(n_queries):
            j = queries[q]
            best, best_d = -1, e2
            for e in range(found.ptr[q], found.ptr[q + 1]):
                d = taken[found.cols[e]]  # ascending, as the dense scan over all detections
                i = owner[d]
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
