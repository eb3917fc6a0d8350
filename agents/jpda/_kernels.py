r"""Compiled (numba) JPDA association of one frame, with merged blobs as joint events.

For ``n`` predicted measurements ``N(ŷ_i, S_i)`` and ``m`` detections ``z_j`` (``D`` dimensions)
one call of [`jpda_frame`][agents.jpda._kernels.jpda_frame] computes, without a Python loop over tracks or
clusters:

1. **Gated likelihoods.** ``S_i = L_i L_iᵀ``, ``d²_ij = ‖L_i⁻¹ (z_j − ŷ_i)‖²``, admissible when
   ``d²_ij ≤ γ``, with log weight ([`agents.jpda.weights`][agents.jpda.weights])

   .. math::

       \log w_{ij} = \log\frac{p_D}{λ} - \tfrac12 d^2_{ij} - \log\det L_i - \tfrac D2 \log 2π .

2. **Merged blobs.** Two tracks predicted within ``extent`` of each other form a candidate pair
   ``e = (a, b)``. Touching particles are seen as one blob at their area-weighted centroid plus
   the sensor noise ([`track_envs.envs.blobs`][track_envs.envs.blobs]); for areas ``w, 1 − w`` with
   ``w ≈ ½ ± σ_w`` its predicted measurement is

   .. math::

       μ_e = \tfrac12 (ŷ_a + ŷ_b), \qquad
       C_e = \tfrac14 (S_a + S_b) + \tfrac12 R + σ_w^2\, δ δ^\top, \quad δ = ŷ_a - ŷ_b,

   (``S = P + R``: the positions' uncertainty averaged, one noise ``R`` for the one centroid, the
   area split along the pair's axis). A detection inside that gate is the pair's merged
   blob with log weight ``log w_ej = log(p_D / λ) + log N(z_j; μ_e, C_e) + log odds_M`` in a joint
   event where both ``a`` and ``b`` take ``j`` and neither takes any other detection.

3. **Clusters.** Union–find over tracks and detections linked by an admissible pair or a
   merged-blob hypothesis (the connected components of that sparse graph); events factorise
   over them.

4. **Exact marginals per cluster** by dynamic programming over its detections with the set ``A``
   of tracks already used as a bitmask (the recursion of [`agents.jpda.exact`][agents.jpda.exact], with the
   merged hypotheses as a third kind of step), in log space:

   .. math::

       F_{j+1}(A) = F_j(A) + \sum_{i \in A} F_j(A∖i)\, w_{ij}
                    + \sum_{e=(a,b) ⊆ A} F_j(A∖\{a,b\})\, w_{ej},

       G_j(A) = G_{j+1}(A) + \sum_{i \notin A} w_{ij} G_{j+1}(A∪i)
                + \sum_{e ∩ A = ∅} w_{ej} G_{j+1}(A∪e), \quad G_m(A) = \prod_{i∉A} w_{i∅},

   ``Z = G_0(∅)``; ``β_ij = Σ_{A∌i} F_j(A) w_ij G_{j+1}(A∪i) / Z``, likewise ``β_ej`` and the
   clutter probability ``β_∅j = Σ_A F_j(A) G_{j+1}(A) / Z``. Cost ``O(m_c · 2^{n_c} · (n_c + e_c))``
   per cluster of ``n_c`` tracks, ``m_c`` detections and ``e_c`` merged hypotheses; without merged
   hypotheses the bitmask runs over the smaller side. A cluster of more than
   [`MAX_MERGE_CLUSTER`][agents.jpda._kernels.MAX_MERGE_CLUSTER] tracks drops its merged hypotheses (their
   exact sum would cost ``2^{n_c}`` masks per detection: 5.8 ms at 12 tracks); clusters of more than
   ``max_exact`` tracks are not computed here (``big`` lists their tracks for the caller's fallback).

5. **Moment matching.** Track ``i``'s hypotheses are its own detections (pseudo-measurement
   ``z_j``) and its merged blobs with a partner ``k`` (``z_j + ½(a_i − a_k)``: the blob moves the
   pair as a group, as in [`agents.tracking.merges`][agents.tracking.merges], each member keeping its offset
   between the anchors ``a``). With the predictions as anchors (``a = ŷ``,
   [`jpda_frame`][agents.jpda._kernels.jpda_frame]) both members take the same innovation ``z_j − μ_e``, so
   the pair's relative motion is extrapolated by the predictor for as long as the blob lasts, unobserved; with
   the tracks' last estimates ([`jpda_frame_anchored`][agents.jpda._kernels.jpda_frame_anchored], a *rigid
   pair*) the offset is held where it was last seen and the members' relative velocity decays. With
   ``p_i = Σ β`` of them (the probability that the track was detected), the mixture's measurement mean and
   spread are

   .. math::

       \bar z_i = \frac{1}{p_i} \sum_h β_h z_h, \qquad
       Σ_i = \frac{1}{p_i} \sum_h β_h (z_h - \bar z_i)(z_h - \bar z_i)^\top,

   which the PDA update of the predictor takes
   ([`predictors.base.MixtureUpdate`][predictors.base.MixtureUpdate]).

**Candidates, linear in the scene.** No step tests all pairs. Every gate lies inside an
axis-aligned box — the χ² ellipse ``(z − μ)ᵀ C⁻¹ (z − μ) ≤ γ`` inside ``|z_k − μ_k| ≤ sqrt(γ C_kk)``
(``d² ≥ Δ_k² / C_kk``) — and the candidates of every box come from the uniform-grid spatial index
of [`track_envs.infra.spatial`][track_envs.infra.spatial] over the first two axes: the detections of a track's
gate (box ``sqrt(γ S_i,kk)``) and of a blob's gate (box ``sqrt(γ C_e,kk)``) from one grid of the frame's
detections, the candidate blob pairs from a grid of the mergeable predictions (box ``extent``),
and the blob splits' pieces ([`_split_candidates`][agents.jpda._kernels._split_candidates]) from grids of the
free detections. Each box is widened by [`BOX_MARGIN`][agents.jpda._kernels.BOX_MARGIN] so that rounding never
drops a pair the exact test keeps; the exact tests then decide as before. For gates of bounded size a frame
costs ``O(n + m)`` plus the clusters' own cost (step 4), whatever the size of the scene.

The hypotheses are listed in the order of a sweep along the first axis — a track's detections,
the blob pairs and each blob's detections by ascending first coordinate, equal coordinates in the
order of numba's ``np.argsort`` (a quicksort: its rank is computed only when two candidates'
coordinates are equal) — since the sums of steps 4 and 5 and their ties run in that order.

Each step is a compiled function of its own, called in order by
[`jpda_frame`][agents.jpda._kernels.jpda_frame]: 1. [`_track_factors`][agents.jpda._kernels._track_factors],
[`_detection_grid`][agents.jpda._kernels._detection_grid] and
[`_gated_pairs`][agents.jpda._kernels._gated_pairs]; 2.
[`_merged_hypotheses`][agents.jpda._kernels._merged_hypotheses] (the pairs by
[`_blob_pairs`][agents.jpda._kernels._blob_pairs], each pair's blob by
[`_blob_gaussian`][agents.jpda._kernels._blob_gaussian]); 3. [`_roots`][agents.jpda._kernels._roots] and
[`_clusters`][agents.jpda._kernels._clusters]; 4. and 5. per cluster
[`_associate_clusters`][agents.jpda._kernels._associate_clusters]:
[`_single_track`][agents.jpda._kernels._single_track] for a lone track, else
[`_cluster_weights`][agents.jpda._kernels._cluster_weights],
[`_cluster_marginals`][agents.jpda._kernels._cluster_marginals] and
[`_cluster_mixtures`][agents.jpda._kernels._cluster_mixtures].
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from agents.tracking._kernels import cholesky_lower
from track_envs.infra.compiled import njit
from track_envs.infra.spatial import GridIndex, box_candidates, build_grid, query_grid
from track_envs.values.types import FloatArray

IntArray = NDArray[np.int64]

#: Largest cluster (tracks) whose merged-blob hypotheses are kept; a larger cluster's marginals
#: are computed without them, over the smaller of its sides.
MAX_MERGE_CLUSTER = 8
#: Relative widening of every candidate box of the spatial index over its exact bound: rounding
#: never leaves out a pair that the exact test keeps (the test, not the box, decides).
BOX_MARGIN = 1e-7
#: Half-width of a box that holds every point (a gate of infinite or NaN size).
BOX_ALL = 1e300
#: Status of [`jpda_frame`][agents.jpda._kernels.jpda_frame]: every covariance positive definite.
FRAME_OK = 0
#: Status: the predicted covariance of track ``bad`` is not positive definite.
FRAME_NOT_PD = 1


class JpdaFrame(NamedTuple):
    """Result of [`jpda_frame`][agents.jpda._kernels.jpda_frame] (new arrays).

    Attributes:
        p_seen: (n,) ``p_i``, the probability that the track was detected this frame.
        z_mean: (n, D) ``z̄_i`` (the prediction where ``p_i = 0``).
        z_spread: (n, D, D) ``Σ_i``.
        best: (n,) the detection of the track's most probable hypothesis (−1: none).
        best_prob: (n,) that hypothesis's probability (0 where ``best`` is −1).
        merged_with: (n,) the partner of the most probable hypothesis when it is a merged blob, else −1.
        clutter: (m,) ``β_∅j``.
        settled: (m,) the probability that a mergeable (settled) track took detection ``j``, alone
            or in a merged blob.
        cluster_tracks: (n_clusters,) tracks per cluster that holds a track, in label order.
        cluster_of: (n,) each track's cluster (an index into ``cluster_tracks``).
        cluster_detections: (n_clusters,) detections of those clusters.
        big: tracks of the clusters with more than ``max_exact`` tracks (not computed here), ascending.
        status: [`FRAME_OK`][agents.jpda._kernels.FRAME_OK] or
            [`FRAME_NOT_PD`][agents.jpda._kernels.FRAME_NOT_PD].
        bad: the offending track, or −1.
    """

    p_seen: FloatArray
    z_mean: FloatArray
    z_spread: FloatArray
    best: IntArray
    best_prob: FloatArray
    merged_with: IntArray
    clutter: FloatArray
    settled: FloatArray
    cluster_tracks: IntArray
    cluster_of: IntArray
    cluster_detections: IntArray
    big: IntArray
    status: int
    bad: int


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
def _cluster_marginals_log(
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
    """Exact marginals of one cluster (module docstring, step 4), local indices, in log space
    (the fallback of [`_cluster_marginals`][agents.jpda._kernels._cluster_marginals] for weights beyond the
    float range).

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
def _dp_linear(
    W: FloatArray,
    step_free: FloatArray,
    item_free: FloatArray,
    m_a: IntArray,
    m_b: IntArray,
    m_step: IntArray,
    m_w: FloatArray,
    P: FloatArray,
    PM: FloatArray,
    PS: FloatArray,
) -> bool:
    """The recursion of step 4 in linear space: ``K`` steps (``W`` rows) over a bitmask of ``C``
    items (``W`` columns). Step ``s`` takes item ``c`` (factor ``W[s, c]``), two items of a merged
    hypothesis ``e`` with ``m_step[e] = s`` (factor ``m_w[e]``), or nothing (``step_free[s]``);
    an item never taken closes with ``item_free[c]``. Adds the marginals to ``P`` (K, C), ``PM``
    (e,) and ``PS`` (K,); False when ``Z`` is not a positive finite number (the caller then
    uses the log-space recursion)."""
    K, C = W.shape
    ne = len(m_a)
    nm = 1 << C
    full = nm - 1
    F = np.zeros((K + 1, nm))
    G = np.zeros((K + 1, nm))
    F[0, 0] = 1.0
    for s in range(K):
        sf = step_free[s]
        for A in range(nm):
            acc = F[s, A] * sf
            for c in range(C):
                if (A >> c) & 1:
                    acc += F[s, A ^ (1 << c)] * W[s, c]
            for e in range(ne):
                if m_step[e] == s:
                    bits = (1 << m_a[e]) | (1 << m_b[e])
                    if A & bits == bits:
                        acc += F[s, A ^ bits] * m_w[e]
            F[s + 1, A] = acc
    for A in range(nm):
        g = 1.0
        for c in range(C):
            if not (A >> c) & 1:
                g *= item_free[c]
        G[K, A] = g
    for s in range(K - 1, -1, -1):
        sf = step_free[s]
        for A in range(nm):
            acc = G[s + 1, A] * sf
            for c in range(C):
                if not (A >> c) & 1:
                    acc += W[s, c] * G[s + 1, A | (1 << c)]
            for e in range(ne):
                if m_step[e] == s:
                    bits = (1 << m_a[e]) | (1 << m_b[e])
                    if A & bits == 0:
                        acc += m_w[e] * G[s + 1, A | bits]
            G[s, A] = acc
    Z = G[0, 0]
    if not 0.0 < Z < np.inf:
        return False
    inv = 1.0 / Z
    for s in range(K):
        ps = 0.0
        sf = step_free[s]
        for A in range(nm):
            f = F[s, A]
            if f == 0.0:
                continue
            ps += f * sf * G[s + 1, A]
            rest = full ^ A
            for c in range(C):
                if (rest >> c) & 1:
                    P[s, c] += f * W[s, c] * G[s + 1, A | (1 << c)] * inv
            for e in range(ne):
                if m_step[e] == s:
                    bits = (1 << m_a[e]) | (1 << m_b[e])
                    if A & bits == 0:
                        PM[e] += f * m_w[e] * G[s + 1, A | bits] * inv
        PS[s] = ps * inv
    return True


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

    In linear space with every factor scaled so that the largest of its row of steps is 1 (a
    constant per step multiplies every joint event once, so the marginals do not change): the
    bitmask runs over the tracks with the detections as steps, or, without merged hypotheses
    and with fewer detections than tracks, over the detections with the tracks as steps
    (``O(K · C · 2^C)`` for the smaller side ``C``). Falls back to the log-space recursion
    ([`_cluster_marginals_log`][agents.jpda._kernels._cluster_marginals_log]) when the scaled weights leave
    the float range.

    Args and return as [`_cluster_marginals_log`][agents.jpda._kernels._cluster_marginals_log].
    """
    nc, mc = L.shape
    ne = len(m_a)
    miss = math.exp(log_miss) if log_miss > -np.inf else 0.0
    if ne == 0 and mc < nc:
        # steps: tracks (free: missed); items: detections (free: clutter)
        W = np.zeros((nc, mc))
        step_free = np.empty(nc)
        for t in range(nc):
            top = log_miss
            for j in range(mc):
                if L[t, j] > top:
                    top = L[t, j]
            step_free[t] = math.exp(log_miss - top) if log_miss > -np.inf else 0.0
            for j in range(mc):
                if L[t, j] > -np.inf:
                    W[t, j] = math.exp(L[t, j] - top)
        PT = np.zeros((nc, mc))
        PS = np.zeros(nc)
        if _dp_linear(W, step_free, np.ones(mc), m_a, m_b, m_det, m_w, PT, PM, PS):
            for t in range(nc):
                for j in range(mc):
                    P[t, j] += PT[t, j]
            for j in range(mc):
                c = 1.0
                for t in range(nc):
                    c -= PT[t, j]
                PC[j] = max(c, 0.0)
            return True
    else:
        # steps: detections (free: clutter); items: tracks (free: missed)
        W = np.zeros((mc, nc))
        step_free = np.empty(mc)
        mw = np.empty(ne)
        for j in range(mc):
            top = 0.0
            for t in range(nc):
                if L[t, j] > top:
                    top = L[t, j]
            for e in range(ne):
                if m_det[e] == j and m_w[e] > top:
                    top = m_w[e]
            step_free[j] = math.exp(-top)
            for t in range(nc):
                if L[t, j] > -np.inf:
                    W[j, t] = math.exp(L[t, j] - top)
            for e in range(ne):
                if m_det[e] == j:
                    mw[e] = math.exp(m_w[e] - top)
        PT = np.zeros((mc, nc))
        if _dp_linear(W, step_free, np.full(nc, miss), m_a, m_b, m_det, mw, PT, PM, PC):
            for t in range(nc):
                for j in range(mc):
                    P[t, j] += PT[j, t]
            return True
    P[:] = 0.0
    PM[:] = 0.0
    PC[:] = 0.0
    return _cluster_marginals_log(L, log_miss, m_a, m_b, m_det, m_w, P, PM, PC)


class _Clusters(NamedTuple):
    """Step 3's clusters that hold a track, labelled in order of their smallest track.

    Attributes:
        root: (n + m,) union–find root of every track (``0..n−1``) and detection (``n + j``).
        label: (n + m,) cluster of every root (−1: a cluster without a track).
        c_nt, c_nd: (n_clusters,) tracks and detections per cluster.
        local: (n + m,) index of each track / detection within its cluster.
        t_start, d_start: (n_clusters + 1,) start of each cluster's run in ``t_of`` / ``d_of``.
        t_of, d_of: the tracks and detections of every cluster, cluster by cluster (ascending inside).
    """

    root: IntArray
    label: IntArray
    c_nt: IntArray
    c_nd: IntArray
    local: IntArray
    t_start: IntArray
    d_start: IntArray
    t_of: IntArray
    d_of: IntArray


@njit(cache=True)
def _track_factors(cov: FloatArray, chol: FloatArray, lnorm: FloatArray) -> int:
    """Step 1's factors of every track: ``S_i = L_i L_iᵀ`` into ``chol[i]``, the log normaliser
    ``−log det L_i − (D/2) log 2π`` into ``lnorm[i]``.

    Returns:
        −1, or the first track whose ``S_i`` is not positive definite (no later row is written).
    """
    for i in range(cov.shape[0]):
        if not cholesky_lower(cov[i], chol[i]):
            return i
        lnorm[i] = _log_norm(chol[i])
    return -1


@njit(cache=True)
def _widen(h: float, centre: float) -> float:
    """A box half-width ``h`` widened by [`BOX_MARGIN`][agents.jpda._kernels.BOX_MARGIN] (and a few ulps of
    the centre), so that rounding never leaves out a point the exact test keeps; not finite: a box holding
    every point (the test then decides alone, as a scan of all points would)."""
    w = h * (1.0 + BOX_MARGIN) + 1e-12 * abs(centre)
    if not w < BOX_ALL:
        return BOX_ALL
    return w


@njit(cache=True)
def _first_axis_rank(x: FloatArray) -> FloatArray:
    """Every element's place in ``np.argsort(x)`` (as floats, exact): the order of the first
    coordinates, equal ones in the order of numba's (unstable) quicksort."""
    order = np.argsort(x)
    rank = np.empty(len(x))
    for q in range(len(x)):
        rank[order[q]] = q
    return rank


