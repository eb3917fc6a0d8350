"""Bootstrap particle filter (agents/particle/agent.py): resampling oracle, accuracy, determinism,
batching."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from filterpy.monte_carlo import resampling as filterpy_resampling

import track_envs  # noqa: F401
from agents import make_agent
from agents.particle.agent import (
    BatchParticleFilter,
    ParticleFilterAgent,
    systematic_resample,
    systematic_resample_batch,
)
from predictors.displacement import Brownian, ConstantVelocityDisplacement
from track_envs.wrappers import TrackingMetrics


def reference_systematic_resample(weights: np.ndarray, u: float) -> np.ndarray:
    """Systematic resampling written out independently: position ``p_k = (u + k) / N`` picks the
    first ``j`` with ``p_k < cumsum(w)[j]``. Every position lies below 1 = the total weight in exact
    arithmetic, so the last cumulative sum is made unbounded: a position that rounding put at or
    beyond the computed last sum (1 − 1 ulp, or a position rounded up to 1) picks the last particle,
    where filterpy overruns."""
    n = len(weights)
    cumsum = np.cumsum(weights)
    cumsum[-1] = np.inf
    positions = (u + np.arange(n)) / n
    return np.searchsorted(cumsum, positions, side="right")


@pytest.mark.parametrize("seed", range(40))
def test_systematic_resample_equals_filterpy_for_the_same_uniform_draw(seed, monkeypatch):
    """Every draw against the independent reference; where filterpy does not overrun (its index
    passes the last cumulative sum when rounding leaves it below 1), against filterpy too."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 300))
    w = rng.random(n) ** int(rng.integers(1, 10))
    w[rng.random(n) < 0.3] = 0.0
    w[0] += 1e-3
    w /= w.sum()
    u = float(rng.random()) if seed % 4 else 0.0
    got = systematic_resample(w, u)
    np.testing.assert_array_equal(got, reference_systematic_resample(w, u))
    monkeypatch.setattr(filterpy_resampling, "random", lambda: u)
    try:
        expected = filterpy_resampling.systematic_resample(w)
    except IndexError:  # filterpy's overrun: the reference above covers this draw
        assert np.cumsum(w)[-1] < (u + n - 1) / n
        return
    np.testing.assert_array_equal(got, expected)


def test_the_reference_resampler_covers_the_draws_where_filterpy_overruns(monkeypatch):
    """Weights whose cumulative sum rounds below the last position: filterpy raises IndexError,
    ours and the reference pick the last particle for it."""
    rng = np.random.default_rng(0)
    overruns = 0
    for _ in range(2000):
        n = int(rng.integers(2, 300))
        w = rng.random(n)
        w /= w.sum()
        if np.cumsum(w)[-1] >= 1.0:
            continue
        u = np.nextafter(1.0, 0.0)
        monkeypatch.setattr(filterpy_resampling, "random", lambda u=u: u)
        try:
            filterpy_resampling.systematic_resample(w)
        except IndexError:
            overruns += 1
            got = systematic_resample(w, u)
            np.testing.assert_array_equal(got, reference_systematic_resample(w, u))
            assert got[-1] == n - 1
    assert overruns > 0


def test_uniform_weights_resample_to_the_identity():
    for n in (1, 3, 10, 1000):
        np.testing.assert_array_equal(systematic_resample(np.full(n, 1.0 / n), 0.5), np.arange(n))


def test_batched_resampling_equals_row_by_row():
    rng = np.random.default_rng(0)
    w = rng.random((7, 50)) ** 3
    w /= w.sum(axis=1, keepdims=True)
    u = rng.random(7)
    flat = systematic_resample_batch(w, u)
    for r in range(7):
        np.testing.assert_array_equal(flat[r] - 50 * r, systematic_resample(w[r], u[r]))


def run_episode(env_id="SineTarget-v0", seed=0, agent_kwargs=None, **env_kwargs):
    env = TrackingMetrics(gym.make(env_id, **env_kwargs))
    agent = make_agent("pf", **(agent_kwargs or {}))
    obs, info = env.reset(seed=seed)
    agent.reset(env.get_wrapper_attr("sensor_spec"), seed=seed)
    reports = []
    while True:
        report = agent.act(obs)
        assert env.action_space.contains(report)
        reports.append(report)
        obs, _, terminated, truncated, info = env.step(report)
        if terminated or truncated:
            return info["episode_metrics"], reports


@pytest.mark.parametrize("env_id", ["SineTarget-v0", "PiecewiseTarget-v0"])
def test_error_is_close_to_the_measurement_noise_at_full_detection(env_id):
    metrics, _ = run_episode(env_id, p_detect=1.0, sigma_m=0.1, periods=5.0)
    noise = 0.1 * 0.2 * np.sqrt(np.pi / 2)  # mean norm of 2-D Gaussian noise with std σ_m·Δ
    assert metrics["mean_error"] < 2.0 * noise
    assert metrics["lost"] == 0.0


def test_paper_setting_tracks_and_occlusion_costs_accuracy():
    metrics, _ = run_episode(p_detect=1.0, sigma_m=0.5, occlusion_length=25, periods=5.0)
    assert metrics["lost"] == 0.0
    assert metrics["occlusion_error"] > 2 * metrics["mean_error"]


def test_pf_is_deterministic_under_a_seed():
    _, a = run_episode(seed=3, periods=2.0)
    _, b = run_episode(seed=3, periods=2.0)
    for x, y in zip(a, b, strict=True):
        for key in x:
            np.testing.assert_array_equal(x[key], y[key])


