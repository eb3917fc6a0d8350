"""RecordTracking writes an episode's truth, reports and detections in the MOT and wide formats."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401  (registers the envs)
from track_envs.io.detections import read_mot_detections, read_wide_detections
from track_envs.io.tracks import read_tracks
from track_envs.wrappers import RecordTracking


def test_an_episode_is_written_in_both_formats_and_reads_back(tmp_path: Path) -> None:
    env = RecordTracking(gym.make("SineTarget-v0", max_episode_steps=40), tmp_path)
    obs, info = env.reset(seed=0)
    env.action_space.seed(0)
    truths, reports, detections = [], [], []
    while True:
        live = info["truth"]["ids"] >= 0
        truths.append(info["truth"]["positions"][live])
        detections.append(obs["detections"][obs["mask"] == 1].astype(np.float64))
        report = env.action_space.sample()
        reports.append(report["positions"][report["mask"] == 1].astype(np.float64))
        obs, _, terminated, truncated, info = env.step(report)
        if terminated or truncated:
            break
    folder = tmp_path / "episode-000"
    assert sorted(p.name for p in folder.iterdir()) == sorted(
        ["gt.txt", "gt.csv", "tracks.txt", "tracks.csv", "det.txt", "det.csv"]
    )
    n = len(reports)
    recorded = env.last_episode
    assert recorded is not None and recorded["tracks"].n_frames == n
    for name in ("gt.txt", "gt.csv"):
        truth = read_tracks(folder / name, n_frames=n)
        assert truth.equals(recorded["truth"]) or name == "gt.csv"  # the wide layout renumbers ids
        np.testing.assert_array_equal(truth.positions, np.concatenate(truths))
    for name in ("tracks.txt", "tracks.csv"):
        tracks = read_tracks(folder / name, n_frames=n)
        np.testing.assert_array_equal(
            np.sort(tracks.positions, axis=0), np.sort(np.concatenate(reports), axis=0)
        )
    assert read_tracks(folder / "tracks.txt", n_frames=n).equals(recorded["tracks"])
    mot = read_mot_detections(folder / "det.txt", n_frames=n)
    wide = read_wide_detections(folder / "det.csv", time_column="time")
    for stream in (mot, wide):
        np.testing.assert_array_equal(stream.points, np.concatenate(detections))
    assert wide.inferred_dt() == pytest.approx(env.unwrapped.sensor_spec.dt)
    np.testing.assert_array_equal(mot.ids, recorded["detections"].ids)


def test_keypoint_envs_and_unknown_formats_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="2-d point tracks"):
        RecordTracking(gym.make("KeypointWalkers-v0"), tmp_path)
    with pytest.raises(ValueError, match="formats must be a non-empty subset"):
        RecordTracking(gym.make("SineTarget-v0"), tmp_path, formats=("xml",))