@njit(cache=True)
def _sort_run(idx: IntArray, val: FloatArray, lo: int, hi: int, key: FloatArray) -> bool:
    """Sort ``idx[lo:hi]`` (and ``val[lo:hi]`` alongside) by ``key[idx]``, stably, in place.

    Returns:
        Whether two of the run's keys are equal (the caller then orders it by rank).
    """
    k = hi - lo
    if k < 2:
        return False
    if k <= 32:
        for a in range(lo + 1, hi):
            v, w = idx[a], val[a]
            kv = key[v]
            b = a - 1
            while b >= lo and key[idx[b]] > kv:
                idx[b + 1], val[b + 1] = idx[b], val[b]
                b -= 1
            idx[b + 1], val[b + 1] = v, w
    else:
        keys = np.empty(k)
        for a in range(k):
            keys[a] = key[idx[lo + a]]
        perm = np.argsort(keys, kind="mergesort")
        i2, v2 = idx[lo:hi].copy(), val[lo:hi].copy()
        for a in range(k):
            idx[lo + a], val[lo + a] = i2[perm[a]], v2[perm[a]]
    tie = False
    for a in range(lo + 1, hi):
        tie |= key[idx[a]] == key[idx[a - 1]]
    return tie


@njit(cache=True)
def _in_first_axis_order(
    idx: IntArray, val: FloatArray, lo: int, hi: int, first: FloatArray, rank: FloatArray, x: FloatArray
) -> FloatArray:
    """Order the run ``idx[lo:hi]`` (points, ``val`` alongside) by ascending first coordinate
    ``first`` as ``np.argsort(x)`` lists them (``first = x``): by value, and where two are equal
    by their place in that argsort, ``rank`` (computed here on first need, else as given)."""
    if _sort_run(idx, val, lo, hi, first):
        if len(rank) != len(x):
            rank = _first_axis_rank(x)
        _sort_run(idx, val, lo, hi, rank)
    return rank


