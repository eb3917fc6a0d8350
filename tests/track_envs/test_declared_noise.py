"""The noise an env adds and the measurement noise its sensor spec declares are separate.

Regression: replaying real centroids with ``noise_std=0`` used to declare R = (1 µm)² to the
tracker (the Kalman floor), so its gates were far tighter than the recording's own ≈30 µm scatter
and tracks broke at every jitter.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from agents import make_agent
from track_envs.contracts.report import empty_report
from track_envs.io.wide_tracks import write_track_csv
from track_envs.wrappers import TrackingMetrics

DT = 0.005  # a 200 Hz camera


def sparse_lane_recording(seed: int = 0, frames: int = 1200, jitter: float = 3e-5) -> np.ndarray:
    """Spheres at ≈1 m/s in three lanes, one entering every 8–20 frames (1–3 in view), with
    ``jitter`` metres of white centroid scatter, as a (frames, particles, 2) track array."""
    rng = np.random.default_rng(seed)
    starts = np.cumsum(rng.integers(8, 20, size=400))
    starts = starts[starts < frames]
    tracks = np.full((frames, len(starts), 2), np.nan)
    for p, t0 in enumerate(starts):
        v, a = rng.normal(1.0, 0.05), rng.normal(0.5, 0.3)
        y = rng.choice([0.02, 0.05, 0.08]) + rng.normal(0, 1e-3)
        t = np.arange(t0, frames)
        s = (t - t0) * DT
        x = -0.002 + v * s + 0.5 * a * s**2
        keep = (x >= 0) & (x <= 0.12)
        tracks[t[keep], p, 0] = x[keep]
        tracks[t[keep], p, 1] = y + 0.01 * s[keep]
    return tracks + rng.normal(0, jitter, tracks.shape)


@pytest.fixture(scope="module")
def jittered(tmp_path_factory):
    path = tmp_path_factory.mktemp("declared") / "jittered.csv"
    tracks = sparse_lane_recording()
    write_track_csv(path, tracks)
    return path, tracks


def test_replay_declares_noise_without_adding_any(jittered):
    path, tracks = jittered
    env = gym.make("BeltReplay-v0", path=str(path), dt=DT, noise_std=0.0, measurement_noise_std=3e-5)
    spec = env.unwrapped.sensor_spec
    assert spec.noise_std == 3e-5
    obs, info = env.reset(seed=0)
    for t in range(50):
        rows = np.flatnonzero(obs["mask"])
        ids = info["detection_ids"][rows]
        np.testing.assert_array_equal(obs["detections"][rows], tracks[t, ids].astype(np.float32))
        obs, *_, info = env.step(empty_report(spec.max_tracks, (2,)))


def test_declared_noise_defaults_to_the_added_noise():
    assert gym.make("BeltReplay-v0", noise_std=2e-4).unwrapped.sensor_spec.noise_std == 2e-4
    assert gym.make("BeltSorter-v0", noise_std=2e-4).unwrapped.sensor_spec.noise_std == 2e-4


def test_belt_sorter_declares_noise_without_adding_any():
    env = gym.make("BeltSorter-v0", noise_std=0.0, measurement_noise_std=3e-5, merge_touching=False)
    assert env.unwrapped.sensor_spec.noise_std == 3e-5
    obs, info = env.reset(seed=1)
    rows = np.flatnonzero(obs["mask"])
    truth = info["truth"]
    at = {int(i): k for k, i in enumerate(truth["ids"]) if i >= 0}
    expected = truth["positions"][[at[int(i)] for i in info["detection_ids"][rows]]]
    np.testing.assert_array_equal(obs["detections"][rows], expected.astype(np.float32))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"measurement_noise_std": -1.0}, "measurement_noise_std"),
        ({"measurement_noise_std": np.nan}, "measurement"),
    ],
)
@pytest.mark.parametrize("env_id", ["BeltReplay-v0", "BeltSorter-v0"])
def test_bad_declared_noise_is_named(env_id, kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make(env_id, **kwargs)


def id_switches(path, **kwargs) -> dict[str, float]:
    env = TrackingMetrics(gym.make("BeltReplay-v0", path=str(path), dt=DT, noise_std=0.0, **kwargs))
    agent = make_agent("gnn", predictor="kf-ca")
    obs, _ = env.reset(seed=0)
    agent.reset(env.get_wrapper_attr("sensor_spec"), seed=0)
    while True:
        obs, _, terminated, truncated, info = env.step(agent.act(obs))
        if terminated or truncated:
            return info["episode_metrics"]


def test_declaring_the_recordings_noise_keeps_tracks_through_jitter(jittered):
    # measured: 78 ID switches (e2 0.71) told R = (1 µm)², 1 (e2 0.012) told 30 µm
    path, _ = jittered
    undeclared = id_switches(path)
    declared = id_switches(path, measurement_noise_std=3e-5)
    assert undeclared["id_switches"] >= 30 and undeclared["e2"] >= 0.3
    assert declared["id_switches"] <= 3 and declared["e2"] <= 0.05
