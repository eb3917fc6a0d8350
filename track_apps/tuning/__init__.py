"""RL-tuned association: GateTuning-v0 and its policies (PPO via stable-baselines3).

Importing this package registers ``GateTuning-v0`` (idempotent)::

    import gymnasium as gym
    import track_apps.tuning
    env = gym.make("GateTuning-v0", base_env="BeltSorter-v0")
    policy = track_apps.tuning.load_policy()            # the shipped PPO policy, numpy only
    obs, info = env.reset(seed=0)
    action, _ = policy.predict(obs, deterministic=True)

stable-baselines3 (the ``rl`` extra) is only needed to train
(`track_apps.tuning.train`, the ``track tune`` command); the shipped policy runs
without it.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from track_apps.tuning.adaptive import NisRule
from track_apps.tuning.evaluate import episode_errors, paired
from track_apps.tuning.informed import SensorInformedPolicy
from track_apps.tuning.knobs import Knob, knob_ranges, make_knobs
from track_apps.tuning.policy import FixedPolicy, TunedPolicy, load_policy

__all__ = [
    "ENV_ID",
    "FixedPolicy",
    "Knob",
    "NisRule",
    "SensorInformedPolicy",
    "TunedPolicy",
    "episode_errors",
    "knob_ranges",
    "load_policy",
    "make_knobs",
    "paired",
    "register_tuning_env",
]

ENV_ID = "GateTuning-v0"


def register_tuning_env() -> None:
    """Register GateTuning-v0 unless it is registered already."""
    if ENV_ID not in registry:
        register(id=ENV_ID, entry_point="track_apps.tuning.env:GateTuningEnv")


register_tuning_env()