@njit(cache=True)
def _detection_grid(
    mean: FloatArray, cov: FloatArray, z: FloatArray, gate: float
) -> tuple[GridIndex, FloatArray]:
    """The spatial index of the detections ([`track_envs.infra.spatial`][track_envs.infra.spatial]) and every
    track's gate box ``h_ik = sqrt(γ S_i,kk)`` on the first ``K = min(D, 2)`` axes, widened
    ([`_widen`][agents.jpda._kernels._widen]), (n, K); the grid's cells are the median box width."""
    n, D = mean.shape
    K = min(D, 2)
    half = np.empty((n, K))
    for i in range(n):
        for k in range(K):
            half[i, k] = _widen(math.sqrt(gate * cov[i, k, k]), mean[i, k])
    cell = 2.0 * float(np.median(half)) if n else 1.0
    return build_grid(z, K, cell), half


@njit(cache=True)
def _gated_pairs(
    mean: FloatArray,
    cov: FloatArray,
    z: FloatArray,
    chol: FloatArray,
    lnorm: FloatArray,
    gate: float,
    log_ratio: float,
    grid: GridIndex,
    half: FloatArray,
    z_rank: FloatArray,
    diff: FloatArray,
    work: FloatArray,
) -> tuple[IntArray, IntArray, FloatArray, int, FloatArray]:
    """Step 1: the admissible (track, detection) pairs, ``d²_ij ≤ γ``, and their log weights.

    A pair outside the box ``|z_k − ŷ_ik| ≤ sqrt(γ S_i,kk)`` is outside the gate
    (``d² ≥ Δ_k² / S_kk``), so track ``i`` tests only the detections of its box, found in the
    grid ``grid`` (``half``: the widened boxes of [`_detection_grid`][agents.jpda._kernels._detection_grid]):
    ``O(n + m)`` for gates of bounded size. Of those it keeps the window ``ŷ_i0 − r ≤ z_0 ≤ ŷ_i0 + r``,
    ``r = sqrt(γ S_i,00)`` (the same numbers as the exact bound), then the full gate.

    Returns:
        ``(e_t, e_d, e_w, ne, z_rank)``: track, detection and ``log w_ij`` in the first ``ne``
            rows, tracks ascending, each track's detections by ascending first coordinate (equal ones
            as ``np.argsort(z[:, 0])`` lists them: ``z_rank``, computed on first need).
    """
    n, D = mean.shape
    m = z.shape[0]
    cap = 4 * (n + m) + 16
    e_t = np.empty(cap, np.int64)
    e_d = np.empty(cap, np.int64)
    e_w = np.empty(cap)
    ne = 0
    found = query_grid(grid, z, mean, half)
    zx = z[:, 0].copy()
    for i in range(n):
        reach = math.sqrt(gate * cov[i, 0, 0])
        lo_x, hi_x = mean[i, 0] - reach, mean[i, 0] + reach
        row = ne
        for q in range(found.ptr[i], found.ptr[i + 1]):
            j = found.cols[q]
            if not (zx[j] >= lo_x and zx[j] <= hi_x):
                continue
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
        z_rank = _in_first_axis_order(e_d, e_w, row, ne, zx, z_rank, zx)
    return e_t, e_d, e_w, ne, z_rank


