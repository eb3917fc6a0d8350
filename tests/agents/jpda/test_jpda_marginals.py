"""JPDA marginals against brute-force enumeration of the joint events, and argument checks."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from agents.jpda.marginals import Marginals, association_marginals, cluster_marginals, jpda_marginals
from agents.jpda.weights import jpda_log_weights


def brute_force(
    g: np.ndarray, gate: np.ndarray, p_d: float, lam: float, p_g: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every joint event of Fortmann et al.: each track takes a gated detection or none, no
    detection twice; weight Π p_D g_ij / λ · Π_missed (1 − p_D P_G); normalised."""
    n, m = g.shape
    pairs, miss, clutter = np.zeros((n, m)), np.zeros(n), np.zeros(m)
    total = 0.0
    choices = [[-1, *np.flatnonzero(gate[i]).tolist()] for i in range(n)]
    for event in itertools.product(*choices):
        taken = [j for j in event if j >= 0]
        if len(set(taken)) < len(taken):
            continue
        w = 1.0
        for i, j in enumerate(event):
            w *= p_d * g[i, j] / lam if j >= 0 else 1.0 - p_d * p_g
        total += w
        for i, j in enumerate(event):
            if j >= 0:
                pairs[i, j] += w
            else:
                miss[i] += w
        for j in set(range(m)) - set(taken):
            clutter[j] += w
    return pairs / total, miss / total, clutter / total


