"""Live knobs of the GNN tracker: p_gate, recovery_inflation and noise_scale set between frames."""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from agents import make_agent
from predictors.kalman.predictor import KalmanPredictor


class NoScalePredictor:
    """A protocol predictor (a Kalman filter behind it) that cannot scale its measurement noise."""

    def __init__(self) -> None:
        self._kf = KalmanPredictor("cv")

    def reset(self, spec):
        self._kf.reset(spec)

    def start(self, z, velocity=None, velocity_cov=None):
        return self._kf.start(z, velocity=velocity, velocity_cov=velocity_cov)

    def predict(self, state):
        return self._kf.predict(state)

    def update(self, state, z, seen):
        return self._kf.update(state, z, seen)

    def estimate(self, state):
        return self._kf.estimate(state)


def _running_agent(frames: int = 20, **kwargs):
    env = gym.make("BeltSorter-v0", merge_touching=False)
    obs, _ = env.reset(seed=0)
    agent = make_agent("gnn", predictor="kf-ca", **kwargs)
    agent.reset(env.unwrapped.sensor_spec, seed=0)
    for _ in range(frames):
        obs, *_ = env.step(agent.act(obs))
    return env, agent, obs


def test_noise_scale_set_between_frames_scales_r_in_the_next_prediction():
    env, agent, obs = _running_agent()
    sigma = env.unwrapped.sensor_spec.noise_std
    scaled = copy.deepcopy(agent)
    scaled.noise_scale = 3.0
    agent.act(obs)
    scaled.act(obs)
    # the same tracks and the same P: the innovation covariances differ by exactly (9 - 1) σ² I
    np.testing.assert_array_equal(agent.last_prediction_ids, scaled.last_prediction_ids)
    diff = scaled.last_prediction.cov - agent.last_prediction.cov
    np.testing.assert_allclose(diff, np.broadcast_to(8 * sigma**2 * np.eye(2), diff.shape), rtol=1e-9)
    assert scaled.predictor.noise_scale == 3.0


def test_noise_scale_holds_across_reset_and_new_tracks_start_with_it():
    env, agent, _ = _running_agent(frames=1, noise_scale=2.0)
    sigma = env.unwrapped.sensor_spec.noise_std
    np.testing.assert_allclose(agent.predictor.R, (2 * sigma) ** 2 * np.eye(2))
    np.testing.assert_allclose(agent.track_covariances()[0], (2 * sigma) ** 2 * np.eye(2))
    agent.reset(env.unwrapped.sensor_spec, seed=1)
    assert agent.noise_scale == 2.0
    np.testing.assert_allclose(agent.predictor.R, (2 * sigma) ** 2 * np.eye(2))


def test_a_tighter_gate_set_between_frames_drops_the_far_detections():
    _, agent, obs = _running_agent()
    tight = copy.deepcopy(agent)
    tight.p_gate = 1e-6  # γ ≈ 2e-6: nothing passes
    tight.recovery_inflation = 1.0  # and no second chance
    agent.act(obs)
    tight.act(obs)
    assert np.count_nonzero(agent.last_prediction_detection >= 0) > 10
    assert np.count_nonzero(tight.last_prediction_detection >= 0) == 0


def test_recovery_inflation_set_between_frames_is_used():
    _, agent, _ = _running_agent(frames=2)
    agent.recovery_inflation = 100
    assert agent.recovery_inflation == 100.0 and isinstance(agent.recovery_inflation, float)


@pytest.mark.parametrize(
    ("name", "value", "message"),
    [
        ("p_gate", 1.0, "p_gate must be a probability in \\(0, 1\\), got 1.0"),
        ("p_gate", float("nan"), "p_gate must be a probability"),
        ("p_gate", "0.9", "p_gate must be a probability"),
        ("recovery_inflation", 0.5, "recovery_inflation must be a finite number >= 1, got 0.5"),
        ("recovery_inflation", float("inf"), "recovery_inflation must be a finite number >= 1"),
        ("recovery_inflation", True, "recovery_inflation must be a finite number >= 1"),
        ("noise_scale", 0.0, "noise_scale must be a finite number > 0, got 0.0"),
        ("noise_scale", -2, "noise_scale must be a finite number > 0"),
        ("noise_scale", None, "noise_scale must be a finite number > 0"),
    ],
)
def test_bad_knob_values_are_refused_and_leave_the_knob_as_it_was(name, value, message):
    _, agent, _ = _running_agent(frames=2)
    before = getattr(agent, name)
    with pytest.raises(ValueError, match=message):
        setattr(agent, name, value)
    assert getattr(agent, name) == before


def test_noise_scale_needs_a_predictor_that_can_scale():
    agent = make_agent("gnn", predictor=NoScalePredictor())
    agent.noise_scale = 1.0  # no change: fine
    with pytest.raises(ValueError, match="needs a predictor with set_noise_scale"):
        agent.noise_scale = 2.0
    with pytest.raises(ValueError, match="needs a predictor with set_noise_scale"):
        make_agent("gnn", predictor=NoScalePredictor(), noise_scale=2.0)