@njit(cache=True)
def _blob_gaussian(
    mean: FloatArray,
    cov: FloatArray,
    a: int,
    b: int,
    noise_cov: FloatArray,
    area_var: float,
    mu: FloatArray,
    cm: FloatArray,
) -> None:
    """Step 2's predicted measurement of the merged blob of tracks ``a, b`` into ``mu`` and ``cm``:
    ``μ_e = ½ (ŷ_a + ŷ_b)``, ``C_e = ¼ (S_a + S_b) + ½ R + σ_w² δ δᵀ`` with ``δ = ŷ_a − ŷ_b``."""
    D = mean.shape[1]
    for r in range(D):
        mu[r] = 0.5 * (mean[a, r] + mean[b, r])
        for c in range(D):
            dr = mean[a, r] - mean[b, r]
            dc = mean[a, c] - mean[b, c]
            cm[r, c] = 0.25 * (cov[a, r, c] + cov[b, r, c]) + 0.5 * noise_cov[r, c] + area_var * dr * dc


@njit(cache=True)
def _blob_pairs(mean: FloatArray, extent: float, mergeable: NDArray[np.bool_]) -> tuple[IntArray, IntArray]:
    """Step 2's candidate pairs: mergeable tracks ``(a, b)`` predicted at most ``extent`` apart
    (``‖ŷ_a − ŷ_b‖² ≤ extent²``), found in the spatial index of the mergeable predictions with
    boxes of half-width ``extent``.

    Each pair once, ``a`` before ``b`` in ascending first coordinate (equal ones as
    ``np.argsort(ŷ[:, 0])`` lists them), the pairs in that order of ``a`` then of ``b``: the
    order of a sweep of the sorted predictions.
    """
    n, D = mean.shape
    K = min(D, 2)
    # the mergeable predictions in the grid's cell order (a counting sort): neighbouring queries
    # read neighbouring memory; the pairs are sorted below, so this order does not show
    idx = np.flatnonzero(mergeable)
    idx = idx[build_grid(mean[idx], K, 2.0 * extent).order]
    pts = np.empty((len(idx), D))
    half = np.empty((len(idx), K))
    for r in range(len(idx)):
        for d in range(D):
            pts[r, d] = mean[idx[r], d]
        for k in range(K):
            half[r, k] = _widen(extent, pts[r, k])
    found = box_candidates(pts, half, pts)
    ext2 = extent * extent
    mx = mean[:, 0].copy()
    rank = np.empty(0)
    pa = []
    pb = []
    for r in range(len(idx)):
        a = idx[r]
        for q in range(found.ptr[r], found.ptr[r + 1]):
            b = idx[found.cols[q]]
            if b == a or mx[b] < mx[a]:
                continue
            if mx[b] == mx[a]:  # as the argsort of the first coordinates lists them
                if len(rank) != n:
                    rank = _first_axis_rank(mx)
                if rank[b] < rank[a]:
                    continue
            if mx[b] - mx[a] > extent:
                continue
            dist2 = 0.0
            for d in range(D):
                dist2 += (mean[a, d] - mean[b, d]) ** 2
            if dist2 > ext2:
                continue
            pa.append(a)
            pb.append(b)
    npair = len(pa)
    first = np.empty(npair, np.int64)
    second = np.empty(npair, np.int64)
    if npair == 0:
        return first, second
    # rank the tracks of the pairs by first coordinate (argsort's rank where two are equal)
    members = np.unique(np.array(pa + pb))
    place = np.zeros(len(members))
    tie = _sort_run(members, place, 0, len(members), mx)
    if tie and len(rank) != n:
        rank = _first_axis_rank(mx)
    pos = np.empty(n, np.int64)
    for q in range(len(members)):
        pos[members[q]] = int(rank[members[q]]) if tie else q
    key = np.empty(npair, np.int64)
    for p in range(npair):
        key[p] = pos[pa[p]] * n + pos[pb[p]]
    order = np.argsort(key)
    for p in range(npair):
        first[p], second[p] = pa[order[p]], pb[order[p]]
    return first, second


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
    grid: GridIndex,
    z_rank: FloatArray,
    diff: FloatArray,
    work: FloatArray,
) -> tuple[IntArray, IntArray, IntArray, FloatArray, int, FloatArray]:
    """Step 2: the merged-blob hypotheses, every pair of mergeable tracks at most ``extent``
    apart ([`_blob_pairs`][agents.jpda._kernels._blob_pairs]) with every detection inside its blob's gate
    (none when ``extent`` is 0).

    A blob's detections are those of the box ``|z_k − μ_k| ≤ sqrt(γ C_kk)`` (the detections'
    ``grid``), in the window ``|z_0 − μ_0| ≤ sqrt(γ C_00)``, then inside the full gate; pairs in
    the order of [`_blob_pairs`][agents.jpda._kernels._blob_pairs], each pair's detections by ascending first
    coordinate (``z_rank`` as in [`_gated_pairs`][agents.jpda._kernels._gated_pairs]).

    Returns:
        ``(g_a, g_b, g_d, g_w, ng, z_rank)``: the smaller and larger track, the detection and
            ``log w_ej`` in the first ``ng`` rows.
    """
    n, D = mean.shape
    m = z.shape[0]
    K = grid.shape.shape[0]
    mcap = 16
    g_a = np.empty(mcap, np.int64)
    g_b = np.empty(mcap, np.int64)
    g_d = np.empty(mcap, np.int64)
    g_w = np.empty(mcap)
    ng = 0
    if not (extent > 0.0 and n > 1 and m > 0):
        return g_a, g_b, g_d, g_w, ng, z_rank
    pa, pb = _blob_pairs(mean, extent, mergeable)
    npair = len(pa)
    mu = np.zeros((npair, D))
    cls = np.zeros((npair, D, D))
    half = np.zeros((npair, K))
    lnorm = np.zeros(npair)
    reach = np.zeros(npair)
    cm = np.zeros((D, D))
    for p in range(npair):
        _blob_gaussian(mean, cov, pa[p], pb[p], noise_cov, area_var, mu[p], cm)
        if not cholesky_lower(cm, cls[p]):
            mu[p, 0] = np.nan  # no gate: no detection in its box
            continue
        lnorm[p] = _log_norm(cls[p])
        reach[p] = math.sqrt(gate * cm[0, 0])
        for k in range(K):
            half[p, k] = _widen(math.sqrt(gate * cm[k, k]), mu[p, k])
    found = query_grid(grid, z, mu, half)
    zx = z[:, 0].copy()
    for p in range(npair):
        a, b = pa[p], pb[p]
        lo, hi = (a, b) if a < b else (b, a)
        lo_x, hi_x = mu[p, 0] - reach[p], mu[p, 0] + reach[p]
        row = ng
        for q in range(found.ptr[p], found.ptr[p + 1]):
            j = found.cols[q]
            if not (zx[j] >= lo_x and zx[j] <= hi_x):
                continue
            for d in range(D):
                diff[d] = z[j, d] - mu[p, d]
            d2 = _mahalanobis(cls[p], diff, work)
            if d2 <= gate:
                if ng == len(g_a):
                    g_a = np.concatenate((g_a, np.empty(len(g_a), np.int64)))
                    g_b = np.concatenate((g_b, np.empty(len(g_b), np.int64)))
                    g_d = np.concatenate((g_d, np.empty(len(g_d), np.int64)))
                    g_w = np.concatenate((g_w, np.empty(len(g_w))))
                g_a[ng], g_b[ng], g_d[ng] = lo, hi, j
                g_w[ng] = log_ratio + log_merge_odds - 0.5 * d2 + lnorm[p]
                ng += 1
        z_rank = _in_first_axis_order(g_d, g_w, row, ng, zx, z_rank, zx)
    return g_a, g_b, g_d, g_w, ng, z_rank


