"""The public conformance checks pass on every registered env and predictor, and catch breakage.

(Every registered agent runs through ``check_agent`` in tests/agents/test_agents.py.)
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs
from predictors import available_predictors, make_predictor
from track_envs.testing import check_agent, check_predictor, check_tracking_env


@pytest.mark.parametrize("env_id", track_envs.ENV_IDS)
def test_every_env_passes(env_id):
    check_tracking_env(gym.make(env_id), steps=10)


@pytest.mark.parametrize("name", available_predictors())
def test_every_predictor_passes(name):
    check_predictor(make_predictor(name), gym.make("BeltSorter-v0").unwrapped.sensor_spec)


class LeakyAgent:
    """Reports one track pointing at a padding row: must be caught."""

    def reset(self, spec, *, seed=None):
        self.spec = spec

    def act(self, obs):
        from track_envs.report import pack_report

        last_row = self.spec.max_detections - 1
        return pack_report(np.array([0]), np.zeros((1, 2)), np.array([last_row]), self.spec.max_tracks)


def test_a_broken_agent_is_caught():
    env = gym.make("SineTarget-v0")
    with pytest.raises(AssertionError, match="detection rows"):
        check_agent(LeakyAgent(), env, steps=3)
