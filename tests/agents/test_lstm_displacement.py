"""The particle filter and the ``pf`` agent with the LSTM displacement model (``model="lstm"``):
accuracy against the Brownian model, rotation invariance, the agent checks, user weights, bad
arguments (the model itself: tests/predictors/test_displacement_lstm_model.py)."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from agents import make_agent
from agents.particle.agent import BatchParticleFilter
from predictors.belt_lstm.predictor import shipped_weights
from predictors.displacement import Brownian
from predictors.displacement_lstm.model import LSTMDisplacement
from predictors.training.model_file import ModelFileError
from track_envs.envs.single_target import draw_detections, n_frames_for, sine_trajectory, to_world
from track_envs.testing import check_agent
from track_envs.wrappers import TrackingMetrics


def _batched_runs(model: object, rotation: float, runs: int = 16, periods: float = 25.0) -> float:
    """Mean error of ``runs`` filters (one batch) on the sine rotated by ``rotation`` degrees."""
    truth = to_world(sine_trajectory(n_frames_for(periods)), rotation, (0.0, 0.0))
    rng = np.random.default_rng(11)
    pf = BatchParticleFilter(runs, 100, model, sigma_m=0.1, sigma_0=0.1, rng=rng)  # type: ignore[arg-type]
    errors = []
    for t, x in enumerate(truth):
        z, seen = draw_detections(np.broadcast_to(x, (runs, 2)), rng, noise_std=0.1, p_detect=0.5)
        if t == 0:
            seen[:] = True
        else:
            pf.predict()
        errors.append(np.linalg.norm(pf.update(z, seen) - x, axis=1))
    return float(np.mean(errors))


def test_lstm_pf_beats_brownian_and_is_rotation_invariant() -> None:
    """Jung et al. (2019), Exp. 1 setting (N = 100, p_d = 0.5, σ_p = σ_m = 0.5). Measured: Brownian
    13.5 (16 runs), LSTM 0.283 on the sine and 0.287 rotated by 45° (64 batched runs each; the
    runs' spread makes two such means differ by up to ~5%)."""
    brownian = _batched_runs(Brownian(0.5), 0.0)
    lstm = _batched_runs(LSTMDisplacement(sigma_p=0.5), 0.0, runs=64)
    rotated = _batched_runs(LSTMDisplacement(sigma_p=0.5), 45.0, runs=64)
    assert lstm < 0.4 < 5.0 < brownian
    assert abs(rotated - lstm) < 0.1 * lstm


def test_pf_agent_with_lstm_passes_the_agent_checks() -> None:
    env = gym.make("SineTarget-v0", p_detect=0.5, periods=3.0)
    check_agent(make_agent("pf", model="lstm"), env, steps=60)
    check_agent(make_agent("pf", model="lstm"), gym.make("SineTarget-v0", clutter_rate=2.0), steps=60)


def _episode(seed: int, **agent_kwargs: object) -> tuple[dict, list]:
    env = TrackingMetrics(gym.make("SineTarget-v0", p_detect=0.5, periods=5.0))
    agent = make_agent("pf", n_particles=100, sigma_p=0.5, **agent_kwargs)
    obs, _ = env.reset(seed=seed)
    agent.reset(env.get_wrapper_attr("sensor_spec"), seed=seed)
    reports = []
    while True:
        reports.append(agent.act(obs))
        obs, _, terminated, truncated, info = env.step(reports[-1])
        if terminated or truncated:
            return info["episode_metrics"], reports


def test_same_agent_seed_same_report() -> None:
    (m1, a), (m2, b) = _episode(3, model="lstm"), _episode(3, model="lstm")
    np.testing.assert_equal(m1, m2)  # NaN occlusion error without an occlusion
    for x, y in zip(a, b, strict=True):
        for key in x:
            np.testing.assert_array_equal(x[key], y[key])
    assert m1["mean_error"] < 0.5


def test_user_weights_by_path(tmp_path: Path) -> None:
    from track_apps.cli.train import main

    out = tmp_path / "mine"
    argv = ["displacement-lstm", "--sine", "--periods", "4", "--window", "48", "--epochs", "2"]
    assert main([*argv, "--no-progress", "--out", str(out)]) == 0
    model = make_agent("pf", model="lstm", model_weights=str(out)).model
    assert isinstance(model, LSTMDisplacement) and model.net.path == out.with_suffix(".json")
    metrics, _ = _episode(0, model="lstm", model_weights=out)
    assert np.isfinite(metrics["mean_error"])


def test_bad_arguments_are_named() -> None:
    with pytest.raises(ModelFileError, match=r"holds a 'nll-lstm' model; expected 'displacement-lstm'"):
        make_agent("pf", model="lstm", model_weights=shipped_weights("nll-lstm", "cylinder"))
    with pytest.raises(ModelFileError, match=r"missing\.json does not exist"):
        make_agent("pf", model="lstm", model_weights="missing")
    with pytest.raises(
        ValueError, match=r"model_weights='w' is for a learned model \['lstm'\], not model='cv'"
    ):
        make_agent("pf", model="cv", model_weights="w")
    with pytest.raises(ValueError, match=r"sigma_p must be finite and >= 0, got -1"):
        make_agent("pf", model="lstm", sigma_p=-1.0)
