r"""Compiled (numba) JPDA association of one frame, with merged blobs as joint events.

For ``n`` predicted measurements ``N(ŷ_i, S_i)`` and ``m`` detections ``z_j`` (``D`` dimensions)
one call of :func:`jpda_frame` computes, without a Python loop over tracks or clusters:

1. **Gated likelihoods.** ``S_i = L_i L_iᵀ``, ``d²_ij = ‖L_i⁻¹ (z_j − ŷ_i)‖²``, admissible when
   ``d²_ij ≤ γ``, with log weight (:mod:`agents.jpda.weights`)

   .. math::

       \log w_{ij} = \log\frac{p_D}{λ} - \tfrac12 d^2_{ij} - \log\det L_i - \tfrac D2 \log 2π .

2. **Merged blobs.** Two tracks predicted within ``extent`` of each other form a candidate pair
   ``e = (a, b)``. Touching particles are seen as one blob at their area-weighted centroid plus
   the sensor noise (:mod:`track_envs.envs.blobs`); for areas ``w, 1 − w`` with ``w ≈ ½ ± σ_w``
   its predicted measurement is

   .. math::

       μ_e = \tfrac12 (ŷ_a + ŷ_b), \qquad
       C_e = \tfrac14 (S_a + S_b) + \tfrac12 R + σ_w^2\, δ δ^\top, \quad δ = ŷ_a - ŷ_b,

   (``S = P + R``: the positions' uncertainty averaged, one noise ``R`` for the one centroid, the
   area split along the pair's axis). A detection inside that gate is the pair's merged
   blob with log weight ``log w_ej = log(p_D / λ) + log N(z_j; μ_e, C_e) + log odds_M`` in a joint
   event where both ``a`` and ``b`` take ``j`` and neither takes any other detection.

3. **Clusters.** Union–find over tracks and detections linked by an admissible pair or a
   merged-blob hypothesis; events factorise over them.

4. **Exact marginals per cluster** by dynamic programming over its detections with the set ``A``
   of tracks already used as a bitmask (the recursion of :mod:`agents.jpda.exact`, with the
   merged hypotheses as a third kind of step), in log space:

   .. math::

       F_{j+1}(A) = F_j(A) + \sum_{i \in A} F_j(A∖i)\, w_{ij}
                    + \sum_{e=(a,b) ⊆ A} F_j(A∖\{a,b\})\, w_{ej},

       G_j(A) = G_{j+1}(A) + \sum_{i \notin A} w_{ij} G_{j+1}(A∪i)
                + \sum_{e ∩ A = ∅} w_{ej} G_{j+1}(A∪e), \quad G_m(A) = \prod_{i∉A} w_{i∅},

   ``Z = G_0(∅)``; ``β_ij = Σ_{A∌i} F_j(A) w_ij G_{j+1}(A∪i) / Z``, likewise ``β_ej`` and the
   clutter probability ``β_∅j = Σ_A F_j(A) G_{j+1}(A) / Z``. Cost ``O(m_c · 2^{n_c} · (n_c + e_c))``
   per cluster of ``n_c`` tracks, ``m_c`` detections and ``e_c`` merged hypotheses. Clusters of
   more than ``max_exact`` tracks are not computed here (``big`` lists their tracks for the caller's
   fallback).

5. **Moment matching.** Track ``i``'s hypotheses are its own detections (pseudo-measurement
   ``z_j``) and its merged blobs with a partner ``k`` (``z_j + ½(ŷ_i − ŷ_k)``: the blob moves the
   pair as a rigid group, as in :mod:`agents.tracking.merges`). With ``p_i = Σ β`` of them (the
   probability that the track was detected), the mixture's measurement mean and spread are

   .. math::

       \bar z_i = \frac{1}{p_i} \sum_h β_h z_h, \qquad
       Σ_i = \frac{1}{p_i} \sum_h β_h (z_h - \bar z_i)(z_h - \bar z_i)^\top,

   which the PDA update of the predictor takes (:class:`predictors.base.MixtureUpdate`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from track_envs.compiled import njit
from track_envs.types import FloatArray

IntArray = NDArray[np.int64]

#: Status of :func:`jpda_frame`: every covariance positive definite.
FRAME_OK = 0
#: Status: the predicted covariance of track ``bad`` is not positive definite.
FRAME_NOT_PD = 1


class JpdaFrame(NamedTuple):
    """Result of :func:`jpda_frame` (new arrays).

    Attributes:
        p_seen: (n,) ``p_i``, the probability that the track was detected this frame.
        z_mean: (n, D) ``z̄_i`` (the prediction where ``p_i = 0``).
        z_spread: (n, D, D) ``Σ_i``.
        best: (n,) the detection of the track's most probable hypothesis (−1: none).
        best_prob: (n,) that hypothesis's probability (0 where ``best`` is −1).
        merged_with: (n,) the partner of the most probable hypothesis when it is a merged blob, else −1.
        clutter: (m,) ``β_∅j``.
        cluster_tracks: (n_clusters,) tracks per cluster that holds a track, in label order.
        cluster_detections: (n_clusters,) detections of those clusters.
        big: tracks of the clusters with more than ``max_exact`` tracks (not computed here), ascending.
        status: :data:`FRAME_OK` or :data:`FRAME_NOT_PD`.
        bad: the offending track, or −1.
    """

    p_seen: FloatArray
    z_mean: FloatArray
    z_spread: FloatArray
    best: IntArray
    best_prob: FloatArray
    merged_with: IntArray
    clutter: FloatArray
    cluster_tracks: IntArray
    cluster_detections: IntArray
    big: IntArray
    status: int
    bad: int


@njit(cache=True)
def _cholesky(a: FloatArray, out: FloatArray) -> bool:
    """Lower Cholesky factor of the small SPD matrix ``a`` into ``out``; False if not PD."""
    d = a.shape[0]
    for r in range(d):
        for c in range(r + 1):
            s = a[r, c]
            for k in range(c):
                s -= out[r, k] * out[c, k]
            if r == c:
                if not s > 0.0:
                    return False
                out[r, r] = math.sqrt(s)
            else:
                out[r, c] = s / out[c, c]
        for c in range(r + 1, d):
            out[r, c] = 0.0
    return True


@njit(cache=True)
def _mahalanobis(chol: FloatArray, diff: FloatArray, work: FloatArray) -> float:
    """``‖L⁻¹ diff‖²`` by forward substitution."""
    d = chol.shape[0]
    s2 = 0.0
    for r in range(d):
        s = diff[r]
        for k in range(r):
            s -= chol[r, k] * work[k]
        work[r] = s / chol[r, r]
        s2 += work[r] * work[r]
    return s2


@njit(cache=True)
def _log_norm(chol: FloatArray) -> float:
    """``−log det L − (D/2) log 2π``, the log normaliser of ``N(·; ·, L Lᵀ)``."""
    d = chol.shape[0]
    s = -0.5 * d * math.log(2.0 * math.pi)
    for r in range(d):
        s -= math.log(chol[r, r])
    return s


@njit(cache=True)
def _lae(a: float, b: float) -> float:
    """``log(eᵃ + eᵇ)`` (−inf safe)."""
    if a < b:
        a, b = b, a
    if b == -np.inf:
        return a
    return a + math.log1p(math.exp(b - a))


@njit(cache=True)
def _find(parent: IntArray, x: int) -> int:
    while parent[x] != x:
        parent[x] = parent[parent[x]]
        x = parent[x]
    return x


@njit(cache=True)
def _union(parent: IntArray, a: int, b: int) -> None:
    ra, rb = _find(parent, a), _find(parent, b)
    if ra != rb:
        if ra < rb:
            parent[rb] = ra
        else:
            parent[ra] = rb


@njit(cache=True)
def _cluster_marginals(
    L: FloatArray,
    log_miss: float,
    m_a: IntArray,
    m_b: IntArray,
    m_det: IntArray,
    m_w: FloatArray,
    P: FloatArray,
    PM: FloatArray,
    PC: FloatArray,
) -> bool:
    """Exact marginals of one cluster (module docstring, step 4), local indices.

    Args:
        L: (nc, mc) log pair weights (−inf outside the gate).
        log_miss: ``log w_∅`` of every track.
        m_a, m_b, m_det, m_w: the cluster's merged hypotheses (local tracks, detection, log weight).
        P, PM, PC: outputs, (nc, mc) pair, (e,) merged and (mc,) clutter probabilities.

    Returns:
        False when no joint event has positive weight.
    """
    nc, mc = L.shape
    ne = len(m_a)
    nm = 1 << nc
    full = nm - 1
    F = np.full((mc + 1, nm), -np.inf)
    G = np.full((mc + 1, nm), -np.inf)
    F[0, 0] = 0.0
    for j in range(mc):
        for A in range(nm):
            acc = F[j, A]
            for t in range(nc):
                if (A >> t) & 1 and L[t, j] > -np.inf:
                    acc = _lae(acc, F[j, A ^ (1 << t)] + L[t, j])
            for e in range(ne):
                if m_det[e] == j:
                    bits = (1 << m_a[e]) | (1 << m_b[e])
                    if A & bits == bits:
                        acc = _lae(acc, F[j, A ^ bits] + m_w[e])
            F[j + 1, A] = acc
    for A in range(nm):
        free = 0
        for t in range(nc):
            if not (A >> t) & 1:
                free += 1
        G[mc, A] = free * log_miss if free else 0.0
    for j in range(mc - 1, -1, -1):
        for A in range(nm):
            acc = G[j + 1, A]
            for t in range(nc):
                if not (A >> t) & 1 and L[t, j] > -np.inf:
                    acc = _lae(acc, G[j + 1, A | (1 << t)] + L[t, j])
            for e in range(ne):
                if m_det[e] == j:
                    bits = (1 << m_a[e]) | (1 << m_b[e])
                    if A & bits == 0:
                        acc = _lae(acc, G[j + 1, A | bits] + m_w[e])
            G[j, A] = acc
    log_z = G[0, 0]
    if not log_z > -np.inf:
        return False
    for j in range(mc):
        c = 0.0
        for A in range(nm):
            f = F[j, A]
            if f == -np.inf:
                continue
            c += math.exp(f + G[j + 1, A] - log_z)
            rest = full ^ A
            for t in range(nc):
                if (rest >> t) & 1 and L[t, j] > -np.inf:
                    P[t, j] += math.exp(f + L[t, j] + G[j + 1, A | (1 << t)] - log_z)
            for e in range(ne):
                if m_det[e] == j:
                    bits = (1 << m_a[e]) | (1 << m_b[e])
                    if A & bits == 0:
                        PM[e] += math.exp(f + m_w[e] + G[j + 1, A | bits] - log_z)
        PC[j] = c
    return True


@njit(cache=True)
def jpda_frame(
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
) -> JpdaFrame:
    """The JPDA association of one frame (module docstring).

    Args:
        mean: (n, D) predicted measurements ``ŷ``. cov: (n, D, D) their covariances ``S``.
        z: (m, D) detections.
        gate: ``γ`` on squared Mahalanobis distances.
        log_ratio: ``log(p_D / λ)``.
        log_miss: ``log(1 − p_D P_G)`` (−inf allowed).
        extent: largest distance of two predictions that may be one blob; 0: no merged blobs.
        noise_cov: (D, D) the sensor noise ``R``.
        area_var: ``σ_w²``, the variance of a blob member's area fraction around ½.
        log_merge_odds: log prior odds of a merged blob against two separate particles.
        max_exact: clusters of more tracks are left to the caller (``big``).
    """
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
    for i in range(n):
        if not _cholesky(cov[i], chol[i]):
            return JpdaFrame(
                p_seen, z_mean, z_spread, best, best_prob, merged_with, clutter,
                np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64), FRAME_NOT_PD, i,
            )  # fmt: skip
        lnorm[i] = _log_norm(chol[i])
    # 1. gated pairs (edge lists)
    cap = 4 * (n + m) + 16
    e_t = np.empty(cap, np.int64)
    e_d = np.empty(cap, np.int64)
    e_w = np.empty(cap)
    ne = 0
    for i in range(n):
        for j in range(m):
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
    # 2. merged-blob hypotheses
    mcap = 16
    g_a = np.empty(mcap, np.int64)
    g_b = np.empty(mcap, np.int64)
    g_d = np.empty(mcap, np.int64)
    g_w = np.empty(mcap)
    ng = 0
    if extent > 0.0 and n > 1 and m > 0:
        cm = np.zeros((D, D))
        cl = np.zeros((D, D))
        mu = np.zeros(D)
        ext2 = extent * extent
        order = np.argsort(mean[:, 0])
        for oa in range(n):
            a = order[oa]
            for ob in range(oa + 1, n):
                b = order[ob]
                if mean[b, 0] - mean[a, 0] > extent:
                    break
                dist2 = 0.0
                for d in range(D):
                    dist2 += (mean[a, d] - mean[b, d]) ** 2
                if dist2 > ext2:
                    continue
                for r in range(D):
                    mu[r] = 0.5 * (mean[a, r] + mean[b, r])
                    for c in range(D):
                        dr = mean[a, r] - mean[b, r]
                        dc = mean[a, c] - mean[b, c]
                        cm[r, c] = (
                            0.25 * (cov[a, r, c] + cov[b, r, c]) + 0.5 * noise_cov[r, c] + area_var * dr * dc
                        )
                if not _cholesky(cm, cl):
                    continue
                ln = _log_norm(cl)
                lo, hi = (a, b) if a < b else (b, a)
                for j in range(m):
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
    # 3. clusters
    parent = np.arange(n + m)
    for k in range(ne):
        _union(parent, e_t[k], n + e_d[k])
    for k in range(ng):
        _union(parent, g_a[k], n + g_d[k])
        _union(parent, g_b[k], n + g_d[k])
    root = np.empty(n + m, np.int64)
    for v in range(n + m):
        root[v] = _find(parent, v)
    # clusters that hold a track, labelled in order of their smallest track
    label = np.full(n + m, -1, np.int64)
    n_cl = 0
    for i in range(n):
        r = root[i]
        if label[r] < 0:
            label[r] = n_cl
            n_cl += 1
    c_nt = np.zeros(n_cl, np.int64)
    c_nd = np.zeros(n_cl, np.int64)
    local = np.empty(n + m, np.int64)
    for v in range(n + m):
        lab = label[root[v]]
        if lab < 0:
            continue  # a detection in no track's gate: clutter for sure
        if v < n:
            local[v] = c_nt[lab]
            c_nt[lab] += 1
        else:
            local[v] = c_nd[lab]
            c_nd[lab] += 1
    t_start = np.zeros(n_cl + 1, np.int64)
    d_start = np.zeros(n_cl + 1, np.int64)
    for c in range(n_cl):
        t_start[c + 1] = t_start[c] + c_nt[c]
        d_start[c + 1] = d_start[c] + c_nd[c]
    t_of = np.empty(n, np.int64)
    d_of = np.empty(max(d_start[n_cl], 1), np.int64)
    for v in range(n + m):
        lab = label[root[v]]
        if lab < 0:
            continue
        if v < n:
            t_of[t_start[lab] + local[v]] = v
        else:
            d_of[d_start[lab] + local[v]] = v - n
    e_start = np.zeros(n_cl + 1, np.int64)
    for k in range(ne):
        e_start[label[root[e_t[k]]] + 1] += 1
    for c in range(n_cl):
        e_start[c + 1] += e_start[c]
    e_ord = np.empty(ne, np.int64)
    fill = e_start[:-1].copy()
    for k in range(ne):
        c = label[root[e_t[k]]]
        e_ord[fill[c]] = k
        fill[c] += 1
    g_start = np.zeros(n_cl + 1, np.int64)
    for k in range(ng):
        g_start[label[root[g_a[k]]] + 1] += 1
    for c in range(n_cl):
        g_start[c + 1] += g_start[c]
    g_ord = np.empty(ng, np.int64)
    fill = g_start[:-1].copy()
    for k in range(ng):
        c = label[root[g_a[k]]]
        g_ord[fill[c]] = k
        fill[c] += 1
    n_big = 0
    for c in range(n_cl):
        if c_nt[c] > max_exact:
            n_big += c_nt[c]
    big = np.empty(n_big, np.int64)
    nb = 0
    hyp_w = np.zeros(n)
    # 4. per cluster: marginals; 5. per track: the mixture
    for c in range(n_cl):
        nc, mc = c_nt[c], c_nd[c]
        if nc > max_exact:
            for q in range(nc):
                big[nb] = t_of[t_start[c] + q]
                nb += 1
            continue
        if mc == 0:
            continue
        L = np.full((nc, mc), -np.inf)
        for q in range(e_start[c], e_start[c + 1]):
            k = e_ord[q]
            L[local[e_t[k]], local[n + e_d[k]]] = e_w[k]
        ge = g_start[c + 1] - g_start[c]
        ma = np.empty(ge, np.int64)
        mb = np.empty(ge, np.int64)
        md = np.empty(ge, np.int64)
        mw = np.empty(ge)
        for q in range(ge):
            k = g_ord[g_start[c] + q]
            ma[q], mb[q], md[q], mw[q] = local[g_a[k]], local[g_b[k]], local[n + g_d[k]], g_w[k]
        P = np.zeros((nc, mc))
        PM = np.zeros(ge)
        PC = np.zeros(mc)
        if not _cluster_marginals(L, log_miss, ma, mb, md, mw, P, PM, PC):
            # p_D P_G = 1 and the tracks cannot all take a detection: leave them undetected
            continue
        for q in range(mc):
            clutter[d_of[d_start[c] + q]] = PC[q]
        # the mixture of every track of the cluster: mean, then centred spread
        for pass_ in range(2):
            for q in range(nc):
                i = t_of[t_start[c] + q]
                if pass_ == 0:
                    hyp_w[i] = 0.0
                    for d in range(D):
                        z_mean[i, d] = 0.0
                for r in range(mc):
                    w = P[q, r]
                    if w <= 0.0:
                        continue
                    j = d_of[d_start[c] + r]
                    _accumulate(pass_, i, w, z[j], z_mean, z_spread, hyp_w, diff, D)
                    if pass_ == 0 and w > best_prob[i]:
                        best_prob[i], best[i], merged_with[i] = w, j, -1
                for h in range(ge):
                    if ma[h] != q and mb[h] != q:
                        continue
                    w = PM[h]
                    if w <= 0.0:
                        continue
                    k = t_of[t_start[c] + (mb[h] if ma[h] == q else ma[h])]
                    j = d_of[d_start[c] + md[h]]
                    for d in range(D):
                        work[d] = z[j, d] + 0.5 * (mean[i, d] - mean[k, d])
                    _accumulate(pass_, i, w, work, z_mean, z_spread, hyp_w, diff, D)
                    if pass_ == 0 and w > best_prob[i]:
                        best_prob[i], best[i], merged_with[i] = w, j, k
                if pass_ == 0:
                    p_seen[i] = hyp_w[i]
                    if hyp_w[i] > 0.0:
                        for d in range(D):
                            z_mean[i, d] /= hyp_w[i]
                    else:
                        for d in range(D):
                            z_mean[i, d] = mean[i, d]
                elif hyp_w[i] > 0.0:
                    for r in range(D):
                        for s in range(D):
                            z_spread[i, r, s] /= hyp_w[i]
    return JpdaFrame(
        p_seen, z_mean, z_spread, best, best_prob, merged_with, clutter, c_nt, c_nd, big, FRAME_OK, -1
    )


@njit(cache=True)
def _accumulate(
    pass_: int,
    i: int,
    w: float,
    zh: FloatArray,
    z_mean: FloatArray,
    z_spread: FloatArray,
    hyp_w: FloatArray,
    diff: FloatArray,
    D: int,
) -> None:
    """Add hypothesis ``zh`` of weight ``w`` to track ``i``'s mean sums (pass 0) or, with the mean
    known, to its centred spread sums (pass 1)."""
    if pass_ == 0:
        hyp_w[i] += w
        for d in range(D):
            z_mean[i, d] += w * zh[d]
    else:
        for d in range(D):
            diff[d] = zh[d] - z_mean[i, d]
        for r in range(D):
            for s in range(D):
                z_spread[i, r, s] += w * diff[r] * diff[s]
