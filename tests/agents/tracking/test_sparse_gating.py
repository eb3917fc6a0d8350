"""The spatial-index paths of the association against the dense computations they replace: the
second chance's pairs, the blobs' members, the errors of an unbounded gate, NaN detections."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agents.tracking import _kernels, _upkeep_kernels
from agents.tracking.assign import associate_greedy, associate_hungarian, gated_pairs, mahalanobis_cost
from agents.tracking.merges import share_blobs
from track_envs.values.types import Gaussian


def scene(seed: int, n: int, m: int, dim: int = 2):
    """Tracks and detections in a unit box, covariances of a few mm with correlation."""
    rng = np.random.default_rng(seed)
    mean = rng.uniform(size=(n, dim))
    a = rng.normal(scale=rng.uniform(1e-3, 3e-2), size=(n, dim, dim))
    cov = a @ a.transpose(0, 2, 1) + 1e-6 * np.eye(dim)
    z = np.concatenate(
        [
            mean[: m // 2] + rng.normal(scale=0.01, size=(min(m // 2, n), dim)),
            rng.uniform(size=(m - min(m // 2, n), dim)),
        ]
    )
    return mean, cov, z


def recovery_reference(mean, cov, z, det, inflation, gate, last, flow, k_u, r_s, kappa=math.inf):
    """The dense second chance: every leftover pair's cost, the cap, the clutter bound."""
    tracks = np.flatnonzero(det < 0)
    used = np.zeros(len(z), bool)
    used[det[det >= 0]] = True
    dets = np.flatnonzero(~used)
    cost = mahalanobis_cost(Gaussian(mean[tracks], cov[tracks] * inflation), z[dets])
    if not np.any(cost <= gate):
        return tracks, dets, [], math.inf
    cap = k_u * max(flow, _upkeep_kernels.median_displacement(mean, last)) + r_s
    diff = z[dets][None, :, :] - mean[tracks][:, None, :]
    dist2 = np.zeros(cost.shape)
    for d in range(mean.shape[1]):
        dist2 = dist2 + diff[..., d] * diff[..., d]
    bound = np.array(
        [
            2 * kappa - _upkeep_kernels.log_det(cov[t] * inflation) if kappa < math.inf else math.inf
            for t in tracks
        ]
    )
    keep = (cost <= gate) & ~((dist2 > cap * cap) | (cost > bound[:, None]))
    return tracks, dets, [(a, b, cost[a, b]) for a, b in zip(*np.nonzero(keep), strict=True)], cap


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    n=st.integers(1, 40),
    m=st.integers(1, 40),
    dim=st.sampled_from([1, 2, 3]),
    kappa=st.sampled_from([math.inf, 3.0, 8.0]),
)
def test_second_chance_pairs_are_the_dense_ones(seed, n, m, dim, kappa):
    mean, cov, z = scene(seed, n, m, dim)
    rng = np.random.default_rng(seed + 1)
    det = np.full(n, -1, np.int64)
    taken = rng.permutation(m)[: rng.integers(0, min(n, m) + 1)]
    det[rng.permutation(n)[: len(taken)]] = taken
    last = mean - rng.normal(scale=0.01, size=mean.shape)
    args = (mean, cov, z, det, 9.0, 13.8, last, 0.002, 3.0, 0.005, kappa)
    got = _upkeep_kernels.recovery_costs(*args)
    tracks, dets, pairs, cap = recovery_reference(*args)
    assert got.bad == got.wide == -1
    np.testing.assert_array_equal(got.tracks, tracks)
    np.testing.assert_array_equal(got.dets, dets)
    rows = np.repeat(np.arange(len(tracks)), np.diff(got.ptr))
    assert list(zip(rows.tolist(), got.cols.tolist(), got.cost.tolist(), strict=True)) == [
        (int(a), int(b), float(c)) for a, b, c in pairs
    ]  # costs bit-identical
    assert got.n_admissible == len(pairs)
    assert got.cap == cap  # inf when no pair passes the inflated gate


