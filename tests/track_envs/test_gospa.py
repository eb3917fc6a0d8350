"""GOSPA against closed-form cases and a brute-force oracle over all assignments."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist

from track_envs.metrics.gospa import DENSE_LIMIT, gospa


def brute_force(x, y, c, p):
    """min over partial assignments γ of Σ d^p + c^p/2 (|X| + |Y| − 2|γ|), α = 2 (definition)."""
    m, n = len(x), len(y)
    best = c**p / 2 * (m + n)
    for k in range(1, min(m, n) + 1):
        for rows in itertools.combinations(range(m), k):
            for cols in itertools.permutations(range(n), k):
                d = np.linalg.norm(x[list(rows)] - y[list(cols)], axis=1)
                if np.all(d < c):
                    best = min(best, float(np.sum(d**p)) + c**p / 2 * (m + n - 2 * k))
    return best ** (1 / p)


def test_closed_form_cases():
    assert gospa(np.zeros((0, 2)), np.zeros((0, 2)), c=1.0).distance == 0.0
    # one missed target: sqrt(c^2/2)
    assert gospa(np.zeros((1, 2)), np.zeros((0, 2)), c=2.0).distance == pytest.approx(np.sqrt(2.0))
    # one pair at distance 0.5 < c
    r = gospa(np.array([[0.0, 0.0]]), np.array([[0.3, 0.4]]), c=1.0)
    assert r.distance == pytest.approx(0.5) and (r.missed, r.false) == (0, 0)
    # a pair farther than c counts as one miss and one false track
    r = gospa(np.array([[0.0, 0.0]]), np.array([[3.0, 4.0]]), c=1.0)
    assert r.distance == pytest.approx(1.0) and (r.missed, r.false) == (1, 1)


@settings(max_examples=60, deadline=None)
@given(
    m=st.integers(0, 4),
    n=st.integers(0, 4),
    seed=st.integers(0, 10_000),
    c=st.floats(0.1, 3.0),
)
def test_matches_the_definition(m, n, seed, c):
    rng = np.random.default_rng(seed)
    x, y = rng.random((m, 2)) * 3, rng.random((n, 2)) * 3
    assert gospa(x, y, c).distance == pytest.approx(brute_force(x, y, c, 2.0), rel=1e-9, abs=1e-12)


def dense_oracle(x, y, c, p):
    """GOSPA^p = c^p/2 (m + n) + min over matchings of Σ (d^p − c^p) over pairs with d < c, solved
    densely by scipy (pairs at d >= c priced 0, i.e. left unassigned).

    Returns (GOSPA, Σ d^p over the assigned close pairs, their number)."""
    m, n = len(x), len(y)
    if m == 0 or n == 0:
        return (c**p / 2 * (m + n)) ** (1 / p), 0.0, 0
    d = cdist(x, y)
    gain = np.where(d < c, d**p - c**p, 0.0)
    rows, cols = linear_sum_assignment(gain)
    total = c**p / 2 * (m + n) + gain[rows, cols].sum()
    close = d[rows, cols] < c
    return max(total, 0.0) ** (1 / p), float((d[rows, cols][close] ** p).sum()), int(close.sum())


def point_sets(rng, kind):
    m, n, dims = rng.integers(0, 60), rng.integers(0, 60), rng.integers(1, 4)
    if kind == 0:  # crowded: every truth has several estimates within c
        x = rng.uniform(0, 3, (m, dims))
        return x, rng.uniform(0, 3, (n, dims))
    if kind == 1:  # a grid: ties, and pairs exactly at the cut-off
        return rng.integers(0, 6, (m, dims)) * 0.5, rng.integers(0, 6, (n, dims)) * 0.5
    if kind == 2:  # tracking-like: estimates near their truths, some clutter and misses
        x = rng.uniform(0, 30, (m, dims))
        near = x[rng.permutation(m)[: min(m, n)]] + rng.normal(0, 0.2, (min(m, n), dims))
        return x, np.concatenate([near, rng.uniform(0, 30, (n - len(near), dims))])
    return rng.uniform(0, 1, (m, dims)), rng.uniform(100, 101, (n, dims))  # all far apart


@settings(max_examples=120, deadline=None)
@given(
    st.integers(0, 2**32 - 1),
    st.integers(0, 3),
    st.sampled_from([0.5, 1.0]),
    st.sampled_from([1.0, 2.0, 3.0]),
)
def test_sparse_gospa_equals_a_dense_assignment(seed, kind, c, p):
    """Lone pairs taken directly, the rest assigned: the optimum of the dense problem."""
    x, y = point_sets(np.random.default_rng(seed), kind)
    result = gospa(x, y, c, p)
    expected, loc, pairs = dense_oracle(x, y, c, p)
    assert result.distance == pytest.approx(expected, rel=1e-12, abs=1e-12)
    assert result.missed - result.false == len(x) - len(y)
    if kind != 1:  # without ties the optimum, hence the decomposition, is unique
        assert (result.missed, result.false) == (len(x) - pairs, len(y) - pairs)
        assert result.localisation == pytest.approx(loc, rel=1e-12, abs=1e-15)


def test_a_belt_sized_frame_equals_the_dense_assignment_to_rounding():
    """Hundreds of close pairs (numpy sums these pairwise, the kernel in row order): the same
    distance and localisation to a relative 1e-12."""
    rng = np.random.default_rng(3)
    x = rng.uniform(0, 1, (400, 2))
    y = np.concatenate([x[40:] + rng.normal(0, 2e-3, (360, 2)), rng.uniform(0, 1, (30, 2))])
    result = gospa(x, y, c=5e-3)
    expected, loc, pairs = dense_oracle(x, y, 5e-3, 2.0)
    assert pairs > 300 and (result.missed, result.false) == (400 - pairs, 390 - pairs)
    assert result.distance == pytest.approx(expected, rel=1e-12)
    assert result.localisation == pytest.approx(loc, rel=1e-12)


def test_bad_parameters_are_named():
    with pytest.raises(ValueError, match="cut-off c"):
        gospa(np.zeros((1, 2)), np.zeros((1, 2)), c=0.0)
    with pytest.raises(ValueError, match="cut-off c"):
        gospa(np.zeros((1, 2)), np.zeros((1, 2)), c=np.inf)
    with pytest.raises(ValueError, match="order p"):
        gospa(np.zeros((1, 2)), np.zeros((1, 2)), c=1.0, p=0.5)
    with pytest.raises(ValueError, match="same D"):
        gospa(np.zeros((1, 2)), np.zeros((1, 3)), c=1.0)


def _one_problem_core(x, y, c, p):
    """gospa_core with every competing row in one ``[C | M]`` problem (the path before components)."""
    from track_envs.infra.assignment.lone_pairs import split_sparse
    from track_envs.metrics.close_pairs import close_pairs
    from track_envs.metrics.gospa import _assign_rest

    cp = c**p
    ptr, cols, dist = close_pairs(x, y, c * (1.0 + 1e-9))
    keep = (dist**2 if p == 2.0 else dist**p) <= cp
    rows = np.repeat(np.arange(len(x)), np.diff(ptr))[keep]
    cols, dist = cols[keep], dist[keep]
    ptr = np.zeros(len(x) + 1, np.int64)
    np.cumsum(np.bincount(rows, minlength=len(x)), out=ptr[1:])
    cost = dist * dist if p == 2.0 else dist**p
    col_of, rest_rows, rest_cols = split_sparse(ptr, cols, len(y))
    if len(rest_rows):
        _assign_rest(ptr, cols, cost, rest_rows, rest_cols, len(y), cp, col_of)
    loc, n_close = 0.0, 0
    for i in range(len(x)):
        for e in range(ptr[i], ptr[i + 1]):
            if col_of[i] >= 0 and cols[e] == col_of[i]:
                if dist[e] < c:
                    loc += cost[e]
                    n_close += 1
                break
    return loc, n_close


@pytest.mark.parametrize("seed", range(6))
def test_components_give_the_one_problem_assignment(seed):
    """Solving the competing rows per connected component (falling back on a tie) gives exactly
    the localisation and pairs of one problem over all of them, also with integer coordinates."""
    from track_envs.metrics.gospa import gospa_core

    rng = np.random.default_rng(seed)
    x = rng.uniform(0, 20, (300, 2))
    y = np.concatenate([x[:200] + rng.normal(0, 0.4, (200, 2)), rng.uniform(0, 20, (80, 2))])
    if seed % 2:
        x, y = np.round(x), np.round(y)
    for c, p in ((1.0, 2.0), (2.0, 1.0)):
        assert gospa_core(x, y, c, p, c**p) == _one_problem_core(x, y, c, p)


def test_a_tie_in_a_frame_above_the_dense_limit_is_broken_inside_its_component():
    """1,100 squares of two truths and two estimates, all four distances 1 (two optimal matchings
    each): 2,200 rest rows x 2,200 estimates exceed DENSE_LIMIT, so no frame-wide matrix is built;
    the value is the optimum's, as on a small frame of the same squares."""
    k = 1100
    corner = 10.0 * np.arange(k)[:, None] * np.array([[1.0, 0.0]])
    right, up = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    truth = np.concatenate([corner, corner + right + up])
    estimates = np.concatenate([corner + right, corner + up])
    assert len(truth) * len(estimates) > DENSE_LIMIT
    big = gospa(truth, estimates, c=2.0)
    assert (big.localisation, big.missed, big.false) == (2.0 * k, 0, 0)
    small = gospa(truth[[0, k]], estimates[[0, k]], c=2.0)
    assert (small.localisation, small.missed, small.false) == (2.0, 0, 0)
