"""GOSPA against closed-form cases and a brute-force oracle over all assignments."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from track_envs.metrics.gospa import gospa


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


def test_bad_parameters_are_named():
    with pytest.raises(ValueError, match="cut-off c"):
        gospa(np.zeros((1, 2)), np.zeros((1, 2)), c=0.0)
    with pytest.raises(ValueError, match="order p"):
        gospa(np.zeros((1, 2)), np.zeros((1, 2)), c=1.0, p=0.5)