def blob_reference(predicted, z, det_of_track, extent, low, high):
    """The dense pass: every leftover track against every taken detection."""
    n, dim = predicted.shape
    out = det_of_track.copy()
    owner = np.full(len(z), -1)
    for i in range(n):
        if det_of_track[i] >= 0:
            owner[det_of_track[i]] = i
    e2 = extent * extent
    for j in range(n):
        if det_of_track[j] >= 0 or not np.all((low <= predicted[j]) & (predicted[j] <= high)):
            continue
        best, best_d = -1, e2
        for d in range(len(z)):
            i = owner[d]
            if i < 0:
                continue
            dj = sum((predicted[j, k] - z[d, k]) ** 2 for k in range(dim))
            di = sum((predicted[i, k] - z[d, k]) ** 2 for k in range(dim))
            if dj <= best_d and di <= e2:
                best, best_d = d, dj
        out[j] = best
    return out


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 10_000), n=st.integers(1, 60), m=st.integers(1, 60), dim=st.sampled_from([1, 2, 3])
)
def test_blob_members_are_the_dense_ones(seed, n, m, dim):
    rng = np.random.default_rng(seed)
    predicted = rng.uniform(size=(n, dim))
    z = rng.uniform(size=(m, dim))
    z[rng.random(m) < 0.1] = np.nan  # a detection with NaN is no candidate
    predicted[rng.random(n) < 0.05, 0] = 0.5  # equal distances: the last detection wins, as dense
    det = np.full(n, -1, np.int64)
    taken = rng.permutation(m)[: rng.integers(0, min(n, m) + 1)]
    det[rng.permutation(n)[: len(taken)]] = taken
    low, high = np.full(dim, 0.05), np.full(dim, 0.95)
    extent = float(rng.choice([0.05, 0.2, 0.5]))
    shared, _ = share_blobs(predicted, z, det, extent, low, high)
    np.testing.assert_array_equal(shared, blob_reference(predicted, z, det, extent, low, high))


def test_an_unbounded_gate_is_named():
    mean, cov, z = scene(0, 4, 4)
    cov[2] = np.diag([1e308, 1.0])  # positive definite, but γ S_00 overflows
    for associate in (associate_hungarian, associate_greedy):
        with pytest.raises(ValueError, match=r"track 2: gate half-width .*inf"):
            associate(Gaussian(mean, cov), z, 13.8)
    cov[2] = cov[1]
    with pytest.raises(ValueError, match=r"track 0: .*gate inf"):
        gated_pairs(Gaussian(mean, cov), z, math.inf)  # an infinite gate has no box either


def test_a_covariance_that_is_not_positive_definite_is_still_a_linalg_error():
    mean, cov, z = scene(0, 4, 4)
    cov[1] = -cov[1]
    cov[3] = np.diag([1e308, 1.0])
    with pytest.raises(np.linalg.LinAlgError, match="track 1 is not positive definite"):
        associate_hungarian(Gaussian(mean, cov), z, 13.8)


def test_detections_with_nan_are_never_candidates():
    mean, cov, z = scene(3, 6, 6)
    z[[1, 4]] = np.nan
    z[2, 1] = np.inf
    pairs = gated_pairs(Gaussian(mean, cov), z, 1e6)
    assert not set(pairs.cols.tolist()) & {1, 2, 4}
    dense = mahalanobis_cost(Gaussian(mean, cov), z)
    np.testing.assert_array_equal(np.flatnonzero(np.any(dense <= 1e6, axis=0)), np.unique(pairs.cols))


def test_the_gate_box_holds_every_admissible_pair_of_thin_ellipses():
    # nearly degenerate covariances: the exact test admits pairs at the very edge of the box
    rng = np.random.default_rng(5)
    n = 200
    mean = rng.uniform(size=(n, 2))
    angle = rng.uniform(0, np.pi, n)
    u = np.stack([np.cos(angle), np.sin(angle)], 1)
    cov = 1e-2 * u[:, :, None] * u[:, None, :] + 1e-14 * np.eye(2)
    z = mean + np.sqrt(13.8e-2) * u * rng.uniform(-1.0, 1.0, size=(n, 1))
    pairs = gated_pairs(Gaussian(mean, cov), z, 13.8)
    dense = mahalanobis_cost(Gaussian(mean, cov), z)
    rows, cols = np.nonzero(dense <= 13.8)
    np.testing.assert_array_equal(np.repeat(np.arange(n), np.diff(pairs.ptr)), rows)
    np.testing.assert_array_equal(pairs.cols, cols)
    assert _kernels.BOX_SLACK == 1e-9
