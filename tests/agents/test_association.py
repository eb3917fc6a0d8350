"""Association: cost against a direct formula, gating, Hungarian vs brute force, greedy, edge cases."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import chi2

from agents.association import assign_greedy, assign_hungarian, chi2_gate, mahalanobis_cost
from track_envs.types import Gaussian


def random_gaussians(rng, n, d=2):
    a = rng.normal(size=(n, d, d))
    return Gaussian(rng.normal(size=(n, d)), a @ a.transpose(0, 2, 1) + 0.1 * np.eye(d))


def test_mahalanobis_cost_matches_the_formula():
    rng = np.random.default_rng(0)
    pred = random_gaussians(rng, 5)
    z = rng.normal(size=(7, 2))
    cost = mahalanobis_cost(pred, z)
    for i, j in itertools.product(range(5), range(7)):
        diff = z[j] - pred.mean[i]
        assert cost[i, j] == pytest.approx(diff @ np.linalg.solve(pred.cov[i], diff), rel=1e-10)


def test_gate_is_the_chi_square_quantile():
    assert chi2_gate(0.999, 2) == pytest.approx(chi2.ppf(0.999, 2))
    assert chi2_gate(0.999, 2) == pytest.approx(-2 * np.log(0.001))
    with pytest.raises(ValueError, match="p_gate"):
        chi2_gate(1.0, 2)


def brute_force(cost, gate):
    """Minimum of Σ assigned cost + gate · unassigned tracks over all admissible matchings."""
    n, m = cost.shape
    best = (gate * n, [])
    cols = list(range(m)) + [None] * n
    for perm in itertools.permutations(cols, n):
        pairs = [(i, j) for i, j in enumerate(perm) if j is not None]
        if any(cost[i, j] > gate for i, j in pairs):
            continue
        total = sum(cost[i, j] for i, j in pairs) + gate * (n - len(pairs))
        if total < best[0] - 1e-12:
            best = (total, pairs)
    return best[0]


@settings(max_examples=60, deadline=None)
@given(n=st.integers(0, 4), m=st.integers(0, 4), seed=st.integers(0, 10_000), gate=st.floats(0.1, 5.0))
def test_hungarian_is_optimal_with_miss_costs(n, m, seed, gate):
    cost = np.random.default_rng(seed).random((n, m)) * 6
    rows, cols = assign_hungarian(cost, gate)
    assert len(set(rows.tolist())) == len(rows) and len(set(cols.tolist())) == len(cols)
    assert np.all(cost[rows, cols] <= gate)
    total = cost[rows, cols].sum() + gate * (n - len(rows))
    assert total == pytest.approx(brute_force(cost, gate), abs=1e-9)


def test_all_gated_row_regression_stone_soup_824():
    cost = np.array([[0.5, 9.0], [50.0, 60.0], [9.0, 0.2]])
    rows, cols = assign_hungarian(cost, gate=1.0)
    assert rows.tolist() == [0, 2] and cols.tolist() == [0, 1]


def test_all_gated_frame_regression_stone_soup_824():
    rows, cols = assign_hungarian(np.full((3, 4), 100.0), gate=1.0)
    assert len(rows) == len(cols) == 0
    rows, cols = assign_hungarian(np.full((3, 4), np.inf), gate=1.0)
    assert len(rows) == 0


@pytest.mark.parametrize("assign", [assign_hungarian, assign_greedy])
@pytest.mark.parametrize("shape", [(0, 0), (0, 3), (3, 0)])
def test_empty_frames_on_either_side(assign, shape):
    rows, cols = assign(np.zeros(shape), 1.0)
    assert rows.shape == cols.shape == (0,)


def greedy_reference(cost, gate):
    pairs = sorted((cost[i, j], i, j) for i in range(cost.shape[0]) for j in range(cost.shape[1]))
    used_r, used_c, out = set(), set(), []
    for c, i, j in pairs:
        if c <= gate and i not in used_r and j not in used_c:
            used_r.add(i)
            used_c.add(j)
            out.append((i, j))
    return sorted(out)


@settings(max_examples=60, deadline=None)
@given(n=st.integers(0, 6), m=st.integers(0, 6), seed=st.integers(0, 10_000))
def test_greedy_matches_the_sorted_pairs_definition(n, m, seed):
    cost = np.random.default_rng(seed).random((n, m))
    rows, cols = assign_greedy(cost, 0.7)
    assert sorted(zip(rows.tolist(), cols.tolist(), strict=True)) == greedy_reference(cost, 0.7)


def test_greedy_can_be_worse_than_hungarian():
    cost = np.array([[1.0, 2.0], [1.5, 10.0]])
    r, c = assign_greedy(cost, 20.0)
    greedy_total = cost[r, c].sum()
    r, c = assign_hungarian(cost, 20.0)
    assert cost[r, c].sum() < greedy_total
