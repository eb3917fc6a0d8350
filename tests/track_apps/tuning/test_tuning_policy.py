"""Policies: the 256-step PPO smoke run and its export, the shipped policy offline, the baselines."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import predictors
from predictors.training.model_file import ModelFileError, load_model
from track_apps.tuning import FixedPolicy, NisRule, load_policy
from track_apps.tuning.diagnostics import N_FEATURES
from track_apps.tuning.policy import KIND, shipped_policy_path


def test_a_256_step_ppo_run_exports_an_actor_equal_to_sb3(tmp_path):
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    from track_apps.tuning.train import TrainConfig, train

    config = TrainConfig(
        timesteps=256,
        n_envs=2,
        vec="dummy",
        n_steps=64,
        batch_size=64,
        n_epochs=2,
        checkpoint_every=128,
        env_kwargs={"frames_per_step": 2, "episode_steps": 16},
    )
    _, summary = train(config, tmp_path / "run", progress=False, command="test")
    assert summary["timesteps"] == 256
    assert sorted(p.name for p in (tmp_path / "run" / "checkpoints").iterdir())[0].startswith("ppo_")
    policy = load_policy(tmp_path / "run" / "policy")
    obs = np.random.default_rng(0).uniform(-3, 3, (64, N_FEATURES + 3)).astype(np.float32)
    ours, _ = policy.predict(obs, deterministic=True)
    theirs, _ = PPO.load(tmp_path / "run" / "ppo_final", device="cpu").predict(obs, deterministic=True)
    np.testing.assert_allclose(ours, theirs, atol=1e-5)
    assert policy.predict(obs[0])[0].shape == (3,)
    assert load_model(tmp_path / "run" / "policy").meta["training"]["command"] == "test"


def test_the_shipped_policy_loads_and_acts_offline_without_torch_or_sb3():
    code = """
import sys


class Offline:  # no torch, no stable-baselines3
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in ("torch", "stable_baselines3"):
            raise ImportError(f"{name} is blocked")


sys.meta_path.insert(0, Offline())
import gymnasium as gym
import numpy as np
import track_apps.tuning
policy = track_apps.tuning.load_policy()
env = gym.make("GateTuning-v0", frames_per_step=2, episode_steps=3)
obs, _ = env.reset(seed=0)
for _ in range(3):
    action, state = policy.predict(obs, deterministic=True)
    assert action.shape == (3,) and action.dtype == np.float32 and state is None
    assert np.all(np.abs(action) <= 1)
    obs, *_ = env.step(action)
assert "torch" not in sys.modules and "stable_baselines3" not in sys.modules
print("ok")
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"


def test_the_shipped_policy_records_how_it_was_made():
    model = load_model(shipped_policy_path(), kind=KIND)
    assert model.meta["training"]["command"].startswith("track-tune train")
    assert model.meta["training"]["wall_s"] > 0
    assert model.architecture["obs_dim"] == N_FEATURES + 3


def test_load_policy_names_a_wrong_or_missing_file(tmp_path):
    with pytest.raises(ModelFileError, match="does not exist"):
        load_policy(tmp_path / "nothing")
    with pytest.raises(ModelFileError, match="expected 'gate-tuning-ppo'"):
        load_policy(Path(predictors.__file__).parent / "weights" / "lstm-cylinder")


def test_sampled_actions_spread_around_the_mean():
    policy = load_policy()
    obs = np.zeros(N_FEATURES + 3, np.float32)
    rng = np.random.default_rng(0)
    samples = np.array([policy.predict(obs, deterministic=False, rng=rng)[0] for _ in range(200)])
    assert samples.std(axis=0).min() > 0
    with pytest.raises(ValueError, match="observation must have shape"):
        policy.predict(np.zeros(5))


def test_fixed_policy_and_nis_rule_act_like_sb3_policies():
    env = gym.make("GateTuning-v0", frames_per_step=2, episode_steps=2)
    obs, _ = env.reset(seed=0)
    fixed = FixedPolicy({"p_gate": 0.9999})
    action, state = fixed.predict(obs)
    assert state is None and action.shape == (3,)
    assert fixed.predict(np.stack([obs, obs]))[0].shape == (2, 3)
    _, _, _, _, info = env.step(action)
    assert info["knobs"]["p_gate"] == pytest.approx(0.9999)
    assert NisRule().predict(np.stack([obs, obs]))[0].shape == (2, 3)
    with pytest.raises(ValueError, match="unknown knob"):
        FixedPolicy({"gate": 0.9})
    with pytest.raises(ValueError, match="gain must be"):
        NisRule(gain=0.0)