def test_reports_one_track_with_the_detection_row_used():
    env = gym.make("SineTarget-v0", p_detect=0.5, periods=1.0)
    agent = ParticleFilterAgent()
    obs, _ = env.reset(seed=1)
    agent.reset(env.unwrapped.sensor_spec, seed=1)
    started = False
    for _ in range(30):
        report = agent.act(obs)
        live = report["mask"] == 1
        assert live.sum() <= 1
        started |= bool(live.any())
        if live.any():
            row = report["detection"][0]
            assert row == (np.flatnonzero(obs["mask"])[0] if obs["mask"].any() else -1)
        else:
            assert not started
        obs, *_ = env.step(report)
    assert started


def test_clutter_is_gated_out():
    metrics, _ = run_episode(clutter_rate=2.0, p_detect=0.9, periods=5.0)
    assert metrics["lost"] == 0.0 and metrics["mean_error"] < 2.0


def test_same_code_runs_one_target_or_many():
    rng = np.random.default_rng(0)
    pf = BatchParticleFilter(5, 200, Brownian(np.linspace(0.5, 2.0, 5)), sigma_m=0.1, sigma_0=0.1, rng=rng)
    truth = np.stack([np.arange(50) * 0.2, np.sin(np.arange(50) * 0.2)], axis=1)
    for x in truth:
        est = pf.step(np.broadcast_to(x, (5, 2)) + rng.normal(0, 0.1, (5, 2)), np.ones(5, bool))
    assert est.shape == (5, 2) and np.all(np.linalg.norm(est - truth[-1], axis=1) < 0.5)
    assert pf.history.shape == (5, 50, 2)


def test_prediction_only_without_measurement_and_not_started_is_nan():
    pf = BatchParticleFilter(2, 10, Brownian(0.0), sigma_m=0.1, sigma_0=0.0, rng=np.random.default_rng(0))
    est = pf.step(np.array([[1.0, 2.0], [0.0, 0.0]]), np.array([True, False]))
    np.testing.assert_allclose(est[0], [1.0, 2.0])
    assert np.isnan(est[1]).all()
    est = pf.step(np.zeros((2, 2)), np.array([False, False]))  # σ_p = 0: nothing moves
    np.testing.assert_allclose(est[0], [1.0, 2.0])


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"n_particles": 0}, "n_particles"),
        ({"sigma_p": -1.0}, "sigma_p"),
        ({"sigma_m": -0.5}, "sigma_m"),
        ({"sigma_0": -0.5}, "sigma_0"),
        ({"model": "lstm-magic"}, "brownian"),
        ({"p_gate": 1.5}, "p_gate"),
        ({"resample_threshold": 2.0}, "resample_threshold"),
    ],
)
def test_bad_kwargs_raise_errors_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        make_agent("pf", **kwargs)


def test_batch_filter_bad_arguments_are_named():
    with pytest.raises(ValueError, match="n_particles"):
        BatchParticleFilter(1, 0, Brownian(), sigma_m=0.1, sigma_0=0.1, rng=np.random.default_rng())
    with pytest.raises(ValueError, match="sigma_m"):
        BatchParticleFilter(1, 5, Brownian(), sigma_m=0.0, sigma_0=0.1, rng=np.random.default_rng())


def test_agent_draws_are_independent_of_the_env_stream_for_the_same_seed():
    """Regression: default_rng(seed) is the env's own np_random stream for that seed."""
    from agents.particle.agent import agent_rng

    env_stream = np.random.default_rng(7).standard_normal(6)
    assert not np.allclose(agent_rng(7).standard_normal(6), env_stream)
    assert np.array_equal(agent_rng(7).standard_normal(6), agent_rng(7).standard_normal(6))


def test_restart_forgets_the_lost_track_history():
    """Regression: after a restart the constant-velocity model read the jump as a velocity."""
    pf = BatchParticleFilter(
        1, 200, ConstantVelocityDisplacement(), sigma_m=0.1, sigma_0=0.1, rng=np.random.default_rng(0)
    )
    for _ in range(5):
        pf.step(np.zeros((1, 2)), np.array([True]))
    pf.started[:] = False  # what the agent does when it restarts a target
    estimates = [pf.step(np.array([[20.0, 0.0]]), np.array([True]))[0] for _ in range(4)]
    assert np.allclose(estimates, [20.0, 0.0], atol=0.5)


def test_weighted_moments_run_on_one_blas_thread(monkeypatch):
    """The particles' weighted mean and covariance are per-frame products: one BLAS thread."""
    import contextlib

    from threadpoolctl import threadpool_limits

    from agents.particle import agent as agent_module
    from track_envs.infra.blas_threads import blas_info

    inside: list[set[int]] = []
    pinned = agent_module.frame_blas

    @contextlib.contextmanager
    def recording():
        with pinned():
            inside.append({int(i["num_threads"]) for i in blas_info()})
            yield

    monkeypatch.setattr(agent_module, "frame_blas", recording)
    pf = BatchParticleFilter(3, 6000, Brownian(0.5), sigma_m=0.1, sigma_0=0.1, rng=np.random.default_rng(0))
    pf.update(np.zeros((3, 2)), np.ones(3, bool))
    blas_info()
    with threadpool_limits(2, user_api="blas"):
        mean, cov = pf.moments()
        np.testing.assert_array_equal(pf.estimate, mean)
    assert len(inside) == 2 and all(s == {1} for s in inside)
    assert cov.shape == (3, 2, 2) and np.all(np.linalg.eigvalsh(cov) > 0)
