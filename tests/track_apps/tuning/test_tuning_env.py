"""GateTuning-v0: registration, env checkers, determinism, vectorisation, reward, diagnostics."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

import track_apps.tuning
from track_apps.tuning import FixedPolicy, NisRule
from track_apps.tuning.diagnostics import FEATURES, N_FEATURES
from track_apps.tuning.env import GateTuningEnv

SMALL = {"frames_per_step": 3, "episode_steps": 4}


def test_registered_on_import_and_made_with_a_base_env():
    assert track_apps.tuning.ENV_ID in gym.registry
    track_apps.tuning.register_tuning_env()  # idempotent
    env = gym.make("GateTuning-v0", base_env="BeltSorter-v0", **SMALL)
    assert env.observation_space.shape == (N_FEATURES + 3,)
    assert env.action_space.shape == (3,)
    np.testing.assert_array_equal(env.action_space.low, -1.0)


def test_passes_gymnasium_and_sb3_check_env_without_warnings():
    pytest.importorskip("stable_baselines3")
    from gymnasium.utils.env_checker import check_env as gym_check
    from stable_baselines3.common.env_checker import check_env as sb3_check

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        gym_check(gym.make("GateTuning-v0", **SMALL).unwrapped)
        sb3_check(gym.make("GateTuning-v0", **SMALL), warn=True)
    assert [str(w.message) for w in caught] == []


def _episode(env, seed, action):
    obs, info = env.reset(seed=seed)
    trace = [obs]
    rewards = []
    while True:
        obs, reward, terminated, truncated, info = env.step(action)
        trace.append(obs)
        rewards.append(reward)
        if terminated or truncated:
            return np.array(trace), rewards, info


def test_deterministic_per_seed():
    env = gym.make("GateTuning-v0", **SMALL)
    action = np.array([0.2, -0.3, 0.5], np.float32)
    a = _episode(env, 11, action)
    b = _episode(env, 11, action)
    c = _episode(env, 12, action)
    np.testing.assert_array_equal(a[0], b[0])
    assert a[1] == b[1] and a[2] == b[2]
    assert not np.array_equal(a[0], c[0])


def test_the_return_is_minus_the_episode_association_errors():
    env = gym.make("GateTuning-v0", frames_per_step=10, episode_steps=8)
    _, rewards, info = _episode(env, 0, FixedPolicy().action)
    assert info["association_errors"] > 0
    assert -sum(rewards) == info["association_errors"]
    assert info["frames"] == 80
    assert set(info["sensor"]) == {"noise_std", "p_detect", "clutter_rate"}
    assert info["knobs"] == pytest.approx(FixedPolicy.GNN_DEFAULTS)


def test_a_constant_setting_gives_the_errors_of_the_track_bench_cell():
    """The grid baseline runs in track bench: its cell of seed s is the episode GateTuning-v0
    plays from seed s with that setting held constant."""
    from track_apps.bench.cells import Cell
    from track_apps.bench.runner import run_cell
    from track_apps.tuning.evaluate import record_errors

    setting = {"p_gate": 0.9999, "recovery_inflation": 400.0, "noise_scale": 4.0}
    cell = Cell(
        "BeltSorter-v0",
        "gnn",
        "kf-ca",
        3,
        (("drift", "belt"), ("max_targets", 512), ("max_tracks", 512)),
        1,
        60,
        tuple(sorted({**setting, "predict_sorting": False}.items())),
    )
    bench = record_errors(run_cell(cell))
    env = gym.make("GateTuning-v0", frames_per_step=10, episode_steps=6)
    _, _, info = _episode(env, 3, FixedPolicy(setting).action)
    assert info["association_errors"] == bench


def test_vectorises():
    envs = gym.make_vec("GateTuning-v0", num_envs=2, vectorization_mode="sync", **SMALL)
    obs, _ = envs.reset(seed=[1, 2])
    assert obs.shape == (2, N_FEATURES + 3)
    obs, reward, *_ = envs.step(np.zeros((2, 3), np.float32))
    assert obs.shape == (2, N_FEATURES + 3) and reward.shape == (2,)
    envs.close()


def test_gospa_reward_sums_the_base_rewards():
    env = gym.make("GateTuning-v0", reward="gospa", **SMALL)
    _, rewards, _ = _episode(env, 0, np.zeros(3, np.float32))
    assert all(r < 0 for r in rewards)


def test_the_nis_features_see_an_under_declared_noise():
    """4x the declared noise: the mean NIS grows by ~16 (log ≈ 2.8) until the noise scale is 4."""
    kwargs = {"drift": None, "base_kwargs": {"noise_std": 4e-4, "measurement_noise_std": 1e-4}}
    env = gym.make("GateTuning-v0", frames_per_step=20, episode_steps=3, **kwargs)
    nis = FEATURES.index("log_mean_nis")
    told, _, _ = _episode(env, 0, FixedPolicy().action)
    fitted, _, _ = _episode(env, 0, FixedPolicy({"noise_scale": 4.0}).action)
    assert told[-1, nis] - fitted[-1, nis] > 1.5
    assert abs(fitted[-1, nis]) < 1.0
    assert NisRule().predict(told[-1])[0][2] > told[-1, N_FEATURES + 2] + 0.2  # the rule scales up


def test_bad_actions_and_arguments_are_refused():
    env = gym.make("GateTuning-v0", **SMALL)
    with pytest.raises(RuntimeError, match="before reset"):
        env.unwrapped.step(np.zeros(3))
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action must have shape \\(3,\\)"):
        env.unwrapped.step(np.zeros(4))
    with pytest.raises(ValueError, match="in \\[-1, 1\\]"):
        env.unwrapped.step(np.array([2.0, 0.0, 0.0]))
    with pytest.raises(ValueError, match="reward must be one of"):
        GateTuningEnv(reward="mota")
    with pytest.raises(ValueError, match="range of p_gate"):
        GateTuningEnv(ranges={"p_gate": (0.5, 1.5)})
    with pytest.raises(ValueError, match="frames_per_step"):
        GateTuningEnv(frames_per_step=0)
    with pytest.raises(ValueError, match="KeypointWalkers-v0"):
        GateTuningEnv(base_env="KeypointWalkers-v0")


def test_renders_the_base_frame():
    env = gym.make("GateTuning-v0", render_mode="rgb_array", **SMALL)
    env.reset(seed=0)
    env.step(np.zeros(3, np.float32))
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3
