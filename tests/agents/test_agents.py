"""Behaviour tests parametrised over every registered agent, and the registry."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs
from agents import AGENTS, agent_applies_to, agent_traits, available_agents, make_agent
from track_envs.infra.registry import UnknownArgumentError
from track_envs.testing import check_agent

# oracles that read the truth (needs_truth, e.g. one-step) cannot act without it: their
# behaviour is tested on their own (tests/agents/test_one_step.py)
TRACKERS = [a for a in available_agents() if not agent_traits(AGENTS.factory(a)).needs_truth]


def test_unknown_agent_lists_the_valid_names():
    with pytest.raises(ValueError, match=r"valid names are \['detections'"):
        make_agent("kalman-magic")


@pytest.mark.parametrize("name", TRACKERS)
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


def _agent_on_its_env(name: str):
    """Agent ``name`` reset on the first registered env it applies to, and that env's first observation."""
    for env_id in track_envs.ENV_IDS:
        env = gym.make(env_id)
        if agent_applies_to(name, env.unwrapped.position_shape, env.unwrapped.max_targets):
            agent = make_agent(name)
            obs, _ = env.reset(seed=0)
            agent.reset(env.unwrapped.sensor_spec, seed=0)
            return agent, obs
    raise AssertionError(f"{name} applies to no registered env")


@pytest.mark.parametrize("value", [2, -1])
@pytest.mark.parametrize("name", available_agents())
def test_every_agent_rejects_mask_values_other_than_zero_and_one(name, value):
    """gnn used to read padding rows with mask 2 or -1 as detections (256 tracks instead of 35)."""
    agent, obs = _agent_on_its_env(name)
    padding = np.flatnonzero(obs["mask"] == 0)
    obs["mask"][padding] = value
    with pytest.raises(ValueError, match=rf"must hold 0 or 1; rows \[{padding[0]}, {padding[1]},"):
        agent.act(obs)


@pytest.mark.parametrize("name", available_agents())
def test_every_agent_rejects_a_float_mask_nan_rows_and_wrong_shapes(name):
    agent, obs = _agent_on_its_env(name)
    with pytest.raises(ValueError, match=r"0/1 integer array \(or bool\)"):
        agent.act({**obs, "mask": obs["mask"].astype(np.float32)})
    live = np.flatnonzero(obs["mask"] == 1)
    nan = obs["detections"].copy()
    nan[live[0]] = np.nan
    with pytest.raises(ValueError, match=rf"masked-in detection rows \[{live[0]}\] hold NaN or inf"):
        agent.act({**obs, "detections": nan})
    for shape in [(10, 2), obs["detections"].shape[::-1]]:
        with pytest.raises(ValueError, match=r"observation\['detections'\] must be a float array of shape"):
            agent.act({**obs, "detections": np.zeros(shape, np.float32)})


@pytest.mark.parametrize("name", available_agents())
def test_every_agent_names_a_non_mapping_observation(name):
    agent, obs = _agent_on_its_env(name)
    message = "observation must be a mapping with keys 'detections' and 'mask', got"
    with pytest.raises(ValueError, match=f"{message} tuple"):
        agent.act((obs["detections"], obs["mask"]))
    with pytest.raises(ValueError, match=f"{message} ndarray"):
        agent.act(np.zeros((2, 256)))


@pytest.mark.parametrize("name", TRACKERS)
def test_a_rejected_observation_leaves_the_agent_as_it_was(name):
    agent, obs = _agent_on_its_env(name)
    twin, _ = _agent_on_its_env(name)
    bad = {**obs, "mask": np.where(obs["mask"] == 0, 2, 1).astype(np.int8)}
    with pytest.raises(ValueError):
        agent.act(bad)
    report, expected = agent.act(obs), twin.act(obs)
    for key, value in expected.items():
        np.testing.assert_array_equal(report[key], value)


@pytest.mark.parametrize("name", available_agents())
def test_an_unknown_keyword_names_the_agent_arguments(name):
    with pytest.raises(
        UnknownArgumentError, match=r"has no argument 'not_an_argument'; its arguments are \["
    ):
        make_agent(name, not_an_argument=1)