@njit(cache=True)
def _roots(
    n: int,
    m: int,
    e_t: IntArray,
    e_d: IntArray,
    ne: int,
    g_a: IntArray,
    g_b: IntArray,
    g_d: IntArray,
    ng: int,
) -> IntArray:
    """Step 3's union–find over the ``n`` tracks and ``m`` detections (node ``n + j``) linked by
    an admissible pair or a merged-blob hypothesis: the (n + m,) root of every node."""
    parent = np.arange(n + m)
    for k in range(ne):
        _union(parent, e_t[k], n + e_d[k])
    for k in range(ng):
        _union(parent, g_a[k], n + g_d[k])
        _union(parent, g_b[k], n + g_d[k])
    root = np.empty(n + m, np.int64)
    for v in range(n + m):
        root[v] = _find(parent, v)
    return root


@njit(cache=True)
def _clusters(root: IntArray, n: int) -> _Clusters:
    """Step 3's clusters that hold a track (of the components ``root`` of ``n`` tracks and the
    detections after them), labelled in order of their smallest track, with their members."""
    nv = len(root)
    label = np.full(nv, -1, np.int64)
    n_cl = 0
    for i in range(n):
        r = root[i]
        if label[r] < 0:
            label[r] = n_cl
            n_cl += 1
    c_nt = np.zeros(n_cl, np.int64)
    c_nd = np.zeros(n_cl, np.int64)
    local = np.empty(nv, np.int64)
    for v in range(nv):
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
    for v in range(nv):
        lab = label[root[v]]
        if lab < 0:
            continue
        if v < n:
            t_of[t_start[lab] + local[v]] = v
        else:
            d_of[d_start[lab] + local[v]] = v - n
    return _Clusters(root, label, c_nt, c_nd, local, t_start, d_start, t_of, d_of)


@njit(cache=True)
def _big_tracks(cl: _Clusters, max_exact: int) -> IntArray:
    """The tracks of the clusters of more than ``max_exact`` tracks, cluster by cluster."""
    n_big = 0
    for c in range(len(cl.c_nt)):
        if cl.c_nt[c] > max_exact:
            n_big += cl.c_nt[c]
    big = np.empty(n_big, np.int64)
    nb = 0
    for c in range(len(cl.c_nt)):
        if cl.c_nt[c] > max_exact:
            for q in range(cl.c_nt[c]):
                big[nb] = cl.t_of[cl.t_start[c] + q]
                nb += 1
    return big


