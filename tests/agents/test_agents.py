"""Behaviour tests parametrised over every registered agent, and the registry."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs
from agents import agent_applies_to, available_agents, make_agent
from track_envs.testing import check_agent


def test_unknown_agent_lists_the_valid_names():
    with pytest.raises(ValueError, match=r"valid names are \['detections'"):
        make_agent("kalman-magic")


@pytest.mark.parametrize("name", available_agents())
@pytest.mark.parametrize("env_id", track_envs.ENV_IDS)
def test_agent_reports_valid_actions_on_every_env_it_applies_to(name, env_id):
    env = gym.make(env_id)
    if not agent_applies_to(name, env.unwrapped.position_shape, env.unwrapped.max_targets):
        pytest.skip(f"{name} does not apply to {env_id}")
    # valid reports, detection rows of real detections, unique ids, finite rewards, determinism
    check_agent(make_agent(name), env, steps=30)


@pytest.mark.parametrize("name", available_agents())
def test_act_before_reset_is_an_error(name):
    with pytest.raises(RuntimeError, match="reset"):
        make_agent(name).act({"detections": np.zeros((4, 2), np.float32), "mask": np.zeros(4, np.int8)})


def test_detections_agent_matches_the_sensor_exactly_at_zero_noise():
    env = gym.make("BeltSorter-v0", noise_std=0.0, merge_touching=False)  # a detection per particle
    agent = make_agent("detections")
    obs, _ = env.reset(seed=0)
    agent.reset(env.unwrapped.sensor_spec)
    _, reward, *_ = env.step(agent.act(obs))
    assert reward == pytest.approx(0.0, abs=1e-6)


def test_applicability_follows_position_shape_and_target_count():
    assert agent_applies_to("gnn", (2,), 256)
    assert not agent_applies_to("gnn", (17, 2))
    assert agent_applies_to("pose-baseline", (17, 2))
    assert agent_applies_to("pf", (2,), 1)
    assert not agent_applies_to("pf", (2,), 256)