def random_case(rng: np.random.Generator, n: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    log_g = rng.normal(0.0, 2.0, size=(n, m))
    gate = rng.random((n, m)) < rng.uniform(0.0, 1.0)
    return log_g, gate


def assert_sums(mg: Marginals) -> None:
    np.testing.assert_allclose(mg.pairs.sum(axis=1) + mg.miss, 1.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(mg.pairs.sum(axis=0) + mg.clutter, 1.0, rtol=0, atol=1e-12)


def test_equals_brute_force_on_random_small_clusters() -> None:
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(400):
        n, m = int(rng.integers(1, 7)), int(rng.integers(0, 8))
        log_g, gate = random_case(rng, n, m)
        p_d, lam, p_g = rng.uniform(0.2, 1.0), rng.uniform(0.01, 3.0), rng.uniform(0.5, 1.0)
        pairs, miss, clutter = brute_force(np.exp(log_g), gate, p_d, lam, p_g)
        mg = jpda_marginals(log_g, gate, p_d, lam, p_g)
        assert mg.exact.all()
        assert_sums(mg)
        np.testing.assert_array_equal(mg.pairs[~gate], 0.0)
        for got, want in ((mg.pairs, pairs), (mg.miss, miss), (mg.clutter, clutter)):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
            worst = max(worst, float(np.abs(got - want).max(initial=0.0)))
    assert worst < 1e-13


def test_single_cluster_equals_brute_force_and_frame_result() -> None:
    rng = np.random.default_rng(8)
    for _ in range(100):
        n, m = int(rng.integers(1, 6)), int(rng.integers(0, 7))
        log_g, gate = random_case(rng, n, m)
        w = jpda_log_weights(log_g, gate, 0.9, 0.3, 0.99)
        one = cluster_marginals(w.log_pair, w.log_miss)
        pairs, miss, clutter = brute_force(np.exp(log_g), gate, 0.9, 0.3, 0.99)
        np.testing.assert_allclose(one.pairs, pairs, rtol=0, atol=1e-12)
        np.testing.assert_allclose(one.miss, miss, rtol=0, atol=1e-12)
        np.testing.assert_allclose(one.clutter, clutter, rtol=0, atol=1e-12)
        frame = association_marginals(w)
        np.testing.assert_allclose(frame.beta, one.beta, rtol=0, atol=1e-12)


def test_several_clusters_in_one_frame_including_empty_rows_and_columns() -> None:
    """A block-diagonal frame: each block against its own enumeration, in shuffled order."""
    rng = np.random.default_rng(9)
    blocks = [(1, 0), (0, 2), (1, 1), (2, 3), (3, 2), (4, 4), (2, 1), (1, 5), (5, 1)]
    n, m = sum(b[0] for b in blocks), sum(b[1] for b in blocks)
    log_g = rng.normal(0.0, 2.0, size=(n, m))
    gate = np.zeros((n, m), dtype=bool)
    r = c = 0
    spans = []
    for bn, bm in blocks:
        gate[r : r + bn, c : c + bm] = True
        spans.append((slice(r, r + bn), slice(c, c + bm)))
        r, c = r + bn, c + bm
    tp, dp = rng.permutation(n), rng.permutation(m)
    mg = jpda_marginals(log_g[np.ix_(tp, dp)], gate[np.ix_(tp, dp)], 0.8, 0.5, 0.95)
    t_inv, d_inv = np.argsort(tp), np.argsort(dp)
    assert_sums(mg)
    for rs, cs in spans:
        pairs, miss, clutter = brute_force(np.exp(log_g[rs, cs]), gate[rs, cs], 0.8, 0.5, 0.95)
        np.testing.assert_allclose(mg.pairs[np.ix_(t_inv[rs], d_inv[cs])], pairs, rtol=0, atol=1e-12)
        np.testing.assert_allclose(mg.miss[t_inv[rs]], miss, rtol=0, atol=1e-12)
        np.testing.assert_allclose(mg.clutter[d_inv[cs]], clutter, rtol=0, atol=1e-12)


def test_lone_track_is_the_pda_filter() -> None:
    """One track: β_j = L_j / (1 − p_D P_G + Σ L_k), L_j = p_D g_j / λ (Bar-Shalom's PDA)."""
    g = np.array([0.2, 1.5, 0.01])
    mg = jpda_marginals(np.log(g)[None], np.ones((1, 3), dtype=bool), 0.9, 0.1, 0.99)
    L = 0.9 * g / 0.1
    den = 1 - 0.9 * 0.99 + L.sum()
    np.testing.assert_allclose(mg.pairs[0], L / den, rtol=1e-14)
    np.testing.assert_allclose(mg.miss[0], (1 - 0.9 * 0.99) / den, rtol=1e-14)


def test_symmetric_cases() -> None:
    # Two identical tracks, two identical detections: every pair 1/2 · (1 − β_miss).
    mg = jpda_marginals(np.zeros((2, 2)), np.ones((2, 2), dtype=bool), 0.9, 1.0, 1.0)
    assert np.ptp(mg.pairs) < 1e-15
    np.testing.assert_allclose(mg.miss[0], mg.miss[1], rtol=0, atol=1e-15)
    # Exchanging two tracks (and their rows) exchanges their marginals.
    rng = np.random.default_rng(3)
    log_g, gate = rng.normal(size=(4, 5)), rng.random((4, 5)) < 0.7
    a = jpda_marginals(log_g, gate, 0.7, 0.2, 0.9)
    b = jpda_marginals(
        log_g[[1, 0, 2, 3]][:, [4, 3, 2, 1, 0]], gate[[1, 0, 2, 3]][:, [4, 3, 2, 1, 0]], 0.7, 0.2, 0.9
    )
    np.testing.assert_allclose(b.pairs, a.pairs[[1, 0, 2, 3]][:, [4, 3, 2, 1, 0]], rtol=0, atol=1e-15)
    # 2 tracks, 1 detection, pair weight 1, miss weight 1/2: events 1/4, 1/2, 1/2 → β = 0.4.
    mg = jpda_marginals(np.zeros((2, 1)), np.ones((2, 1), dtype=bool), 0.5, 0.5, 1.0)
    np.testing.assert_allclose(mg.pairs[:, 0], 0.4, rtol=1e-15)
    np.testing.assert_allclose(mg.miss, 0.6, rtol=1e-15)
    np.testing.assert_allclose(mg.clutter, 0.2, rtol=1e-15)


def test_extreme_likelihoods_neither_overflow_nor_underflow() -> None:
    """Shifting every log g by ±800 (e^800 overflows) changes β like a clutter density e^∓800."""
    rng = np.random.default_rng(4)
    log_g, gate = rng.normal(size=(5, 6)), rng.random((5, 6)) < 0.8
    ref = jpda_marginals(log_g, gate, 0.9, 1.0, 0.99)
    for shift in (800.0, -800.0):
        # log g + s with λ·e^s is the same event distribution.
        w = jpda_log_weights(log_g + shift, gate, 0.9, 1.0, 0.99)
        w_pair = w.log_pair - shift
        from agents.jpda.weights import EventWeights

        mg = association_marginals(EventWeights(w_pair, w.log_miss))
        np.testing.assert_allclose(mg.beta, ref.beta, rtol=0, atol=1e-12)
        big = jpda_marginals(log_g + shift, gate, 0.9, 1.0, 0.99)
        assert np.isfinite(big.beta).all()
        assert_sums(big)
    # Three tracks competing for one detection, misses of weight e^-400 each relative to it.
    huge = jpda_marginals(np.full((3, 1), 400.0), np.ones((3, 1), dtype=bool), 0.5, 1.0, 1.0)
    np.testing.assert_allclose(huge.pairs[:, 0], 1 / 3, rtol=1e-14)


def test_p_detect_gate_one_forces_assignments() -> None:
    """p_D P_G = 1: no misses; 2 tracks, 2 detections → the two perfect matchings only."""
    log_g = np.log(np.array([[2.0, 1.0], [1.0, 3.0]]))
    mg = jpda_marginals(log_g, np.ones((2, 2), dtype=bool), 1.0, 1.0, 1.0)
    np.testing.assert_allclose(mg.pairs, [[6 / 7, 1 / 7], [1 / 7, 6 / 7]], rtol=1e-14)
    np.testing.assert_array_equal(mg.miss, 0.0)
    with pytest.raises(ValueError, match=r"no joint event has positive weight.*\[0, 1\]"):
        jpda_marginals(np.zeros((2, 1)), np.ones((2, 1), dtype=bool), 1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match=r"no joint event.*\[1\]"):
        jpda_marginals(np.zeros((2, 1)), np.array([[True], [False]]), 1.0, 1.0, 1.0)


def test_empty_frames() -> None:
    for n, m in ((0, 0), (0, 3), (3, 0)):
        mg = jpda_marginals(np.zeros((n, m)), np.zeros((n, m), dtype=bool), 0.9, 1.0)
        assert mg.pairs.shape == (n, m) and mg.beta.shape == (n, m + 1)
        np.testing.assert_array_equal(mg.miss, 1.0)
        np.testing.assert_array_equal(mg.clutter, 1.0)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"p_detect": 0.0}, r"p_detect must be in \(0, 1\], got 0.0"),
        ({"p_detect": 1.5}, r"p_detect must be in \(0, 1\], got 1.5"),
        ({"p_detect": math.nan}, r"p_detect must be in \(0, 1\], got nan"),
        ({"p_gate": 0.0}, r"p_gate must be in \(0, 1\], got 0.0"),
        ({"clutter_density": -0.5}, r"clutter_density must be a finite number > 0, got -0.5"),
        ({"clutter_density": 0.0}, r"clutter_density must be a finite number > 0, got 0.0"),
        ({"clutter_density": math.inf}, r"clutter_density must be a finite number > 0, got inf"),
    ],
)
def test_bad_parameters_are_named(kwargs: dict[str, float], message: str) -> None:
    args = {"p_detect": 0.9, "clutter_density": 1.0, "p_gate": 0.99} | kwargs
    with pytest.raises(ValueError, match=message):
        jpda_marginals(np.zeros((2, 2)), np.ones((2, 2), dtype=bool), **args)