@njit(cache=True)
def _cluster_weights(
    c: int,
    cl: _Clusters,
    n: int,
    e_start: IntArray,
    e_ord: IntArray,
    e_t: IntArray,
    e_d: IntArray,
    e_w: FloatArray,
    g_start: IntArray,
    g_ord: IntArray,
    g_a: IntArray,
    g_b: IntArray,
    g_d: IntArray,
    g_w: FloatArray,
    L: FloatArray,
    ma: IntArray,
    mb: IntArray,
    md: IntArray,
    mw: FloatArray,
) -> None:
    """Cluster ``c``'s inputs of step 4 in local indices: its log pair weights into ``L``
    (nc, mc) (−inf outside the gate) and its merged hypotheses into ``ma, mb, md, mw`` (the
    first ``len(ma)`` of its run)."""
    L[:] = -np.inf
    for q in range(e_start[c], e_start[c + 1]):
        k = e_ord[q]
        L[cl.local[e_t[k]], cl.local[n + e_d[k]]] = e_w[k]
    for q in range(len(ma)):
        k = g_ord[g_start[c] + q]
        ma[q], mb[q], md[q], mw[q] = cl.local[g_a[k]], cl.local[g_b[k]], cl.local[n + g_d[k]], g_w[k]


@njit(cache=True)
def _cluster_mixtures(
    tracks: IntArray,
    dets: IntArray,
    P: FloatArray,
    PM: FloatArray,
    ma: IntArray,
    mb: IntArray,
    md: IntArray,
    mean: FloatArray,
    anchor: FloatArray,
    z: FloatArray,
    mergeable: NDArray[np.bool_],
    p_seen: FloatArray,
    z_mean: FloatArray,
    z_spread: FloatArray,
    best: IntArray,
    best_prob: FloatArray,
    merged_with: IntArray,
    settled: FloatArray,
    hyp_w: FloatArray,
    diff: FloatArray,
    work: FloatArray,
) -> None:
    """Step 5 for the tracks of one cluster from its marginals ``P`` (pairs) and ``PM`` (merged
    hypotheses ``ma, mb, md``, local indices): the mixture's mean in a first pass, its centred
    spread in a second; the first pass also adds to ``settled`` and keeps the best hypothesis.
    A merged blob's pseudo-measurement for member ``i`` with partner ``k`` is
    ``z_j + ½(anchor_i − anchor_k)`` (step 5)."""
    D = z.shape[1]
    for pass_ in range(2):
        for q in range(len(tracks)):
            i = tracks[q]
            if pass_ == 0:
                hyp_w[i] = 0.0
                for d in range(D):
                    z_mean[i, d] = 0.0
            for r in range(len(dets)):
                w = P[q, r]
                if w <= 0.0:
                    continue
                j = dets[r]
                _accumulate(pass_, i, w, z[j], z_mean, z_spread, hyp_w, diff, D)
                if pass_ == 0 and mergeable[i]:
                    settled[j] += w
                if pass_ == 0 and w > best_prob[i]:
                    best_prob[i], best[i], merged_with[i] = w, j, -1
            for h in range(len(ma)):
                if ma[h] != q and mb[h] != q:
                    continue
                w = PM[h]
                if w <= 0.0:
                    continue
                k = tracks[mb[h] if ma[h] == q else ma[h]]
                j = dets[md[h]]
                for d in range(D):
                    work[d] = z[j, d] + 0.5 * (anchor[i, d] - anchor[k, d])
                _accumulate(pass_, i, w, work, z_mean, z_spread, hyp_w, diff, D)
                if pass_ == 0 and ma[h] == q:
                    settled[j] += w  # once per blob (both members are settled)
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


@njit(cache=True)
def _associate_clusters(
    mean: FloatArray,
    anchor: FloatArray,
    z: FloatArray,
    log_miss: float,
    max_exact: int,
    mergeable: NDArray[np.bool_],
    cl: _Clusters,
    e_t: IntArray,
    e_d: IntArray,
    e_w: FloatArray,
    ne: int,
    g_a: IntArray,
    g_b: IntArray,
    g_d: IntArray,
    g_w: FloatArray,
    ng: int,
    p_seen: FloatArray,
    z_mean: FloatArray,
    z_spread: FloatArray,
    best: IntArray,
    best_prob: FloatArray,
    merged_with: IntArray,
    clutter: FloatArray,
    settled: FloatArray,
    diff: FloatArray,
    work: FloatArray,
) -> None:
    """Steps 4 and 5 for every cluster of at most ``max_exact`` tracks that holds a detection,
    into the frame's outputs: a lone track without merged blobs in closed form
    ([`_single_track`][agents.jpda._kernels._single_track]), any other cluster by its exact marginals
    ([`_cluster_marginals`][agents.jpda._kernels._cluster_marginals]), then the mixture of each of its
    tracks."""
    n = mean.shape[0]
    n_cl = len(cl.c_nt)
    c_nt, c_nd, t_of, t_start, d_of, d_start = cl.c_nt, cl.c_nd, cl.t_of, cl.t_start, cl.d_of, cl.d_start
    e_start, e_ord = _by_cluster(cl.label, cl.root, e_t[:ne], n_cl)
    g_start, g_ord = _by_cluster(cl.label, cl.root, g_a[:ng], n_cl)
    hyp_w = np.zeros(n)
    # scratch of the multi-track clusters, sized once per frame (views per cluster, no allocation)
    nc_max, mc_max, ge_max = 1, 1, 1
    for c in range(n_cl):
        if c_nt[c] <= max_exact:
            nc_max = max(nc_max, c_nt[c])
            mc_max = max(mc_max, c_nd[c])
            ge_max = max(ge_max, g_start[c + 1] - g_start[c])
    L_buf = np.empty((nc_max, mc_max))
    P_buf = np.empty((nc_max, mc_max))
    PC_buf = np.empty(mc_max)
    ma_buf = np.empty(ge_max, np.int64)
    mb_buf = np.empty(ge_max, np.int64)
    md_buf = np.empty(ge_max, np.int64)
    mw_buf = np.empty(ge_max)
    PM_buf = np.empty(ge_max)
    for c in range(n_cl):
        nc, mc = c_nt[c], c_nd[c]
        if nc > max_exact or mc == 0:
            continue
        tracks, dets = t_of[t_start[c] : t_start[c + 1]], d_of[d_start[c] : d_start[c + 1]]
        if nc == 1 and g_start[c + 1] == g_start[c]:
            _single_track(
                tracks[0], e_ord[e_start[c] : e_start[c + 1]], e_d, e_w, log_miss, z,
                p_seen, z_mean, z_spread, best, best_prob, clutter, diff, settled, mergeable[tracks[0]],
            )  # fmt: skip
            continue
        ge = g_start[c + 1] - g_start[c]
        if nc > MAX_MERGE_CLUSTER:
            ge = 0  # the 2^nc masks of every detection's merged blobs: drop them (module docstring)
        L, ma, mb, md, mw = L_buf[:nc, :mc], ma_buf[:ge], mb_buf[:ge], md_buf[:ge], mw_buf[:ge]
        _cluster_weights(
            c, cl, n, e_start, e_ord, e_t, e_d, e_w, g_start, g_ord, g_a, g_b, g_d, g_w, L, ma, mb, md, mw
        )
        P, PM, PC = P_buf[:nc, :mc], PM_buf[:ge], PC_buf[:mc]
        P[:] = 0.0
        PM[:] = 0.0
        PC[:] = 0.0
        if not _cluster_marginals(L, log_miss, ma, mb, md, mw, P, PM, PC):
            # p_D P_G = 1 and the tracks cannot all take a detection: leave them undetected
            continue
        for q in range(mc):
            clutter[dets[q]] = PC[q]
        _cluster_mixtures(
            tracks, dets, P, PM, ma, mb, md, mean, anchor, z, mergeable,
            p_seen, z_mean, z_spread, best, best_prob, merged_with, settled, hyp_w, diff, work,
        )  # fmt: skip


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
    mergeable: NDArray[np.bool_],
) -> JpdaFrame:
    """[`jpda_frame_anchored`][agents.jpda._kernels.jpda_frame_anchored] with the predictions as the merged
    blobs' anchors: each member of a blob keeps its predicted offset from the pair's centre."""
    return jpda_frame_anchored(
        mean, cov, z, gate, log_ratio, log_miss, extent, noise_cov, area_var, log_merge_odds,
        max_exact, mergeable, mean,
    )  # fmt: skip


