"""The LSTM displacement model of the particle filter (predictors/displacement_lstm/model.py): the
common-displacement contract, state per target, restarts, the compiled frame, rotation invariance,
the speed scale, bad arguments."""

from __future__ import annotations

import numpy as np
import pytest

from predictors.displacement import DisplacementModel
from predictors.displacement_lstm.model import LSTMDisplacement
from track_envs.envs.single_target import n_frames_for, sine_trajectory, to_world

SINE = sine_trajectory(n_frames_for(25.0))


def _histories(x: np.ndarray) -> list[np.ndarray]:
    """The histories (T, t, 2), t = 1 … n, a filter passes while it estimates ``x`` (T, n, 2)."""
    return [x[:, :t] for t in range(1, x.shape[1] + 1)]


def test_is_a_displacement_model_and_propose_is_displacement_plus_noise() -> None:
    a, b = LSTMDisplacement(sigma_p=[0.5, 2.0]), LSTMDisplacement(sigma_p=[0.5, 2.0])
    assert isinstance(a, DisplacementModel)
    np.testing.assert_array_equal(a.std, [0.1, 0.4])
    x = np.stack([SINE[:30], SINE[:30] * 2.0])
    particles = np.random.default_rng(0).normal(size=(2, 50, 2))
    for history in _histories(x):
        got = a.propose(particles, history, np.random.default_rng(len(history[0])))
        eps = np.random.default_rng(len(history[0])).standard_normal(particles.shape)
        expected = particles + b.displacement(history)[:, None, :] + a.std[:, None, None] * eps
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)


def test_follows_the_noiseless_sine_from_its_estimates() -> None:
    model = LSTMDisplacement()
    errors = []
    for t, history in enumerate(_histories(SINE[None, :-1]), start=1):
        d = model.displacement(history)
        if t >= 2:  # a heading exists from the first step on
            errors.append(np.linalg.norm(history[0, -1] + d[0] - SINE[t]))
        else:
            np.testing.assert_array_equal(d, 0.0)
    assert np.mean(errors) < 0.004 and np.max(errors[10:]) < 0.02  # Δ = 0.2


def test_state_is_per_target_and_a_restart_resets_it() -> None:
    rng = np.random.default_rng(1)
    x = np.stack([SINE[:60], to_world(SINE[:60], 30.0, (5.0, 1.0)), SINE[:60] + rng.normal(0, 0.02, (60, 2))])
    x[2, :25] = np.nan  # target 2 (re)starts at frame 25: NaN before, as the filter's history is
    batched, alone = LSTMDisplacement(), [LSTMDisplacement() for _ in range(3)]
    for t, history in enumerate(_histories(x), start=1):
        d = batched.displacement(history)
        for k in range(3):
            if k == 2 and t < 25:
                continue
            dk = alone[k].displacement(history[k : k + 1, max(0, 24 if k == 2 else 0) :])
            np.testing.assert_allclose(d[k], dk[0], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(LSTMDisplacement().displacement(np.full((2, 4, 2), np.nan)), 0.0)


def test_compiled_frame_equals_the_numpy_composition() -> None:
    rng = np.random.default_rng(4)
    x = np.broadcast_to(SINE[:120], (6, 120, 2)) + rng.normal(0, 0.03, (6, 120, 2))
    x[1, 40:45] = x[1, 39]  # a stop: the heading is kept
    x[2, :30] = np.nan  # starts late
    x[3, :70] = np.nan  # a restart: the history before it is wiped
    x[4, :] = x[4, 0]  # never moves
    x[5, 60:] = np.nan  # not started (any more)
    fast, slow = LSTMDisplacement(backend="numba"), LSTMDisplacement(backend="numpy")
    for history in _histories(x):
        np.testing.assert_allclose(fast.displacement(history), slow.displacement(history), atol=1e-12)
    np.testing.assert_allclose(fast._h, slow._h, atol=1e-12)
    np.testing.assert_array_equal(fast._has_heading, slow._has_heading)


def test_rotation_invariance() -> None:
    a, b = LSTMDisplacement(), LSTMDisplacement()
    rot = to_world(SINE[:80], 45.0, (3.0, -2.0))
    c, s = np.cos(np.pi / 4), np.sin(np.pi / 4)
    for h, g in zip(_histories(SINE[None, :80]), _histories(rot[None]), strict=True):
        d, e = a.displacement(h)[0], b.displacement(g)[0]
        np.testing.assert_allclose(e, [c * d[0] - s * d[1], s * d[0] + c * d[1]], atol=1e-9)


def test_the_cost_does_not_depend_on_the_particle_count() -> None:
    """One LSTM step per target: the displacement is the same for N = 1 and N = 2000."""
    outs = []
    for n in (1, 2000):
        model = LSTMDisplacement(sigma_p=0.0)
        for history in _histories(SINE[None, :20]):
            moved = model.propose(np.zeros((1, n, 2)), history, np.random.default_rng(0))
        outs.append(moved[0])
        assert model._h.shape == (1, 25)
    np.testing.assert_array_equal(outs[1], np.broadcast_to(outs[0], (2000, 2)))


def test_bad_arguments_are_named() -> None:
    with pytest.raises(ValueError, match=r"backend must be one of \('numba', 'numpy'\), got 'torch'"):
        LSTMDisplacement(backend="torch")
    with pytest.raises(ValueError, match=r"speed_scale must be a finite number > 0, got 0.0"):
        LSTMDisplacement(speed_scale=0.0)
    model = LSTMDisplacement()
    bad = np.zeros((1, 3, 2))
    bad[0, 1, 0] = np.nan
    with pytest.raises(
        ValueError, match=r"history\[\(0, 1\)\] is \[nan, 0.0\]: an estimate is either finite"
    ):
        model.displacement(bad)
    with pytest.raises(ValueError, match=r"must not hold ±inf; history\[\(0, 2\)\] is \[inf, 0.0\]"):
        model.displacement(np.array([[[0.0, 0.0], [1.0, 0.0], [np.inf, 0.0]]]))
    with pytest.raises(ValueError, match=r"history must have shape \(T, t, 2\), got \(3, 2\)"):
        model.displacement(np.zeros((3, 2)))


def test_speed_scale_follows_the_step() -> None:
    """The sine model records Δ = 0.2; a filter with Δ = 2 (the sine in other units) scales speeds."""
    assert LSTMDisplacement(step=2.0).speed_scale == pytest.approx(10 * LSTMDisplacement().speed_scale)
    model = LSTMDisplacement(step=2.0)
    big = 10.0 * SINE[None, :40]
    small = LSTMDisplacement()
    for h in _histories(big):
        d = model.displacement(h)
        e = small.displacement(h / 10.0)
    np.testing.assert_allclose(d, 10.0 * e, rtol=1e-9)
