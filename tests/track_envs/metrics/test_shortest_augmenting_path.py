"""The numba assignment returns scipy's ``linear_sum_assignment`` result, also where ties allow several."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linear_sum_assignment as scipy_lsa

from track_envs.infra.assignment.shortest_augmenting_path import linear_sum_assignment


def cost_matrix(rng: np.random.Generator, kind: int) -> np.ndarray:
    shape = tuple(rng.integers(0, 10, size=2))
    if kind == 0:
        return rng.random(shape)
    if kind == 1:  # few distinct values: many optimal assignments
        return rng.choice([0.0, 0.25, 0.5, 1.0], size=shape)
    if kind == 2:
        return np.full(shape, 0.5)
    # motmetrics-style: impossible pairs priced far above the rest
    costs = rng.choice([0.0, 0.25, 0.5], size=shape)
    costs[rng.random(shape) < 0.6] = 2 * min(shape) * 1.5 + 1
    return costs


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 3))
def test_same_assignment_as_scipy(seed, kind):
    costs = cost_matrix(np.random.default_rng(seed), kind)
    rows, cols = linear_sum_assignment(costs)
    expected_rows, expected_cols = scipy_lsa(costs)
    assert rows.tolist() == expected_rows.tolist()
    assert cols.tolist() == expected_cols.tolist()


def test_non_finite_costs_give_no_assignment():
    assert [len(a) for a in linear_sum_assignment(np.array([[np.nan, 1.0]]))] == [0, 0]
    assert [len(a) for a in linear_sum_assignment(np.array([[np.inf], [np.inf]]))] == [0, 0]
