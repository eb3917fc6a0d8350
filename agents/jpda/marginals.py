r"""Marginal association probabilities of JPDA for a whole frame.

For tracks ``i`` and detections ``j`` with the joint-event weights of
[`agents.jpda.weights`][agents.jpda.weights],

.. math::

    β_{ij} = \sum_{θ \ni (i,j)} P(θ \mid Z), \qquad
    β_{i∅} = \sum_{θ:\ i \text{ missed}} P(θ \mid Z), \qquad
    β_{∅j} = \sum_{θ:\ j \text{ clutter}} P(θ \mid Z)

(Fortmann, Bar-Shalom, Scheffe: Sonar tracking of multiple targets using joint probabilistic
data association, 1983); ``Σ_j β_ij + β_i∅ = 1`` for every track and
``Σ_i β_ij + β_∅j = 1`` for every detection.

The events factorise over the gating clusters ([`agents.jpda.clusters`][agents.jpda.clusters]). Clusters of
one track are the PDA filter's closed form, all at once. Any other cluster of
``n`` tracks and ``m`` detections is computed exactly ([`agents.jpda.exact`][agents.jpda.exact], bitmask over
the smaller side, ``O(max(n,m) · k · 2^k)`` for ``k = min(n, m)``) when ``k <= max_exact``;
clusters go through the recursion together, one batch per bitmask width (``k`` of 1–2 padded
to 2 rows, 3–4 to 4, larger ``k`` as they are; padded rows and columns never match). Beyond
that bound a cluster of several tracks is approximated by loopy belief propagation
([`agents.jpda.lbp`][agents.jpda.lbp], Williams and Lau 2014) and its tracks are flagged ``exact = False``;
the error of that approximation, measured against the exact marginals, is pinned in
``tests/agents/jpda/test_jpda_lbp.py`` (max |Δβ| up to 0.19 on random 8-target frames, median
0.02–0.05: a fallback, not a substitute).

Accuracy: equal to brute-force enumeration of the joint events to 1e-13 (tests) and to Stone
Soup 1.9.1's ``JPDA`` / ``JPDAwithEHM`` to 4.4e-16 on the same Gaussians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agents.jpda.clusters import GateClusters, gate_clusters
from agents.jpda.exact import exact_marginals, logsumexp
from agents.jpda.lbp import lbp_marginals
from agents.jpda.weights import EventWeights, jpda_log_weights

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

#: Default largest ``min(n_tracks, n_detections)`` of a cluster computed exactly (2^12 masks).
MAX_EXACT = 12


@dataclass(frozen=True)
class Marginals:
    """JPDA marginal association probabilities of one frame.

    Attributes:
        pairs: (n_tracks, n_detections) ``β_ij``.
        miss: (n_tracks,) ``β_i∅``, track ``i`` not detected (or outside its gate).
        clutter: (n_detections,) ``β_∅j``, detection ``j`` from clutter.
        exact: (n_tracks,) whether the track's cluster was computed exactly (else by loopy
            belief propagation).
    """

    pairs: FloatArray
    miss: FloatArray
    clutter: FloatArray
    exact: NDArray[np.bool_]

    @property
    def beta(self) -> FloatArray:
        """(n_tracks, n_detections + 1): ``β_ij`` with ``β_i∅`` as the last column."""
        return np.concatenate([self.pairs, self.miss[:, None]], axis=1)


def _rank_in_cluster(labels: IntArray, n_clusters: int) -> IntArray:
    """Position of every vertex among the vertices of its cluster, in index order."""
    order = np.argsort(labels, kind="stable")
    start = np.concatenate([[0], np.cumsum(np.bincount(labels, minlength=n_clusters))[:-1]])
    rank = np.empty(len(labels), dtype=np.intp)
    rank[order] = np.arange(len(labels)) - start[labels[order]]
    return rank


def _members(labels: IntArray, rank: IntArray, batch_of: IntArray, B: int, width: int) -> IntArray:
    """(B, width) vertex ids of the batched clusters, -1 for padding."""
    out = np.full((B, max(width, 0)), -1, dtype=np.intp)
    sel = np.flatnonzero(batch_of[labels] >= 0)
    out[batch_of[labels[sel]], rank[sel]] = sel
    return out


def _single_track(
    lp: FloatArray, lm: FloatArray, rows: IntArray, pairs: FloatArray, miss: FloatArray, clutter: FloatArray
) -> None:
    """Clusters of one track (Bar-Shalom's PDA): ``β_ij = w_ij / (w_i∅ + Σ_j' w_ij')``, all rows at once.

    Each of their detections is gated to this track only, so ``β_∅j = 1 − β_ij``.
    """
    scores = np.concatenate([lp[rows], lm[rows, None]], axis=1)
    log_z = logsumexp(scores, axis=1)
    beta = np.exp(scores - log_z[:, None])
    pairs[rows] = beta[:, :-1]
    miss[rows] = beta[:, -1]
    r, c = np.nonzero(np.isfinite(lp[rows]))
    clutter[c] = 1.0 - beta[r, c]


def _exact_batch(
    lp: FloatArray,
    lm: FloatArray,
    T: IntArray,
    D: IntArray,
    flip: NDArray[np.bool_],
    K: int,
    pairs: FloatArray,
    miss: FloatArray,
    clutter: FloatArray,
) -> None:
    """Exact marginals of a batch of clusters, the smaller side of each as the bitmask rows.

    ``T``, ``D`` (B, W): track and detection ids of each cluster (-1 padding). Where ``flip`` the
    detections are the rows (``u = 0``) and the tracks the columns (``v = log w_i∅``); padded
    rows and columns have no pairs and unmatched weight 1.
    """
    fl = flip[:, None]
    R = np.where(fl, D, T)[:, :K]
    C = np.where(fl, T, D)
    rv, cv = R >= 0, C >= 0
    tr = np.where(fl[:, :, None], C[:, None, :], R[:, :, None])  # track of pair (b, r, c)
    de = np.where(fl[:, :, None], R[:, :, None], C[:, None, :])  # detection of pair (b, r, c)
    both = rv[:, :, None] & cv[:, None, :]
    L = np.where(both, lp[np.maximum(tr, 0), np.maximum(de, 0)], -np.inf)
    top = len(lm) - 1
    u = np.where(rv & ~fl, lm[np.clip(R, 0, top)], 0.0)
    v = np.where(cv & fl, lm[np.clip(C, 0, top)], 0.0)
    P, Pu, Pv, log_z = exact_marginals(L, u, v)
    if not np.all(np.isfinite(log_z)):
        raise _no_event(np.sort(T[int(np.argmin(np.isfinite(log_z)))]))
    b, r, c = np.nonzero(both)
    pairs[tr[b, r, c], de[b, r, c]] = P[b, r, c]
    for ids, valid, prob, is_track in ((R, rv, Pu, ~fl), (C, cv, Pv, fl)):
        t_sel, d_sel = valid & is_track, valid & ~is_track
        miss[ids[t_sel]] = prob[t_sel]
        clutter[ids[d_sel]] = prob[d_sel]


def _no_event(tracks: IntArray) -> ValueError:
    return ValueError(
        f"no joint event has positive weight in the cluster of tracks {tracks.tolist()}: with "
        "p_detect * p_gate = 1 every track must take a detection, and these cannot all"
    )


def association_marginals(weights: EventWeights, *, max_exact: int = MAX_EXACT) -> Marginals:
    """``β_ij``, ``β_i∅`` and ``β_∅j`` of every track and detection of a frame.

    Args:
        weights: the log joint-event weights
            ([`agents.jpda.weights.jpda_log_weights`][agents.jpda.weights.jpda_log_weights]).
        max_exact: clusters with ``min(n_tracks, n_detections) <= max_exact`` are exact (and
            clusters of one track always).

    Raises:
        ValueError: if ``max_exact < 0``, or if some cluster has no joint event of positive
            weight (possible only with ``p_D P_G = 1``).
    """
    if max_exact < 0:
        raise ValueError(f"max_exact must be >= 0, got {max_exact!r}")
    lp, lm = weights.log_pair, weights.log_miss
    n, m = lp.shape
    clusters: GateClusters = gate_clusters(np.isfinite(lp))
    nc = clusters.n_clusters
    tl, dl = clusters.track_cluster, clusters.detection_cluster
    n_t, n_d = clusters.n_tracks(), clusters.n_detections()
    k = np.minimum(n_t, n_d)
    pairs = np.zeros((n, m))
    miss = np.ones(n)
    clutter = np.ones(m)
    exact = np.ones(n, dtype=bool)
    lonely = (n_d[tl] == 0) & ~np.isfinite(lm)
    if lonely.any():
        raise _no_event(np.flatnonzero(lonely)[:1])
    lone = np.flatnonzero((n_t[tl] == 1) & (n_d[tl] > 0))
    if len(lone):
        _single_track(lp, lm, lone, pairs, miss, clutter)
    t_rank, d_rank = _rank_in_cluster(tl, nc), _rank_in_cluster(dl, nc)
    multi = (n_t > 1) & (k > 0) & (k <= max_exact)
    width = np.where(k <= 2, 2, np.where(k <= 4, 4, k))  # few batches: pad small clusters
    for K in np.unique(width[multi]):
        group = np.flatnonzero(multi & (width == K))
        batch_of = np.full(nc, -1, dtype=np.intp)
        batch_of[group] = np.arange(len(group))
        W = int(max(n_t[group].max(), n_d[group].max()))
        T = _members(tl, t_rank, batch_of, len(group), W)
        D = _members(dl, d_rank, batch_of, len(group), W)
        _exact_batch(lp, lm, T, D, n_t[group] > n_d[group], int(K), pairs, miss, clutter)
    for label in np.flatnonzero((n_t > 1) & (k > max_exact)):
        tracks, dets = np.flatnonzero(tl == label), np.flatnonzero(dl == label)
        p, mi, cl = lbp_marginals(lp[np.ix_(tracks, dets)], lm[tracks])
        pairs[np.ix_(tracks, dets)] = p
        miss[tracks], clutter[dets], exact[tracks] = mi, cl, False
    return Marginals(pairs, miss, clutter, exact)


def jpda_marginals(
    log_likelihood: NDArray[np.floating],
    gate: NDArray[np.bool_],
    p_detect: float,
    clutter_density: float,
    p_gate: float = 1.0,
    *,
    max_exact: int = MAX_EXACT,
) -> Marginals:
    """[`association_marginals`][agents.jpda.marginals.association_marginals] of
    [`agents.jpda.weights.jpda_log_weights`][agents.jpda.weights.jpda_log_weights]."""
    weights = jpda_log_weights(log_likelihood, gate, p_detect, clutter_density, p_gate)
    return association_marginals(weights, max_exact=max_exact)


def cluster_marginals(log_pair: NDArray[np.floating], log_miss: NDArray[np.floating]) -> Marginals:
    """Exact marginals of one set of tracks and detections taken as a single cluster.

    Args:
        log_pair: (n, m) ``log w_ij`` (``-inf`` outside the gate).
        log_miss: (n,) ``log w_i∅``.

    Raises:
        ValueError: on a shape mismatch, NaN weights, or when no event has positive weight.
    """
    lp = np.asarray(log_pair, dtype=np.float64)
    lm = np.asarray(log_miss, dtype=np.float64)
    if lp.ndim != 2 or lm.shape != (lp.shape[0],):
        raise ValueError(f"need log_pair (n, m) and log_miss (n,), got {lp.shape} and {lm.shape}")
    if np.isnan(lp).any() or np.isnan(lm).any():
        raise ValueError("log_pair and log_miss must not contain NaN")
    P, Pu, Pv, log_z = exact_marginals(lp[None], lm[None], np.zeros((1, lp.shape[1])))
    if not np.isfinite(log_z[0]):
        raise _no_event(np.arange(lp.shape[0]))
    return Marginals(P[0], Pu[0], Pv[0], np.ones(lp.shape[0], dtype=bool))


@dataclass(frozen=True)
class MergedMarginals:
    """Marginals of one cluster whose joint events include merged blobs.

    Attributes:
        pairs: (n_tracks, n_detections) ``β_ij``, track ``i`` alone takes detection ``j``.
        miss: (n_tracks,) ``β_i∅``.
        clutter: (n_detections,) ``β_∅j``.
        merged: (n_merges,) ``β_e``, the pair of hypothesis ``e`` takes its detection as one blob.
    """

    pairs: FloatArray
    miss: FloatArray
    clutter: FloatArray
    merged: FloatArray


def merged_cluster_marginals(
    log_pair: NDArray[np.floating],
    log_miss: float,
    merges: NDArray[np.integer],
    log_merged: NDArray[np.floating],
) -> MergedMarginals:
    """Exact marginals of one cluster with merged-blob hypotheses
    ([`agents.jpda._kernels`][agents.jpda._kernels]).

    A joint event gives every track a detection of its gate, a merged blob (hypothesis
    ``e = (a, b, j)``: tracks ``a`` and ``b`` both take detection ``j``) or a miss, no detection
    twice; its weight is the product of the ``exp(log_pair)``, ``exp(log_merged)`` and
    ``exp(log_miss)`` factors it uses.

    Args:
        log_pair: (n, m) ``log w_ij`` (``-inf`` outside the gate), ``n <= 20``.
        log_miss: ``log w_∅`` of every track (``-inf`` allowed).
        merges: (e, 3) integer rows ``(a, b, j)``, ``a != b``.
        log_merged: (e,) their log weights.

    Raises:
        ValueError: naming a bad shape, index or value, or when no event has positive weight.
    """
    from agents.jpda._kernels import _cluster_marginals

    lp = np.ascontiguousarray(log_pair, dtype=np.float64)
    if lp.ndim != 2 or lp.shape[0] > 20:
        raise ValueError(f"log_pair must be (n, m) with n <= 20 tracks, got shape {lp.shape}")
    n, m = lp.shape
    mg = np.asarray(merges, dtype=np.int64).reshape(-1, 3)
    lw = np.ascontiguousarray(log_merged, dtype=np.float64).reshape(-1)
    if len(lw) != len(mg):
        raise ValueError(f"log_merged must have one weight per merge row ({len(mg)}), got {len(lw)}")
    bad = (
        (mg[:, 0] < 0) | (mg[:, 0] >= n) | (mg[:, 1] < 0) | (mg[:, 1] >= n) | (mg[:, 2] < 0) | (mg[:, 2] >= m)
    )
    if bad.any() or np.any(mg[:, 0] == mg[:, 1]):
        raise ValueError(
            f"merges must be rows (a, b, j) of distinct tracks < {n} and a detection < {m}, got {mg.tolist()}"
        )
    if np.isnan(lp).any() or np.isnan(lw).any() or math.isnan(log_miss) or (lp == np.inf).any():
        raise ValueError("log weights must be numbers or -inf")
    P, PM, PC = np.zeros((n, m)), np.zeros(len(mg)), np.zeros(m)
    a, b, j = (np.ascontiguousarray(mg[:, k]) for k in range(3))
    if not _cluster_marginals(lp, float(log_miss), a, b, j, lw, P, PM, PC):
        raise _no_event(np.arange(n))
    miss = 1.0 - P.sum(axis=1)
    for k in range(len(mg)):
        miss[a[k]] -= PM[k]
        miss[b[k]] -= PM[k]
    return MergedMarginals(P, np.clip(miss, 0.0, 1.0), PC, PM)
