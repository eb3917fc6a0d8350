"""The named steps of the compiled JPDA frame ([`agents.jpda._kernels`][agents.jpda._kernels]) against direct
numpy."""

from __future__ import annotations

import math

import jpda_reference  # the first-axis sweeps the compiled steps replaced
import numpy as np
from test_jpda_clusters import bfs_components  # the components of a gate graph, searched directly

from agents.jpda import _kernels


def _random_tracks(rng: np.random.Generator, n: int, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    mean = rng.uniform(0.0, 0.02, size=(n, 2))
    a = rng.normal(size=(n, 2, 2)) * 2e-3
    cov = a @ a.transpose(0, 2, 1) + np.eye(2) * 1e-6
    z = (
        np.concatenate([mean[rng.integers(0, n, m)] + rng.normal(size=(m, 2)) * 2e-3])
        if n
        else rng.random((m, 2))
    )
    return mean, cov, z


def _log_normal(x: np.ndarray, mu: np.ndarray, cov: np.ndarray) -> tuple[float, float]:
    """``(d², log N(x; mu, cov))``."""
    diff = x - mu
    d2 = float(diff @ np.linalg.solve(cov, diff))
    return d2, -0.5 * d2 - 0.5 * math.log(np.linalg.det(cov)) - len(x) / 2 * math.log(2 * math.pi)


def test_gated_pairs_are_every_pair_inside_the_gate_with_its_log_weight() -> None:
    rng = np.random.default_rng(1)
    gate, log_ratio = 9.21, 3.0
    for _ in range(50):
        n, m = int(rng.integers(1, 8)), int(rng.integers(0, 12))
        mean, cov, z = _random_tracks(rng, n, m)
        chol, lnorm = np.zeros((n, 2, 2)), np.zeros(n)
        assert _kernels._track_factors(cov, chol, lnorm) == -1
        np.testing.assert_allclose(chol @ chol.transpose(0, 2, 1), cov, rtol=1e-12, atol=1e-20)
        grid, half = _kernels._detection_grid(mean, cov, z, gate)
        e_t, e_d, e_w, ne, _ = _kernels._gated_pairs(
            mean, cov, z, chol, lnorm, gate, log_ratio, grid, half, np.empty(0), np.zeros(2), np.zeros(2)
        )
        got = {(int(e_t[k]), int(e_d[k])): float(e_w[k]) for k in range(ne)}
        assert len(got) == ne
        assert np.all(np.diff(e_t[:ne]) >= 0)  # tracks ascending, each by ascending first coordinate
        same = np.diff(e_t[:ne]) == 0
        assert np.all(np.diff(z[e_d[:ne], 0])[same] >= 0)
        want = {}
        for i in range(n):
            for j in range(m):
                d2, log_n = _log_normal(z[j], mean[i], cov[i])
                if d2 <= gate:
                    want[(i, j)] = log_ratio + log_n
        assert got.keys() == want.keys()
        for key, w in want.items():
            assert math.isclose(got[key], w, rel_tol=1e-9, abs_tol=1e-9)


def test_track_factors_name_the_first_track_not_positive_definite() -> None:
    cov = np.stack([np.eye(2), np.eye(2), -np.eye(2), -np.eye(2)])
    assert _kernels._track_factors(cov, np.zeros((4, 2, 2)), np.zeros(4)) == 2


def test_merged_hypotheses_are_the_pairs_blob_gaussian() -> None:
    mean = np.array([[0.010, 0.005], [0.0125, 0.005], [0.030, 0.005]])
    cov = np.stack([np.eye(2) * 1e-6] * 3)
    noise = np.eye(2) * 1e-8
    z = np.array([[0.01125, 0.0051], [0.020, 0.005]])
    grid, _ = _kernels._detection_grid(mean, cov, z, 9.21)

    def hypotheses(extent: float, mergeable: np.ndarray) -> tuple:
        return _kernels._merged_hypotheses(
            mean, cov, z, 9.21, 2.0, extent, noise, 0.01, -1.0, mergeable,
            grid, np.empty(0), np.zeros(2), np.zeros(2),
        )  # fmt: skip

    g_a, g_b, g_d, g_w, ng, _ = hypotheses(5e-3, np.ones(3, np.bool_))
    assert ng == 1 and (g_a[0], g_b[0], g_d[0]) == (0, 1, 0)  # track 2 is too far for a blob
    delta = mean[0] - mean[1]
    blob_cov = 0.25 * (cov[0] + cov[1]) + 0.5 * noise + 0.01 * np.outer(delta, delta)
    _, log_n = _log_normal(z[0], 0.5 * (mean[0] + mean[1]), blob_cov)
    assert math.isclose(g_w[0], 2.0 - 1.0 + log_n, rel_tol=1e-12)
    assert hypotheses(5e-3, np.array([True, False, True]))[4] == 0  # a member not mergeable
    assert hypotheses(0.0, np.ones(3, np.bool_))[4] == 0  # no merge model


def test_clusters_are_the_components_of_pairs_and_merged_blobs() -> None:
    rng = np.random.default_rng(2)
    for _ in range(200):
        n, m = int(rng.integers(1, 9)), int(rng.integers(0, 9))
        gate = rng.random((n, m)) < rng.uniform(0.0, 0.4)
        e_t, e_d = (a.astype(np.int64) for a in np.nonzero(gate))
        ng = int(rng.integers(0, 3)) if n > 1 and m else 0
        g_a = rng.integers(0, n, ng)
        g_b = (g_a + 1 + rng.integers(0, n - 1, ng)) % n if ng else g_a.copy()
        g_d = rng.integers(0, m, ng) if ng else g_a.copy()
        linked = gate.copy()
        linked[g_a, g_d] = linked[g_b, g_d] = True
        root = _kernels._roots(n, m, e_t, e_d, len(e_t), g_a, g_b, g_d, ng)
        cl = _kernels._clusters(root, n)
        members = [
            (cl.t_of[cl.t_start[c] : cl.t_start[c + 1]], cl.d_of[cl.d_start[c] : cl.d_start[c + 1]])
            for c in range(len(cl.c_nt))
        ]
        want = {(t, d) for t, d in bfs_components(linked) if t}
        assert {(frozenset(t.tolist()), frozenset(d.tolist())) for t, d in members} == want
        firsts = [int(t[0]) for t, _ in members]
        assert firsts == sorted(firsts)  # labelled in order of the smallest track
        for c, (t, d) in enumerate(members):
            assert np.all(np.diff(t) > 0) and np.all(np.diff(d) > 0)
            np.testing.assert_array_equal(cl.local[t], np.arange(len(t)))
            np.testing.assert_array_equal(cl.local[n + d], np.arange(len(d)))
            np.testing.assert_array_equal(cl.label[cl.root[t]], c)
        big = _kernels._big_tracks(cl, 2)
        np.testing.assert_array_equal(
            big, np.concatenate([t for t, _ in members if len(t) > 2] or [np.zeros(0, int)])
        )


def test_split_candidates_are_greedy_by_distance_each_track_and_detection_once() -> None:
    mean = np.array([[0.010, 0.005], [0.0101, 0.005]])
    cov = np.stack([np.eye(2) * 4e-6] * 2)
    noise = np.eye(2) * 1e-8
    z = np.array([[0.0095, 0.005], [0.0105, 0.005], [0.0096, 0.0051], [0.0106, 0.0049]])
    t, j, k, d2 = _kernels._split_candidates(
        mean, cov, z, np.ones(2, np.bool_), np.ones(4, np.bool_), 9.21, noise, 0.0, 0.004
    )
    assert len(t) > 2 and np.all(j < k) and np.all(d2 <= 9.21)
    track, keep, other = _kernels._greedy_splits(mean, z, t, j, k, d2)
    np.testing.assert_array_equal(track, [0, 1])
    assert len(set(keep.tolist()) | set(other.tolist())) == 4  # each detection once
    first = int(np.argmin(d2))
    assert {int(j[first]), int(k[first])} == {
        int(keep[track == t[first]][0]),
        int(other[track == t[first]][0]),
    }


def _scene(rng: np.random.Generator, n: int, m: int, ties: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tracks and detections on a 5 cm square; ``ties``: coordinates on a coarse lattice, so that
    many first coordinates are equal (the order of equal ones is numba's argsort's)."""
    mean = rng.uniform(0.0, 0.05, (n, 2))
    a = rng.normal(size=(n, 2, 2)) * 3e-3
    cov = a @ a.transpose(0, 2, 1) + np.eye(2) * 1e-6
    near = min(m // 2, n)
    z = np.concatenate(
        [
            mean[rng.integers(0, n, near)] + rng.normal(size=(near, 2)) * 2e-3,
            rng.uniform(0, 0.05, (m - near, 2)),
        ]
    )
    if ties:
        mean, z = np.round(mean, 2), np.round(z, 3)
    return mean, cov, np.ascontiguousarray(z)


def test_steps_list_the_hypotheses_of_the_first_axis_sweeps_in_their_order() -> None:
    """The spatial index finds exactly the gated pairs, merged blobs and blob splits of the
    first-axis sweeps it replaced (``jpda_reference``), in the same order and with the same bits,
    whole frames included; equal first coordinates (lattice scenes) in argsort's order."""
    rng = np.random.default_rng(3)
    noise = np.eye(2) * 1e-7
    for it in range(300):
        n, m = int(rng.integers(1, 40)), int(rng.integers(0, 50))
        mean, cov, z = _scene(rng, n, m, ties=it % 3 == 0)
        if it % 10 == 0:
            cov[0] *= 1e305  # an unbounded gate: every detection is a candidate
        mergeable = rng.random(n) < 0.8
        extent = (0.0, 0.004, 0.01)[it % 3]
        args = (mean, cov, z, 9.21, 2.0, math.log(0.1), extent, noise, 0.01, -0.5, 12, mergeable)
        got, want = _kernels.jpda_frame(*args), jpda_reference.reference_frame(*args)
        for name, a, b in zip(want._fields, got, want, strict=True):
            assert np.array_equal(np.asarray(a), np.asarray(b)), (it, name)
        unseen, free = rng.random(n) < 0.5, rng.random(m) < 0.7
        split = (mean, cov, z, unseen, free, 9.21, noise, (0.0, 0.01)[it % 2], 0.004)
        want_split = jpda_reference._split_candidates(*split)
        for a, b in zip(_kernels._split_candidates(*split), want_split, strict=True):
            assert np.array_equal(a, b), it


def test_equal_first_coordinates_are_ordered_as_numbas_argsort() -> None:
    """A track's pairs and a blob's detections list equal first coordinates in the order of
    ``np.argsort(z[:, 0])`` (numba's quicksort, not stable), computed only when two are equal."""
    rng = np.random.default_rng(4)
    mean = np.array([[0.02, 0.02], [0.0205, 0.0201]])
    cov = np.stack([np.eye(2) * 1e-4] * 2)
    z = np.ascontiguousarray(np.round(rng.uniform(0.0, 0.04, (60, 2)), 2))
    chol, lnorm = np.zeros((2, 2, 2)), np.zeros(2)
    _kernels._track_factors(cov, chol, lnorm)
    grid, half = _kernels._detection_grid(mean, cov, z, 9.21)
    e_t, e_d, _, ne, rank = _kernels._gated_pairs(
        mean, cov, z, chol, lnorm, 9.21, 0.0, grid, half, np.empty(0), np.zeros(2), np.zeros(2)
    )
    assert ne > 10 and len(rank) == len(z)
    order = _kernels._first_axis_rank(z[:, 0])
    for i in range(2):
        d = e_d[:ne][e_t[:ne] == i]
        assert np.all(np.diff(order[d]) > 0)
    g = _kernels._merged_hypotheses(
        mean, cov, z, 9.21, 0.0, 0.01, np.eye(2) * 1e-7, 0.0, 0.0, np.ones(2, np.bool_),
        grid, np.empty(0), np.zeros(2), np.zeros(2),
    )  # fmt: skip
    assert g[4] > 10 and np.all(np.diff(order[g[2][: g[4]]]) > 0)