def test_bad_arrays_are_named() -> None:
    gate = np.ones((2, 3), dtype=bool)
    with pytest.raises(
        ValueError, match=r"gate must have the shape of log_likelihood \(2, 3\), got \(3, 2\)"
    ):
        jpda_marginals(np.zeros((2, 3)), gate.T, 0.9, 1.0)
    with pytest.raises(
        ValueError, match=r"log_likelihood must be \(n_tracks, n_detections\), got shape \(3,\)"
    ):
        jpda_marginals(np.zeros(3), gate, 0.9, 1.0)
    with pytest.raises(ValueError, match="gate must be boolean, got dtype int64"):
        jpda_marginals(np.zeros((2, 3)), gate.astype(np.int64), 0.9, 1.0)
    bad = np.zeros((2, 3))
    bad[1, 2] = np.nan
    with pytest.raises(ValueError, match="got nan at track 1, detection 2"):
        jpda_marginals(bad, gate, 0.9, 1.0)
    bad[1, 2] = np.inf
    with pytest.raises(ValueError, match="got inf at track 1, detection 2"):
        jpda_marginals(bad, gate, 0.9, 1.0)
    with pytest.raises(ValueError, match="max_exact must be >= 0, got -1"):
        jpda_marginals(np.zeros((2, 3)), gate, 0.9, 1.0, max_exact=-1)
    with pytest.raises(
        ValueError, match=r"need log_pair \(n, m\) and log_miss \(n,\), got \(2, 3\) and \(3,\)"
    ):
        cluster_marginals(np.zeros((2, 3)), np.zeros(3))
    with pytest.raises(ValueError, match="must not contain NaN"):
        cluster_marginals(np.full((2, 3), np.nan), np.zeros(2))
