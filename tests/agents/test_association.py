"""Association: cost against a direct formula, gating, Hungarian vs brute force, greedy, edge cases,
and the compiled one-pass gate-and-assign (spatial index, sparse pairs) against the dense two-step
path."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import chi2

from agents.tracking import _kernels as _association_kernels
from agents.tracking.assign import (
    assign_greedy,
    assign_hungarian,
    associate_greedy,
    associate_hungarian,
    chi2_gate,
    mahalanobis_cost,
)
from track_envs.infra.assignment.lone_pairs import split_dense
from track_envs.values.types import Gaussian


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


# -- the compiled gate-and-assign path -------------------------------------------------------


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_mahalanobis_cost_matches_the_formula_in_every_dimension(dim):
    rng = np.random.default_rng(dim)
    pred = random_gaussians(rng, 6, dim)
    z = rng.normal(size=(5, dim))
    cost = mahalanobis_cost(pred, z)
    ref = np.einsum(
        "nmi,nij,nmj->nm", z[None] - pred.mean[:, None], np.linalg.inv(pred.cov), z[None] - pred.mean[:, None]
    )
    np.testing.assert_allclose(cost, ref, rtol=1e-10)


def test_mahalanobis_cost_names_a_covariance_that_is_not_positive_definite():
    pred = random_gaussians(np.random.default_rng(0), 3)
    pred.cov[1] = -pred.cov[1]
    with pytest.raises(np.linalg.LinAlgError, match="track 1 is not positive definite"):
        mahalanobis_cost(pred, np.zeros((2, 2)))
    with pytest.raises(np.linalg.LinAlgError, match="track 1"):
        associate_hungarian(pred, np.zeros((2, 2)), 1.0)


def clustered_frame(rng, n, m, dim, spread):
    """Predictions and detections around 1–12 centres: clusters where rows compete for columns,
    lone pairs where a centre has one of each."""
    k = int(rng.integers(1, 13))
    centres = rng.uniform(size=(k, dim))
    pred = Gaussian(
        centres[rng.integers(k, size=n)] + rng.normal(scale=spread, size=(n, dim)),
        np.broadcast_to(np.eye(dim) * spread**2, (n, dim, dim)) * rng.uniform(0.5, 2.0, size=(n, 1, 1)),
    )
    z = centres[rng.integers(k, size=m)] + rng.normal(scale=spread, size=(m, dim))
    return pred, z


@settings(max_examples=80, deadline=None)
@given(
    n=st.integers(0, 12),
    m=st.integers(0, 12),
    dim=st.sampled_from([1, 2, 3]),
    spread=st.sampled_from([1e-3, 0.05, 0.3]),
    seed=st.integers(0, 10_000),
)
def test_gated_pairs_are_the_admissible_entries_of_the_dense_costs(n, m, dim, spread, seed):
    pred, z = clustered_frame(np.random.default_rng(seed), n, m, dim, spread)
    gate = chi2_gate(0.999, dim)
    ptr, cols, pair_cost, bad, wide = _association_kernels.gated_pairs(
        np.ascontiguousarray(pred.mean), np.ascontiguousarray(pred.cov), z, gate
    )
    assert bad == wide == -1
    cost = mahalanobis_cost(pred, z)
    rows = np.repeat(np.arange(n), np.diff(ptr))
    ref_rows, ref_cols = np.nonzero(cost <= gate)  # row-major: rows, then columns ascending
    np.testing.assert_array_equal(rows, ref_rows)
    np.testing.assert_array_equal(cols, ref_cols)
    np.testing.assert_array_equal(pair_cost, cost[ref_rows, ref_cols])  # bit-identical costs
    _, rest_rows, rest_cols = split_dense(cost, gate)
    if len(rest_rows):  # the solver's problem [C | M] with one finite stand-in for gated entries
        sub = cost[np.ix_(rest_rows, rest_cols)]
        k, ok = len(rest_rows), sub <= gate
        big = 2.0 * (gate + 1.0) * (k + 1) + np.abs(sub[ok]).max()
        expected = np.hstack([np.where(ok, sub, big), np.where(np.eye(k, dtype=bool), gate, big)])
        problem = _association_kernels.rest_problem(cost, gate, rest_rows, rest_cols)
        np.testing.assert_array_equal(problem, expected)
    # and the one-pass association gives the pairs of the two-step one, exactly
    for associate, assign in [(associate_hungarian, assign_hungarian), (associate_greedy, assign_greedy)]:
        rows, cols = associate(pred, z, gate)
        ref_r, ref_c = assign(mahalanobis_cost(pred, z), gate)
        np.testing.assert_array_equal(rows, ref_r)
        np.testing.assert_array_equal(cols, ref_c)
        assert rows.dtype == cols.dtype == np.int64


@pytest.mark.parametrize(("n", "m"), [(0, 0), (0, 4), (4, 0)])
def test_one_pass_association_of_empty_frames(n, m):
    pred = random_gaussians(np.random.default_rng(0), n)
    for associate in (associate_hungarian, associate_greedy):
        rows, cols = associate(pred, np.zeros((m, 2)), 13.8)
        assert rows.shape == cols.shape == (0,)


def test_one_pass_association_of_an_all_gated_frame():
    pred = Gaussian(np.zeros((3, 2)), np.broadcast_to(np.eye(2) * 1e-6, (3, 2, 2)))
    rows, cols = associate_hungarian(pred, np.full((4, 2), 5.0), 13.8)
    assert len(rows) == len(cols) == 0


def test_detections_of_another_dimension_are_named():
    pred = random_gaussians(np.random.default_rng(0), 3)
    for call in (
        lambda: mahalanobis_cost(pred, np.zeros((4, 3))),
        lambda: associate_hungarian(pred, np.zeros(4), 1.0),
    ):
        with pytest.raises(ValueError, match=r"z must have shape \(m, D=2\)"):
            call()
