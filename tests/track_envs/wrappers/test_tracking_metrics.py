"""TrackingMetrics puts the episode's metrics into the last info, terminated or truncated."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from agents import make_agent
from track_envs.metrics import AssociationErrors, ClearMot, GospaMetric, Hota, SortingPrediction
from track_envs.wrappers import TrackingMetrics


def play(env, agent_name="gnn", seed=0):
    agent = make_agent(agent_name)
    obs, info = env.reset(seed=seed)
    agent.reset(env.get_wrapper_attr("sensor_spec"), seed=seed)
    infos, reports = [info], []
    while True:
        report = agent.act(obs)
        reports.append(report)
        obs, _, terminated, truncated, info = env.step(report)
        infos.append(info)
        if terminated or truncated:
            return infos, reports


def test_episode_metrics_on_truncation_equal_the_metrics_fed_by_hand():
    env = TrackingMetrics(gym.make("BeltSorter-v0", max_episode_steps=60))
    infos, reports = play(env)
    assert all("episode_metrics" not in i for i in infos[:-1])
    result = infos[-1]["episode_metrics"]
    assert len(reports) == 60
    c = env.unwrapped.gospa_c
    by_hand = [AssociationErrors(), ClearMot(threshold=c), GospaMetric(c=c), Hota(threshold=c)]
    for info, report in zip(infos[:-1], reports, strict=True):
        for metric in by_hand:
            # the env lists the particles behind merged detections; these metrics read them
            metric.update(info["truth"], info["detection_ids_merged"], report)
    sorting = SortingPrediction()  # the nozzle bar's score reads the primary id of each detection
    for info, report in zip(infos[:-1], reports, strict=True):
        sorting.update(info["truth"], info["detection_ids"], report)
    by_hand.append(sorting)
    expected = {k: v for m in by_hand for k, v in m.compute().items()}
    assert result.keys() == expected.keys()
    for key, value in expected.items():
        assert result[key] == pytest.approx(value, nan_ok=True), key
    assert all(isinstance(v, float) for v in result.values())
    assert {"e1", "e2", "e_mean", "mota", "id_switches", "idf1", "gospa", "hota"} <= result.keys()


def test_episode_metrics_on_termination():
    env = TrackingMetrics(gym.make("BeltReplay-v0", frames=(0, 80)))
    infos, _ = play(env)
    result = infos[-1]["episode_metrics"]
    assert result["e1"] == 0.0 and result["e2"] == 0.0
    assert result["mota"] > 0.95


def test_metrics_restart_with_each_episode():
    env = TrackingMetrics(gym.make("BeltReplay-v0", frames=(0, 40)))
    first = play(env)[0][-1]["episode_metrics"]
    second = play(env)[0][-1]["episode_metrics"]
    assert first == second


def test_step_before_reset_is_an_error():
    env = TrackingMetrics(gym.make("BeltReplay-v0"))
    with pytest.raises(RuntimeError, match="reset"):
        env.step(env.action_space.sample())


def test_no_tracking_scores_badly_on_identity():
    env = TrackingMetrics(gym.make("BeltReplay-v0", frames=(0, 60)))
    result = play(env, "detections")[0][-1]["episode_metrics"]
    assert result["e2"] > 0.9 and result["id_switches"] > 100
    assert np.isfinite(result["gospa"])
