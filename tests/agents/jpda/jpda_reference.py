"""The first-axis sweeps the JPDA frame used before its spatial index, kept as a test oracle.

The gates of [`agents.jpda._kernels.jpda_frame`][agents.jpda._kernels.jpda_frame] were windows of the
detections sorted by their first coordinate (binary search), the merged-blob pairs a sweep of the tracks
sorted the same way, the blob splits a loop over unseen tracks and pairs of free detections. The compiled
steps of today must list exactly the same hypotheses, with the same log weights, in the same order.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from agents.jpda._kernels import (
    FRAME_OK,
    JpdaFrame,
    _associate_clusters,
    _big_tracks,
    _blob_gaussian,
    _clusters,
    _log_norm,
    _mahalanobis,
    _roots,
    _track_factors,
)
from agents.tracking._kernels import cholesky_lower
from track_envs.infra.compiled import njit
from track_envs.values.types import FloatArray

IntArray = NDArray[np.int64]


@njit(cache=True)
def _sorted_first_axis(z: FloatArray) -> tuple[IntArray, FloatArray]:
    """The detections in ascending first coordinate, ``(order, z[order, 0])``: the gates of steps
    1 and 2 are windows of that axis found by binary search."""
    m = z.shape[0]
    z_order = np.argsort(z[:, 0])
    zx = np.empty(m)
    for q in range(m):
        zx[q] = z[z_order[q], 0]
    return z_order, zx


@njit(cache=True)
def _gated_pairs(
    mean: FloatArray,
    cov: FloatArray,
    z: FloatArray,
    chol: FloatArray,
    lnorm: FloatArray,
    gate: float,
    log_ratio: float,
    z_order: IntArray,
    zx: FloatArray,
    diff: FloatArray,
    work: FloatArray,
) -> tuple[IntArray, IntArray, FloatArray, int]:
    """Step 1: the admissible (track, detection) pairs, ``d²_ij ≤ γ``, and their log weights.

    A pair farther along the first axis than ``sqrt(γ S_00)`` is outside the gate
    (``d² ≥ Δ₀² / S_00``), so track ``i`` tests only the detections of that window of ``zx``.

    Returns:
        ``(e_t, e_d, e_w, ne)``: track, detection and ``log w_ij`` in the first ``ne`` rows
            (tracks ascending, each track's detections in ``z_order``).
    """
    n, D = mean.shape
    m = z.shape[0]
    cap = 4 * (n + m) + 16
    e_t = np.empty(cap, np.int64)
    e_d = np.empty(cap, np.int64)
    e_w = np.empty(cap)
    ne = 0
    reach = np.empty(n)
    for i in range(n):
        reach[i] = math.sqrt(gate * cov[i, 0, 0])
    for i in range(n):
        lo = np.searchsorted(zx, mean[i, 0] - reach[i])
        hi = np.searchsorted(zx, mean[i, 0] + reach[i], side="right")
        for q in range(lo, hi):
            j = z_order[q]
            for d in range(D):
                diff[d] = z[j, d] - mean[i, d]
            d2 = _mahalanobis(chol[i], diff, work)
            if d2 <= gate:
                if ne == len(e_t):
                    e_t = np.concatenate((e_t, np.empty(len(e_t), np.int64)))
                    e_d = np.concatenate((e_d, np.empty(len(e_d), np.int64)))
                    e_w = np.concatenate((e_w, np.empty(len(e_w))))
                e_t[ne], e_d[ne], e_w[ne] = i, j, log_ratio - 0.5 * d2 + lnorm[i]
                ne += 1
    return e_t, e_d, e_w, ne


@njit(cache=True)
def _merged_hypotheses(
    mean: FloatArray,
    cov: FloatArray,
    z: FloatArray,
    gate: float,
    log_ratio: float,
    extent: float,
    noise_cov: FloatArray,
    area_var: float,
    log_merge_odds: float,
    mergeable: NDArray[np.bool_],
    z_order: IntArray,
    zx: FloatArray,
    diff: FloatArray,
    work: FloatArray,
) -> tuple[IntArray, IntArray, IntArray, FloatArray, int]:
    """Step 2: the merged-blob hypotheses, every pair of mergeable tracks at most ``extent``
    apart with every detection inside its blob's gate (none when ``extent`` is 0).

    The pairs are swept in ascending first coordinate of their predictions; a blob's detections
    are the window ``|z_0 − μ_0| ≤ sqrt(γ C_00)`` of ``zx``, then the full gate.

    Returns:
        ``(g_a, g_b, g_d, g_w, ng)``: the smaller and larger track, the detection and
            ``log w_ej`` in the first ``ng`` rows.
    """
    n, D = mean.shape
    m = z.shape[0]
    mcap = 16
    g_a = np.empty(mcap, np.int64)
    g_b = np.empty(mcap, np.int64)
    g_d = np.empty(mcap, np.int64)
    g_w = np.empty(mcap)
    ng = 0
    if not (extent > 0.0 and n > 1 and m > 0):
        return g_a, g_b, g_d, g_w, ng
    cm = np.zeros((D, D))
    cl = np.zeros((D, D))
    mu = np.zeros(D)
    ext2 = extent * extent
    order = np.argsort(mean[:, 0])
    for oa in range(n):
        a = order[oa]
        if not mergeable[a]:
            continue
        for ob in range(oa + 1, n):
            b = order[ob]
            if mean[b, 0] - mean[a, 0] > extent:
                break
            if not mergeable[b]:
                continue
            dist2 = 0.0
            for d in range(D):
                dist2 += (mean[a, d] - mean[b, d]) ** 2
            if dist2 > ext2:
                continue
            _blob_gaussian(mean, cov, a, b, noise_cov, area_var, mu, cm)
            if not cholesky_lower(cm, cl):
                continue
            ln = _log_norm(cl)
            lo, hi = (a, b) if a < b else (b, a)
            r0 = math.sqrt(gate * cm[0, 0])
            q0 = np.searchsorted(zx, mu[0] - r0)
            q1 = np.searchsorted(zx, mu[0] + r0, side="right")
            for q in range(q0, q1):
                j = z_order[q]
                for d in range(D):
                    diff[d] = z[j, d] - mu[d]
                d2 = _mahalanobis(cl, diff, work)
                if d2 <= gate:
                    if ng == len(g_a):
                        g_a = np.concatenate((g_a, np.empty(len(g_a), np.int64)))
                        g_b = np.concatenate((g_b, np.empty(len(g_b), np.int64)))
                        g_d = np.concatenate((g_d, np.empty(len(g_d), np.int64)))
                        g_w = np.concatenate((g_w, np.empty(len(g_w))))
                    g_a[ng], g_b[ng], g_d[ng] = lo, hi, j
                    g_w[ng] = log_ratio + log_merge_odds - 0.5 * d2 + ln
                    ng += 1
    return g_a, g_b, g_d, g_w, ng


@njit(cache=True)
def _split_candidates(
    mean: FloatArray,
    cov: FloatArray,
    z: FloatArray,
    unseen: NDArray[np.bool_],
    free: NDArray[np.bool_],
    gate: float,
    noise_cov: FloatArray,
    area_var: float,
    extent: float,
) -> tuple[IntArray, IntArray, IntArray, FloatArray]:
    """The admissible split hypotheses of `split_blobs`: ``(track, j, k, d²)`` for every
    unseen track and pair of free detections ``j < k`` (in ``free`` order) that pass the gate."""
    n, D = mean.shape
    cand_t = np.empty(0, np.int64)
    cand_j = np.empty(0, np.int64)
    cand_k = np.empty(0, np.int64)
    cand_d = np.empty(0)
    C = np.zeros((D, D))
    Lc = np.zeros((D, D))
    diff = np.zeros(D)
    work = np.zeros(D)
    free_idx = np.flatnonzero(free)
    ts = []
    js = []
    ks = []
    ds = []
    for i in range(n):
        if not unseen[i]:
            continue
        for a in range(len(free_idx)):
            j = free_idx[a]
            if abs(z[j, 0] - mean[i, 0]) > extent:
                continue
            for b in range(a + 1, len(free_idx)):
                k = free_idx[b]
                sep2 = 0.0
                for d in range(D):
                    sep2 += (z[j, d] - z[k, d]) ** 2
                if sep2 > extent * extent:
                    continue
                for r in range(D):
                    diff[r] = 0.5 * (z[j, r] + z[k, r]) - mean[i, r]
                    for c in range(D):
                        C[r, c] = (
                            cov[i, r, c]
                            - 0.5 * noise_cov[r, c]
                            + area_var * (z[j, r] - z[k, r]) * (z[j, c] - z[k, c])
                        )
                if not cholesky_lower(C, Lc):
                    continue
                d2 = _mahalanobis(Lc, diff, work)
                if d2 <= gate:
                    ts.append(i)
                    js.append(j)
                    ks.append(k)
                    ds.append(d2)
    if len(ts):
        cand_t, cand_j, cand_k, cand_d = np.array(ts), np.array(js), np.array(ks), np.array(ds)
    return cand_t, cand_j, cand_k, cand_d


@njit(cache=True)
def reference_frame(
    mean: FloatArray,
    cov: FloatArray,
    z: FloatArray,
    gate: float,
    log_ratio: float,
    log_miss: float,
    extent: float,
    noise_cov: FloatArray,
    area_var: float,
    log_merge_odds: float,
    max_exact: int,
    mergeable: NDArray[np.bool_],
) -> JpdaFrame:
    """[`agents.jpda._kernels.jpda_frame`][agents.jpda._kernels.jpda_frame] with the first-axis sweeps for
    steps 1 and 2 (positive definite covariances only)."""
    n, D = mean.shape
    m = z.shape[0]
    chol = np.zeros((n, D, D))
    lnorm = np.zeros(n)
    work = np.zeros(D)
    diff = np.zeros(D)
    p_seen = np.zeros(n)
    z_mean = mean.copy()
    z_spread = np.zeros((n, D, D))
    best = np.full(n, -1, dtype=np.int64)
    best_prob = np.zeros(n)
    merged_with = np.full(n, -1, dtype=np.int64)
    clutter = np.ones(m)
    settled = np.zeros(m)
    _track_factors(cov, chol, lnorm)
    z_order, zx = _sorted_first_axis(z)
    e_t, e_d, e_w, ne = _gated_pairs(mean, cov, z, chol, lnorm, gate, log_ratio, z_order, zx, diff, work)
    g_a, g_b, g_d, g_w, ng = _merged_hypotheses(
        mean, cov, z, gate, log_ratio, extent, noise_cov, area_var, log_merge_odds, mergeable,
        z_order, zx, diff, work,
    )  # fmt: skip
    cl = _clusters(_roots(n, m, e_t, e_d, ne, g_a, g_b, g_d, ng), n)
    cluster_of = np.empty(n, np.int64)
    for i in range(n):
        cluster_of[i] = cl.label[cl.root[i]]
    _associate_clusters(
        mean, mean, z, log_miss, max_exact, mergeable, cl, e_t, e_d, e_w, ne, g_a, g_b, g_d, g_w, ng,
        p_seen, z_mean, z_spread, best, best_prob, merged_with, clutter, settled, diff, work,
    )  # fmt: skip
    return JpdaFrame(
        p_seen, z_mean, z_spread, best, best_prob, merged_with, clutter, settled,
        cl.c_nt, cluster_of, cl.c_nd, _big_tracks(cl, max_exact), FRAME_OK, -1,
    )  # fmt: skip
