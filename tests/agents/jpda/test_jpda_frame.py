"""The compiled JPDA frame (agents.jpda._kernels) against independent oracles: brute-force
enumeration of the joint events with merged blobs, the batched marginals of agents.jpda.marginals
on frames without merges, and the mixture moments computed from those marginals."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from agents.jpda import _kernels
from agents.jpda.marginals import association_marginals, merged_cluster_marginals
from agents.jpda.weights import gaussian_log_likelihood, jpda_log_weights
from agents.tracking.assign import chi2_gate
from track_envs.values.types import Gaussian


def brute_force_merged(
    L: np.ndarray, log_miss: float, merges: list[tuple[int, int, int]], log_merged: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every joint event: each track takes a gated detection alone, is part of one merged
    hypothesis (both of its tracks take its detection), or is missed; no detection twice."""
    n, m = L.shape
    options: list[list[tuple[str, int]]] = []
    for i in range(n):
        opts = [("miss", -1)] + [("own", j) for j in range(m) if np.isfinite(L[i, j])]
        opts += [("merge", e) for e, (a, b, _) in enumerate(merges) if i in (a, b)]
        options.append(opts)
    pairs, miss, clutter, merged = np.zeros((n, m)), np.zeros(n), np.zeros(m), np.zeros(len(merges))
    total = 0.0
    for event in itertools.product(*options):
        used: list[int] = []
        ok = True
        logw = 0.0
        merges_used = set()
        for i, (kind, k) in enumerate(event):
            if kind == "miss":
                logw += log_miss
            elif kind == "own":
                used.append(k)
                logw += L[i, k]
            else:
                a, b, j = merges[k]
                partner = b if i == a else a
                if event[partner] != ("merge", k):
                    ok = False
                    break
                if k not in merges_used:
                    merges_used.add(k)
                    used.append(j)
                    logw += log_merged[k]
        if not ok or len(set(used)) < len(used):
            continue
        w = math.exp(logw)
        total += w
        for i, (kind, k) in enumerate(event):
            if kind == "miss":
                miss[i] += w
            elif kind == "own":
                pairs[i, k] += w
        for k in merges_used:
            merged[k] += w
        for j in set(range(m)) - set(used):
            clutter[j] += w
    return pairs / total, miss / total, clutter / total, merged / total


def test_merged_cluster_marginals_equal_brute_force() -> None:
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(150):
        n, m = int(rng.integers(2, 5)), int(rng.integers(1, 5))
        L = np.where(rng.random((n, m)) < 0.6, rng.normal(0, 2, (n, m)), -np.inf)
        pairs_of = [(a, b) for a in range(n) for b in range(a + 1, n)]
        merges = [(a, b, int(rng.integers(m))) for a, b in pairs_of if rng.random() < 0.5]
        lw = rng.normal(0, 2, len(merges))
        log_miss = math.log(rng.uniform(0.01, 0.5))
        want = brute_force_merged(L, log_miss, merges, lw)
        got = merged_cluster_marginals(L, log_miss, np.array(merges, dtype=np.int64).reshape(-1, 3), lw)
        for a, b in zip(want, (got.pairs, got.miss, got.clutter, got.merged), strict=True):
            worst = max(worst, float(np.max(np.abs(a - b), initial=0.0)))
        # every track: alone, merged or missed; every detection: one owner or clutter
        per_track = got.pairs.sum(axis=1) + got.miss
        for (a, b, _), w in zip(merges, got.merged, strict=True):
            per_track[a] += w
            per_track[b] += w
        np.testing.assert_allclose(per_track, 1.0, atol=1e-12)
    assert worst < 1e-12


