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
        from track_envs.contracts.report import pack_report

        last_row = self.spec.max_detections - 1
        return pack_report(np.array([0]), np.zeros((1, 2)), np.array([last_row]), self.spec.max_tracks)


def test_a_broken_agent_is_caught():
    env = gym.make("SineTarget-v0")
    with pytest.raises(AssertionError, match="detection rows"):
        check_agent(LeakyAgent(), env, steps=3)


class TwinAgent:
    """Reports two tracks under one id: must be caught with the contract's AssertionError."""

    def reset(self, spec, *, seed=None):
        self.spec = spec

    def act(self, obs):
        from track_envs.contracts.report import pack_report

        return pack_report(np.array([5, 5]), np.zeros((2, 2)), np.array([-1, -1]), self.spec.max_tracks)


def test_an_agent_that_repeats_a_track_id_is_caught():
    # regression: the unique-id check came after validate_report, whose ValueError escaped first
    with pytest.raises(AssertionError, match=r"track ids must be unique within a report; repeated: \[5\]"):
        check_agent(TwinAgent(), gym.make("SineTarget-v0"), steps=3)


class TrustingAgent:
    """Reads every row whose mask is non-zero as a detection and checks nothing: must be caught."""

    def reset(self, spec, *, seed=None):
        self.spec = spec

    def act(self, obs):
        from track_envs.contracts.report import pack_report

        rows = np.flatnonzero(obs["mask"])[: self.spec.max_tracks]
        return pack_report(rows, obs["detections"][rows], rows, self.spec.max_tracks)


def test_an_agent_that_reads_mask_two_as_present_is_caught():
    with pytest.raises(AssertionError, match="must reject an observation with a mask value of 2"):
        check_agent(TrustingAgent(), gym.make("SineTarget-v0"), steps=3)


class ForgivingEnv(gym.Wrapper):
    """Scores every report as the empty one, so that no report is ever rejected: must be caught."""

    def step(self, action):
        from track_envs.contracts.report import empty_report

        base = self.env.unwrapped
        return self.env.step(empty_report(base.sensor_spec.max_tracks, base.position_shape))


def test_an_env_that_accepts_repeated_ids_is_caught():
    with pytest.raises(AssertionError, match="must reject a report whose live rows hold a repeated id"):
        check_tracking_env(ForgivingEnv(gym.make("SineTarget-v0")), steps=3)


def test_a_predictor_without_the_protocol_methods_is_caught():
    spec = gym.make("BeltSorter-v0").unwrapped.sensor_spec
    with pytest.raises(
        AssertionError, match=r"it lacks \['reset', 'start', 'predict', 'update', 'estimate'\]"
    ):
        check_predictor(object(), spec)


def test_assert_equal_trees_names_where_trees_differ():
    import numpy as np
    import pytest

    from track_envs.testing import assert_equal_trees

    tree = {"a": (np.arange(3), [1.0, {"b": np.zeros(2)}])}
    assert_equal_trees(tree, {"a": (np.arange(3), [1.0, {"b": np.zeros(2)}])})
    with pytest.raises(AssertionError, match=r"\['a'\]\[1\]\[1\]\['b'\]"):
        assert_equal_trees(tree, {"a": (np.arange(3), [1.0, {"b": np.ones(2)}])})
    with pytest.raises(AssertionError, match="lengths differ"):
        assert_equal_trees(tree, {"a": (np.arange(3),)})