@njit(cache=True)
def jpda_frame_anchored(
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
    anchor: FloatArray,
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
        mergeable: (n,) the tracks that may form a merged blob.
        anchor: (n, D) the points whose offsets a merged blob's members keep (step 5): ``mean``
            (the predictions), or the tracks' last estimates (a rigid pair).
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
    settled = np.zeros(m)
    bad = _track_factors(cov, chol, lnorm)
    if bad >= 0:
        return JpdaFrame(
            p_seen, z_mean, z_spread, best, best_prob, merged_with, clutter, np.zeros(m),
            np.zeros(0, np.int64), np.zeros(n, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64),
            FRAME_NOT_PD, bad,
        )  # fmt: skip
    grid, half = _detection_grid(mean, cov, z, gate)
    e_t, e_d, e_w, ne, z_rank = _gated_pairs(
        mean, cov, z, chol, lnorm, gate, log_ratio, grid, half, np.empty(0), diff, work
    )
    g_a, g_b, g_d, g_w, ng, _ = _merged_hypotheses(
        mean, cov, z, gate, log_ratio, extent, noise_cov, area_var, log_merge_odds, mergeable,
        grid, z_rank, diff, work,
    )  # fmt: skip
    cl = _clusters(_roots(n, m, e_t, e_d, ne, g_a, g_b, g_d, ng), n)
    cluster_of = np.empty(n, np.int64)
    for i in range(n):
        cluster_of[i] = cl.label[cl.root[i]]
    _associate_clusters(
        mean, anchor, z, log_miss, max_exact, mergeable, cl, e_t, e_d, e_w, ne, g_a, g_b, g_d, g_w, ng,
        p_seen, z_mean, z_spread, best, best_prob, merged_with, clutter, settled, diff, work,
    )  # fmt: skip
    return JpdaFrame(
        p_seen, z_mean, z_spread, best, best_prob, merged_with, clutter, settled,
        cl.c_nt, cluster_of, cl.c_nd, _big_tracks(cl, max_exact), FRAME_OK, -1,
    )  # fmt: skip


@njit(cache=True)
def _by_cluster(label: IntArray, root: IntArray, owner: IntArray, n_cl: int) -> tuple[IntArray, IntArray]:
    """Hypotheses grouped by the cluster of their track ``owner`` (a counting sort): the start of
    every cluster's run (n_cl + 1,) and the hypotheses in cluster order (stable)."""
    start = np.zeros(n_cl + 1, np.int64)
    for k in range(len(owner)):
        start[label[root[owner[k]]] + 1] += 1
    for c in range(n_cl):
        start[c + 1] += start[c]
    order = np.empty(len(owner), np.int64)
    fill = start[:-1].copy()
    for k in range(len(owner)):
        c = label[root[owner[k]]]
        order[fill[c]] = k
        fill[c] += 1
    return start, order


@njit(cache=True)
def _single_track(
    i: int,
    edges: IntArray,
    e_d: IntArray,
    e_w: FloatArray,
    log_miss: float,
    z: FloatArray,
    p_seen: FloatArray,
    z_mean: FloatArray,
    z_spread: FloatArray,
    best: IntArray,
    best_prob: FloatArray,
    clutter: FloatArray,
    diff: FloatArray,
    settled: FloatArray,
    is_settled: bool,
) -> None:
    """A cluster of one track and no merged blob (Bar-Shalom's PDA in closed form):
    ``β_j = w_j / (w_∅ + Σ_k w_k)``, each detection clutter with ``1 − β_j``; the mixture
    of step 5 written for track ``i``."""
    D = z.shape[1]
    top = log_miss
    for q in range(len(edges)):
        if e_w[edges[q]] > top:
            top = e_w[edges[q]]
    total = math.exp(log_miss - top) if log_miss > -np.inf else 0.0
    for q in range(len(edges)):
        total += math.exp(e_w[edges[q]] - top)
    p = 0.0
    for d in range(D):
        z_mean[i, d] = 0.0
    for q in range(len(edges)):
        k = edges[q]
        w = math.exp(e_w[k] - top) / total
        j = e_d[k]
        clutter[j] = 1.0 - w
        if is_settled:
            settled[j] += w
        p += w
        for d in range(D):
            z_mean[i, d] += w * z[j, d]
        if w > best_prob[i]:
            best_prob[i], best[i] = w, j
    p_seen[i] = p
    if not p > 0.0:  # every detection e^-700 below the miss: coasts
        for d in range(D):
            z_mean[i, d] = z[e_d[edges[0]], d]
        return
    for d in range(D):
        z_mean[i, d] /= p
    for q in range(len(edges)):
        k = edges[q]
        w = math.exp(e_w[k] - top) / total / p
        j = e_d[k]
        for d in range(D):
            diff[d] = z[j, d] - z_mean[i, d]
        for r in range(D):
            for t in range(D):
                z_spread[i, r, t] += w * diff[r] * diff[t]


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


class BlobSplits(NamedTuple):
    """Result of [`split_blobs`][agents.jpda._kernels.split_blobs]: one row per split (ascending track).

    Attributes:
        track: the track whose blob fell apart.
        keep: the piece it follows (the nearer one to its prediction).
        other: the piece left for a new track.
        midpoint: (k, D) the pieces' midpoint, the blob's centroid the track is updated with.
    """

    track: IntArray
    keep: IntArray
    other: IntArray
    midpoint: FloatArray


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
    """The admissible split hypotheses of [`split_blobs`][agents.jpda._kernels.split_blobs]:
    ``(track, j, k, d²)`` for every unseen track and pair of free detections ``j < k`` that pass the gate, in
    ascending track, then ``j``, then ``k``.

    Both pieces come from spatial indexes of the free detections
    ([`track_envs.infra.spatial`][track_envs.infra.spatial]):
    the first piece ``j`` of track ``i`` lies within ``extent`` of ``ŷ_i`` on the first axis (the
    hypothesis's condition), and on the second within ``sqrt(γ C̄_11) + extent / 2`` with
    ``C̄_11 = S_i,11 − ½ R_11 + σ_w² extent²`` (the midpoint's gate, ``d² ≥ (c_1 − ŷ_1)² / C_11``
    and ``C_11 ≤ C̄_11``, and ``|z_j1 − c_1| = |Δ_1| / 2``); the second piece ``k`` lies within
    ``extent`` of ``j`` on both axes. A frame costs ``O(n + m)`` for gates of bounded size.
    """
    D = mean.shape[1]
    K = min(D, 2)
    cand_t = np.empty(0, np.int64)
    cand_j = np.empty(0, np.int64)
    cand_k = np.empty(0, np.int64)
    cand_d = np.empty(0)
    C = np.zeros((D, D))
    Lc = np.zeros((D, D))
    diff = np.zeros(D)
    work = np.zeros(D)
    if not extent >= 0.0:
        return cand_t, cand_j, cand_k, cand_d
    free_idx = np.flatnonzero(free)
    tracks = np.flatnonzero(unseen)
    nf = len(free_idx)
    zf = np.empty((nf, D))
    near_half = np.empty((nf, K))
    for a in range(nf):
        for d in range(D):
            zf[a, d] = z[free_idx[a], d]
        for k in range(K):
            near_half[a, k] = _widen(extent, zf[a, k])
    centres = np.empty((len(tracks), D))
    first_half = np.empty((len(tracks), K))
    spread = max(area_var, 0.0) * extent * extent
    for r in range(len(tracks)):
        i = tracks[r]
        for d in range(D):
            centres[r, d] = mean[i, d]
        first_half[r, 0] = _widen(extent, centres[r, 0])
        for k in range(1, K):
            c_kk = max(cov[i, k, k] - 0.5 * noise_cov[k, k] + spread, 0.0)
            first_half[r, k] = _widen(math.sqrt(gate * c_kk) + 0.5 * extent, centres[r, k])
    first = box_candidates(centres, first_half, zf)
    near = box_candidates(zf, near_half, zf)
    ts = []
    js = []
    ks = []
    ds = []
    for r in range(len(tracks)):
        i = tracks[r]
        for qa in range(first.ptr[r], first.ptr[r + 1]):
            a = first.cols[qa]
            j = free_idx[a]
            if abs(z[j, 0] - mean[i, 0]) > extent:
                continue
            for qb in range(near.ptr[a], near.ptr[a + 1]):
                b = near.cols[qb]
                if b <= a:
                    continue
                k = free_idx[b]
                sep2 = 0.0
                for d in range(D):
                    sep2 += (z[j, d] - z[k, d]) ** 2
                if sep2 > extent * extent:
                    continue
                for r2 in range(D):
                    diff[r2] = 0.5 * (z[j, r2] + z[k, r2]) - mean[i, r2]
                    for c in range(D):
                        C[r2, c] = (
                            cov[i, r2, c]
                            - 0.5 * noise_cov[r2, c]
                            + area_var * (z[j, r2] - z[k, r2]) * (z[j, c] - z[k, c])
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
def _greedy_splits(
    mean: FloatArray,
    z: FloatArray,
    cand_t: IntArray,
    cand_j: IntArray,
    cand_k: IntArray,
    cand_d: FloatArray,
) -> tuple[IntArray, IntArray, IntArray]:
    """The candidates of [`_split_candidates`][agents.jpda._kernels._split_candidates] taken greedily by
    ascending ``d²`` (stable), each track and detection once: ``(track, keep, other)`` in ascending track,
    ``keep`` the piece nearer to the track's prediction (the first on a tie)."""
    n, D = mean.shape
    m = z.shape[0]
    order = np.argsort(cand_d, kind="mergesort")
    used_t = np.zeros(n, np.bool_)
    used_d = np.zeros(m, np.bool_)
    out_t = []
    out_keep = []
    out_other = []
    for q in order:
        i, j, k = cand_t[q], cand_j[q], cand_k[q]
        if used_t[i] or used_d[j] or used_d[k]:
            continue
        used_t[i] = used_d[j] = used_d[k] = True
        dj = 0.0
        dk = 0.0
        for d in range(D):
            dj += (z[j, d] - mean[i, d]) ** 2
            dk += (z[k, d] - mean[i, d]) ** 2
        out_t.append(i)
        out_keep.append(j if dj <= dk else k)
        out_other.append(k if dj <= dk else j)
    ns = len(out_t)
    track = np.empty(ns, np.int64)
    keep = np.empty(ns, np.int64)
    other = np.empty(ns, np.int64)
    for q in range(ns):
        track[q], keep[q], other[q] = out_t[q], out_keep[q], out_other[q]
    order2 = np.argsort(track)
    return track[order2], keep[order2], other[order2]


@njit(cache=True)
def split_blobs(
    mean: FloatArray,
    cov: FloatArray,
    z: FloatArray,
    unseen: NDArray[np.bool_],
    free: NDArray[np.bool_],
    gate: float,
    noise_cov: FloatArray,
    area_var: float,
    extent: float,
) -> BlobSplits:
    r"""Blobs that fell apart: a track that took no detection, and two free detections whose
    midpoint its prediction explains.

    A track may have followed a blob of touching particles; when they separate, its detection
    becomes two pieces whose area-weighted centroid is where the blob would have been. For an
    unseen track ``i`` and free detections ``j, k`` at most ``extent`` apart, with ``Δ = z_j − z_k``
    and midpoint ``c = ½ (z_j + z_k)``, the hypothesis is admissible when

    .. math::

        (c - ŷ_i)^\top C^{-1} (c - ŷ_i) \le γ, \qquad
        C = S_i - \tfrac12 R + σ_w^2 Δ Δ^\top

    (``S_i − R`` the position's uncertainty, ``R/2`` the midpoint's noise, ``σ_w²`` the area
    split). Admissible hypotheses are taken greedily by that distance, each track and detection
    once.
    """
    D = mean.shape[1]
    cand_t, cand_j, cand_k, cand_d = _split_candidates(
        mean, cov, z, unseen, free, gate, noise_cov, area_var, extent
    )
    track, keep, other = _greedy_splits(mean, z, cand_t, cand_j, cand_k, cand_d)
    ns = len(track)
    midpoint = np.empty((ns, D))
    for q in range(ns):
        for d in range(D):
            midpoint[q, d] = 0.5 * (z[keep[q], d] + z[other[q], d])
    return BlobSplits(track, keep, other, midpoint)
