"""A frame with more detections or tracks than the declared sizes grows the report, as track run's do.

The env (``overflow="grow"``) doubles its observation rows and follows a report with more rows than
``max_tracks``; the point trackers follow a grown observation and grow their report (doubled until
the live tracks fit, warned once). The live rows are those of a run whose sizes fit from the start.
"""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from agents import make_agent
from track_envs.contracts.report import growable_reports


def live_reports(agent_name: str, sizes: int, steps: int = 30) -> list[dict[str, np.ndarray]]:
    """The live rows of every report of ``agent_name`` (kf-cv) on BeltSorter-v0 seed 0."""
    env = gym.make("BeltSorter-v0", max_detections=sizes, max_tracks=sizes, max_targets=sizes)
    agent = make_agent(agent_name, predictor="kf-cv")
    obs, _ = env.reset(seed=0)
    agent.reset(env.unwrapped.sensor_spec, seed=0)
    out = []
    for _ in range(steps):
        report = agent.act(obs)
        live = report["mask"] == 1
        out.append({k: np.asarray(report[k])[live] for k in ("ids", "positions", "detection")})
        obs, _, terminated, truncated, info = env.step(report)
        assert info["dropped_detections"] == 0
        if terminated or truncated:
            break
    return out


@pytest.mark.parametrize("agent_name", ["gnn", "jpda"])
def test_a_tracker_outgrowing_the_sizes_reports_every_track(agent_name):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        grown = live_reports(agent_name, sizes=16)
    messages = [str(w.message) for w in caught]
    assert any("live tracks exceed the report's max_tracks=16; the report grows to 32" in m for m in messages)
    assert any("exceeds max_tracks=16; max_tracks grows to 32" in m for m in messages)
    assert max(len(r["ids"]) for r in grown) > 16
    fitting = live_reports(agent_name, sizes=512)
    assert len(grown) == len(fitting)
    for a, b in zip(grown, fitting, strict=True):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])


def test_inside_track_runs_context_the_report_grows_to_the_tracks_silently():
    env = gym.make("BeltSorter-v0", max_detections=16, max_tracks=16, max_targets=16)
    agent = make_agent("gnn", predictor="kf-cv")
    obs, _ = env.reset(seed=0)
    agent.reset(env.unwrapped.sensor_spec, seed=0)
    with warnings.catch_warnings(record=True) as caught, growable_reports():
        warnings.simplefilter("always")
        report = agent.act(obs)
    n = int(report["mask"].sum())
    assert n > 16 and len(report["mask"]) == n
    assert not [w for w in caught if "live tracks exceed" in str(w.message)]
