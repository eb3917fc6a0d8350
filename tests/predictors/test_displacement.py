"""Rotation / speed displacement data (predictors/displacement/geometry.py): eq. (3) of Jung et al. (2019),
the kept heading through stops, and the exact inverse."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from predictors.displacement.geometry import (
    apply_displacement,
    displacements_of,
    observe_step,
    positions_from_displacements,
    wrap_angle,
)


def _walk(rng: np.random.Generator, shape: tuple[int, ...], stop: float = 0.3) -> np.ndarray:
    """Random walks (..., n, 2) with a fraction ``stop`` of zero-length steps."""
    steps = rng.normal(size=(*shape, 2)) * (rng.random((*shape, 1)) >= stop)
    steps[..., 0, :] = rng.normal(size=(*shape[:-1], 2)) * 5  # any start
    return np.cumsum(steps, axis=-2)


def _round_trip(x: np.ndarray) -> np.ndarray:
    d = displacements_of(x)
    return positions_from_displacements(d.rotation, d.speed, x[..., 0, :], d.first_heading)


@pytest.mark.parametrize("seed", range(5))
def test_round_trip_is_exact_with_zero_length_steps(seed: int) -> None:
    rng = np.random.default_rng(seed)
    x = _walk(rng, (4, 300))
    x[1, 5:40] = x[1, 4]  # a long stop
    x[2] = x[2, 0]  # never moves
    x[3, :10] = x[3, 0]  # starts with a stop
    np.testing.assert_allclose(_round_trip(x), x, rtol=0, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 40), st.floats(0.0, 0.9), st.integers(0, 2**31))
def test_round_trip_property(n: int, stop: float, seed: int) -> None:
    x = _walk(np.random.default_rng(seed), (n,), stop)
    np.testing.assert_allclose(_round_trip(x), x, rtol=0, atol=1e-9)


def test_first_entries_and_the_paper_definition_where_the_previous_step_moves() -> None:
    rng = np.random.default_rng(1)
    x = _walk(rng, (50,), stop=0.0)
    d = displacements_of(x)
    assert d.rotation[0] == 0 and d.speed[0] == 0 and d.rotation[1] == 0  # no heading before step 1
    v = np.diff(x, axis=0)
    c = np.arctan2(v[:, 1], v[:, 0])
    np.testing.assert_allclose(d.speed[1:], np.linalg.norm(v, axis=1))
    expected = (c[1:] - c[:-1] + np.pi) % (2 * np.pi) - np.pi  # eq. (3), wrapped
    np.testing.assert_allclose(np.cos(d.rotation[2:] - expected), 1.0)
    assert np.all((d.rotation > -np.pi) & (d.rotation <= np.pi))
    assert d.first_heading == pytest.approx(c[0])


def test_a_stop_keeps_the_heading() -> None:
    # east, stop, stop, north: the turn after the stop is measured against the kept heading (east)
    x = np.array([[0, 0], [1, 0], [1, 0], [1, 0], [1, 1]], dtype=float)
    d = displacements_of(x)
    np.testing.assert_allclose(d.rotation, [0, 0, 0, 0, np.pi / 2])
    np.testing.assert_allclose(d.speed, [0, 1, 0, 0, 1])


def test_a_u_turn_is_plus_pi() -> None:
    d = displacements_of(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 0.0]]))
    assert d.rotation[2] == np.pi
    assert wrap_angle(-np.pi) == np.pi and wrap_angle(3 * np.pi / 2) == pytest.approx(-np.pi / 2)


def test_rotation_and_translation_invariance() -> None:
    x = _walk(np.random.default_rng(2), (80,))
    a = np.deg2rad(45)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    d, e = displacements_of(x), displacements_of(x @ rot.T + [3.0, -7.0])
    np.testing.assert_allclose(np.cos(e.rotation - d.rotation), 1.0)
    np.testing.assert_allclose(e.speed, d.speed, atol=1e-12)


def test_streaming_step_equals_the_batch_function() -> None:
    x = _walk(np.random.default_rng(3), (6, 60))
    d = displacements_of(x)
    heading, has = np.zeros(6), np.zeros(6, dtype=bool)
    for t in range(1, 60):
        r, s, heading, has = observe_step(x[:, t] - x[:, t - 1], heading, has)
        np.testing.assert_array_equal(r, d.rotation[:, t])
        np.testing.assert_array_equal(s, d.speed[:, t])


def test_apply_displacement_turns_then_moves() -> None:
    c, x = apply_displacement(np.array([0.0, np.pi]), np.zeros((2, 2)), [np.pi / 2, np.pi / 2], [2.0, 1.0])
    np.testing.assert_allclose(c, [np.pi / 2, -np.pi / 2])
    np.testing.assert_allclose(x, [[0.0, 2.0], [0.0, -1.0]], atol=1e-15)


def test_bad_positions_are_named() -> None:
    x = np.zeros((5, 2))
    x[3, 1] = np.nan
    with pytest.raises(ValueError, match=r"positions must be finite; positions\[\(3,\)\] is \[0.0, nan\]"):
        displacements_of(x)
    with pytest.raises(ValueError, match=r"shape \(\.\.\., n >= 1, 2\), got \(5, 3\)"):
        displacements_of(np.zeros((5, 3)))
    with pytest.raises(ValueError, match="same shape"):
        positions_from_displacements(np.zeros(3), np.zeros(4), np.zeros(2), 0.0)
