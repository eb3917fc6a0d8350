"""The one episode loop ([`agents.run_episode`][agents.run_episode]): the bench's metrics, truth for oracles,
a step limit."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import agents
import track_envs  # noqa: F401
from agents import AgentCapability, AgentTraits, EpisodeResult, make_agent, run_episode
from agents.detections_agent import DetectionsAgent
from track_apps.bench.cells import Cell
from track_apps.bench.runner import run_cell
from track_envs.wrappers import TrackingMetrics


def test_run_episode_is_exported():
    assert "run_episode" in agents.__all__ and "EpisodeResult" in agents.__all__


def test_same_metrics_as_the_bench_cell_of_the_same_seed():
    cell = Cell("SineTarget-v0", "gnn", "kf-cv", seed=3, steps=60)
    record = run_cell(cell)
    env = TrackingMetrics(gym.make("SineTarget-v0", max_episode_steps=60))
    result = run_episode(env, make_agent("gnn", predictor="kf-cv"), seed=3)
    assert isinstance(result, EpisodeResult)
    assert result.frames == record["timing"]["frames"] == 60 and result.truncated
    stored = {k: float(v) for k, v in record["metrics"].items()}  # "nan" is stored as a string
    assert list(result.metrics) == list(stored)
    np.testing.assert_equal(result.metrics, stored)  # bit-equal, NaN where NaN


class TruthCounter(DetectionsAgent):
    """An oracle: counts the truths it is handed, one per frame before act."""

    traits = AgentTraits(needs_truth=True)
    capabilities = frozenset({AgentCapability.TRUTH_OBSERVER})

    def reset(self, spec, *, seed=None):
        super().reset(spec, seed=seed)
        self.truths: list[object] = []
        self.acts = 0

    def observe_truth(self, info):
        assert len(self.truths) == self.acts  # before each act
        self.truths.append(info["truth"])

    def act(self, obs):
        self.acts += 1
        return super().act(obs)

    def episode_metrics(self):
        return {"truths_seen": float(len(self.truths))}


def test_a_truth_observer_gets_each_frames_truth_and_its_metrics_join():
    env = TrackingMetrics(gym.make("SineTarget-v0", max_episode_steps=12))
    agent = TruthCounter()
    result = run_episode(env, agent, seed=0)
    assert len(agent.truths) == agent.acts == result.frames == 12
    assert result.metrics["truths_seen"] == 12.0 and "mean_error" in result.metrics


def test_a_tracker_never_sees_the_truth():
    class Tracker(DetectionsAgent):
        def observe_truth(self, info):
            raise AssertionError("a tracker got the truth")

    result = run_episode(TrackingMetrics(gym.make("SineTarget-v0", max_episode_steps=5)), Tracker(), seed=0)
    assert result.frames == 5


def test_steps_stop_the_loop_early_with_the_metrics_so_far():
    env = TrackingMetrics(gym.make("SineTarget-v0", max_episode_steps=50))
    seen: list[int] = []
    result = run_episode(
        env, make_agent("detections"), seed=1, steps=7, on_step=lambda t, obs, report, r, info: seen.append(t)
    )
    assert result.frames == 7 and seen == list(range(7))
    assert not result.terminated and not result.truncated
    np.testing.assert_equal(result.metrics, env.episode_metrics())  # NaN where NaN
    assert "episode_metrics" not in result.info
    with pytest.raises(ValueError, match="steps must be >= 1"):
        run_episode(env, make_agent("detections"), seed=1, steps=0)


def test_an_env_without_the_metrics_wrapper_gives_no_metrics():
    result = run_episode(gym.make("SineTarget-v0", max_episode_steps=4), make_agent("detections"), seed=0)
    assert result.metrics == {} and result.frames == 4