def test_merged_cluster_marginals_name_bad_input() -> None:
    L = np.zeros((2, 2))
    with pytest.raises(ValueError, match="distinct tracks"):
        merged_cluster_marginals(L, -1.0, np.array([[0, 0, 1]]), np.zeros(1))
    with pytest.raises(ValueError, match="one weight per merge row"):
        merged_cluster_marginals(L, -1.0, np.array([[0, 1, 1]]), np.zeros(2))
    with pytest.raises(ValueError, match="no joint event"):
        merged_cluster_marginals(np.full((2, 1), -np.inf), -np.inf, np.zeros((0, 3)), np.zeros(0))


def _frame(rng: np.random.Generator, n: int, m: int, spread: float = 1.0):
    mean = rng.uniform(0, 20, (n, 2))
    a = rng.normal(0, 0.4, (n, 2, 2))
    cov = a @ a.transpose(0, 2, 1) + 0.05 * np.eye(2)
    z = np.concatenate(
        [
            mean[: m // 2] + rng.normal(0, spread, (min(m // 2, n), 2)),
            rng.uniform(0, 20, (m - min(m // 2, n), 2)),
        ]
    )
    return mean, cov, z[rng.permutation(len(z))]


def test_frame_without_merges_equals_the_batched_marginals() -> None:
    """Gating, clusters, marginals and mixture moments of one compiled pass against
    association_marginals and numpy moments, over random dense frames."""
    rng = np.random.default_rng(11)
    gate = chi2_gate(0.99, 2)
    p_d, lam = 0.9, 0.3
    worst = 0.0
    sizes: list[int] = []
    for _ in range(40):
        n, m = int(rng.integers(1, 25)), int(rng.integers(0, 30))
        mean, cov, z = _frame(rng, n, m)
        loglik, d2 = gaussian_log_likelihood(Gaussian(mean, cov), z)
        mg = association_marginals(jpda_log_weights(loglik, d2 <= gate, p_d, lam, 0.99))
        got = _kernels.jpda_frame(
            mean,
            cov,
            z,
            gate,
            math.log(p_d / lam),
            math.log(1 - p_d * 0.99),
            0.0,
            np.eye(2),
            0.0,
            0.0,
            12,
            np.ones(n, np.bool_),
        )
        assert got.status == _kernels.FRAME_OK and len(got.big) == 0
        p = mg.pairs.sum(axis=1)
        worst = max(worst, float(np.max(np.abs(got.p_seen - p), initial=0)))
        worst = max(worst, float(np.max(np.abs(got.clutter - mg.clutter), initial=0)))
        seen = p > 0
        zbar = mg.pairs[seen] @ z / p[seen, None]
        np.testing.assert_allclose(got.z_mean[seen], zbar, rtol=0, atol=1e-10)
        np.testing.assert_array_equal(got.z_mean[~seen], mean[~seen])
        diff = z[None] - zbar[:, None]
        spread = np.einsum("tj,tjd,tje->tde", mg.pairs[seen] / p[seen, None], diff, diff)
        np.testing.assert_allclose(got.z_spread[seen], spread, rtol=0, atol=1e-9)
        best = np.where(seen, np.argmax(mg.pairs, axis=1) if m else -1, -1)
        np.testing.assert_array_equal(got.best, best)
        assert got.cluster_tracks.sum() == n
        sizes += got.cluster_tracks.tolist()
    assert worst < 1e-12
    assert max(sizes) >= 4 and sum(s > 1 for s in sizes) >= 20  # competing tracks were tested


def test_a_joined_pair_is_explained_by_its_merged_blob() -> None:
    """Two tracks 1.8 mm apart, one detection at their midpoint: the merged event takes almost
    all probability, both tracks count as detected, and each is moved by the blob as a rigid
    group (its pseudo-measurement is the blob plus its offset from the pair's centre)."""
    mean = np.array([[0.100, 0.0500], [0.100, 0.0518], [0.100, 0.0560]])
    cov = np.repeat((8e-5) ** 2 * np.eye(2)[None], 3, axis=0)
    R = (3e-5) ** 2 * np.eye(2)
    blob = np.array([[0.10002, 0.0509]])
    neighbour = mean[2:] + 1e-5
    z = np.concatenate([blob, neighbour])
    gate = chi2_gate(0.999, 2)
    args = (gate, math.log(1.0 / 0.25), math.log(1 - 0.999), 0.006, R, 0.01, 0.0, 12, np.ones(3, np.bool_))
    got = _kernels.jpda_frame(mean, cov, z, *args)
    assert got.p_seen[:2].min() > 0.99
    assert got.merged_with[:2].tolist() == [1, 0] and got.best[:2].tolist() == [0, 0]
    centre = mean[:2].mean(axis=0)
    np.testing.assert_allclose(got.z_mean[:2], blob + (mean[:2] - centre), atol=1e-9)
    assert got.best[2] == 1 and got.merged_with[2] == -1
    off = _kernels.jpda_frame(mean, cov, z, gate, *args[1:3], 0.0, *args[4:])  # no merge model
    assert off.p_seen[:2].max() < 0.5  # 0.9 mm off both predictions: outside both gates


def test_a_non_positive_definite_covariance_is_reported() -> None:
    cov = np.array([[[1.0, 0.0], [0.0, 1.0]], [[1.0, 2.0], [2.0, 1.0]]])
    got = _kernels.jpda_frame(
        np.zeros((2, 2)),
        cov,
        np.zeros((1, 2)),
        9.0,
        0.0,
        -1.0,
        0.0,
        np.eye(2),
        0.0,
        0.0,
        12,
        np.ones(2, np.bool_),
    )
    assert got.status == _kernels.FRAME_NOT_PD and got.bad == 1


def test_the_log_space_recursion_equals_brute_force_and_takes_over_beyond_the_float_range() -> None:
    """_cluster_marginals_log (the fallback) against the oracle, and a cluster whose weights span
    e^±800 (the linear recursion cannot hold them) still sums to one and matches the scaled case."""
    rng = np.random.default_rng(9)
    for _ in range(60):
        n, m = int(rng.integers(2, 5)), int(rng.integers(1, 5))
        L = np.where(rng.random((n, m)) < 0.6, rng.normal(0, 2, (n, m)), -np.inf)
        merges = [
            (a, b, int(rng.integers(m))) for a in range(n) for b in range(a + 1, n) if rng.random() < 0.5
        ]
        mg = np.array(merges, dtype=np.int64).reshape(-1, 3)
        lw = rng.normal(0, 2, len(merges))
        log_miss = math.log(rng.uniform(0.01, 0.5))
        want = brute_force_merged(L, log_miss, merges, lw)
        P, PM, PC = np.zeros((n, m)), np.zeros(len(merges)), np.zeros(m)
        a, b, j = (np.ascontiguousarray(mg[:, k]) for k in range(3))
        assert _kernels._cluster_marginals_log(L, log_miss, a, b, j, lw, P, PM, PC)
        np.testing.assert_allclose(P, want[0], atol=1e-12)
        np.testing.assert_allclose(PC, want[2], atol=1e-12)
        np.testing.assert_allclose(PM, want[3], atol=1e-12)
    # two tracks, one detection, a miss weight of e^-800: every event holds one miss, which the
    # linear recursion's scaled weights underflow (Z = 0); the log-space recursion answers
    L = np.zeros((2, 1))
    P, PM, PC = np.zeros((2, 1)), np.zeros(0), np.zeros(1)
    empty = np.zeros(0, np.int64)
    assert not _kernels._dp_linear(
        np.exp(L.T),
        np.ones(1),
        np.full(2, math.exp(-800.0)),
        empty,
        empty,
        empty,
        np.zeros(0),
        P.T.copy(),
        PM,
        PC,
    )
    got = merged_cluster_marginals(L, -800.0, np.zeros((0, 3), np.int64), np.zeros(0))
    np.testing.assert_allclose(got.pairs, [[0.5], [0.5]], atol=1e-12)
    np.testing.assert_allclose(got.clutter, [0.0], atol=1e-12)
