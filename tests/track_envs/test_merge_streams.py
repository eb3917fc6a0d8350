"""gnn + kf-ca on a BeltSorter-v0 stream with frequent merged blobs: pinned association errors.

The default belt (cylinders) merges ≈4 particles into blobs per frame. Measured on seed 0,
300 frames (e_mean, ID switches):

* merged stream, scored with merged ids (a merged detection may go to either particle's track):
  0.096, 107;
* the same stream scored on one id per detection (the metrics before merged ids): 0.179, 158;
* the stream without merging (``merge_touching=False``): 0.0016, 1.

So a tracker that knows nothing of merges loses tracks in them (the gap is what merge handling in
the tracker has to close), and scoring merged detections by their primary id alone counts
correct associations as errors.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from agents import make_agent
from track_envs.metrics import AssociationErrors, ClearMot
from track_envs.wrappers import TrackingMetrics

STEPS = 300


def run_gnn(seed: int = 0, **env_kwargs) -> tuple[dict[str, float], dict[str, float], float]:
    """Episode metrics (merged ids), the same metrics on plain ids, and merged detections per frame."""
    # the stream the figures above were measured on: without the nozzle bar, whose particles stay
    # on the simulated belt longer (the seed's stream departs after a few dozen frames)
    kwargs = {"nozzle_offset": None} | env_kwargs
    env = TrackingMetrics(gym.make("BeltSorter-v0", max_episode_steps=STEPS, **kwargs))
    c = env.get_wrapper_attr("gospa_c")
    plain = [AssociationErrors(), ClearMot(threshold=c)]
    agent = make_agent("gnn", predictor="kf-ca")
    obs, info = env.reset(seed=seed)
    agent.reset(env.get_wrapper_attr("sensor_spec"), seed=seed)
    merges = 0
    while True:
        report = agent.act(obs)
        for metric in plain:
            metric.update(info["truth"], info["detection_ids"], report)
        merges += int(np.count_nonzero(info["detection_ids_merged"][:, 1] >= 0))
        obs, _, terminated, truncated, info = env.step(report)
        if terminated or truncated:
            break
    by_primary = {k: v for m in plain for k, v in m.compute().items()}
    return info["episode_metrics"], by_primary, merges / STEPS


@pytest.fixture(scope="module")
def merged_stream():
    return run_gnn(seed=0)


def test_the_default_belt_merges_often(merged_stream):
    _, _, merges_per_frame = merged_stream
    assert merges_per_frame > 2.0  # measured 4.4


def test_gnn_association_errors_on_merged_blobs_stay_within_the_pinned_bound(merged_stream):
    metrics, _, _ = merged_stream
    assert metrics["e_mean"] <= 0.13  # measured 0.096
    assert metrics["id_switches"] <= 140  # measured 107


def test_primary_ids_alone_count_merged_associations_as_errors(merged_stream):
    metrics, by_primary, _ = merged_stream
    assert by_primary["e1"] > 1.5 * metrics["e1"]  # measured 0.148 vs 0.066
    assert by_primary["e_mean"] > 0.13  # the pinned bound fails on the old scoring (0.179)


def test_merges_are_what_makes_the_stream_hard(merged_stream):
    metrics, _, _ = merged_stream
    unmerged, _, merges = run_gnn(seed=0, merge_touching=False)
    assert merges == 0
    assert unmerged["e_mean"] <= 0.01  # measured 0.0016
    assert metrics["e_mean"] > 10 * unmerged["e_mean"]
