"""BeltReplay-v0: exact replay of a track file, frame ranges, sensor options, bad files."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from track_envs.contracts.report import empty_report
from track_envs.io.csv_parser import TrackFileError
from track_envs.io.wide_tracks import write_track_csv


@pytest.fixture
def recording(tmp_path):
    rng = np.random.default_rng(0)
    frames, particles = 40, 12
    tracks = np.full((frames, particles, 2), np.nan)
    for p in range(particles):
        start = rng.integers(0, 30)
        length = rng.integers(3, 12)
        t = np.arange(start, min(start + length, frames))
        tracks[t, p, 0] = 0.01 * p + 0.0123456789 * (t - start)
        tracks[t, p, 1] = rng.random() * 0.18
    path = tmp_path / "tracks.csv"
    write_track_csv(path, tracks)
    return path, tracks


def replay(path, **kwargs):
    env = gym.make("BeltReplay-v0", path=str(path), **kwargs)
    obs, info = env.reset(seed=0)
    spec = env.unwrapped.sensor_spec
    out = [(obs, info)]
    while True:
        obs, _, terminated, truncated, info = env.step(empty_report(spec.max_tracks, (2,)))
        if terminated or truncated:
            return out, (obs, info)
        out.append((obs, info))


def test_replay_reproduces_the_file_exactly_at_zero_noise(recording):
    path, tracks = recording
    frames, last = replay(path)
    assert len(frames) == len(tracks)
    for t, (obs, info) in enumerate(frames):
        rows = np.flatnonzero(obs["mask"])
        ids = info["detection_ids"][rows]
        expected_ids = np.flatnonzero(np.isfinite(tracks[t, :, 0]))
        assert sorted(ids.tolist()) == expected_ids.tolist()
        np.testing.assert_array_equal(obs["detections"][rows], tracks[t, ids].astype(np.float32))
        live = info["truth"]["ids"] >= 0
        np.testing.assert_array_equal(info["truth"]["positions"][live], tracks[t, info["truth"]["ids"][live]])
    # after the last frame: terminated with an empty observation
    assert last[0]["mask"].sum() == 0 and np.all(last[1]["truth"]["ids"] == -1)


def test_frame_range_selects_frames(recording):
    path, tracks = recording
    frames, _ = replay(path, frames=(10, 20))
    assert len(frames) == 10
    obs, info = frames[0]
    assert (
        sorted(info["detection_ids"][obs["mask"] == 1].tolist())
        == np.flatnonzero(np.isfinite(tracks[10, :, 0])).tolist()
    )


def test_velocities_are_finite_differences(recording):
    path, tracks = recording
    frames, _ = replay(path)
    _, info = frames[5]
    live = info["truth"]["ids"] >= 0
    for pid, v in zip(info["truth"]["ids"][live], info["truth"]["velocities"][live], strict=True):
        if np.isfinite(tracks[4, pid, 0]):
            np.testing.assert_allclose(v, (tracks[5, pid] - tracks[4, pid]) / 0.01)


def test_noise_and_misses_apply_to_the_replay(recording):
    path, tracks = recording
    frames, _ = replay(path, noise_std=0.001, p_detect=0.5)
    shown = sum(int(obs["mask"].sum()) for obs, _ in frames)
    total = int(np.isfinite(tracks[..., 0]).sum())
    assert 0.3 * total < shown < 0.7 * total
    obs, info = frames[10]
    rows = np.flatnonzero(obs["mask"])
    assert not np.array_equal(
        obs["detections"][rows], tracks[10, info["detection_ids"][rows]].astype(np.float32)
    )


def test_default_is_the_shipped_sample():
    env = gym.make("BeltReplay-v0")
    obs, _ = env.reset(seed=0)
    assert env.unwrapped.n_frames == 300
    assert obs["mask"].sum() > 20


def test_zip_files_replay_like_csv(recording, tmp_path):
    path, tracks = recording
    zipped = tmp_path / "tracks.zip"
    write_track_csv(zipped, tracks)
    a, _ = replay(path)
    b, _ = replay(zipped)
    for (oa, _), (ob, _) in zip(a, b, strict=True):
        np.testing.assert_array_equal(oa["detections"], ob["detections"])


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("1,2,3,4\n1,2\n", "row 2 has 2 fields"),
        ("1,2,3\n", "odd count"),
        ("1,abc\n", "holds text 'abc'"),
    ],
)
def test_bad_files_name_the_file_and_the_problem(tmp_path, content, message):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    with pytest.raises(TrackFileError, match=message) as err:
        gym.make("BeltReplay-v0", path=str(path))
    assert "bad.csv" in str(err.value)


def test_missing_file_is_named(tmp_path):
    with pytest.raises(TrackFileError, match="no such file"):
        gym.make("BeltReplay-v0", path=str(tmp_path / "nope.csv"))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"noise_std": -1.0}, "noise_std"),
        ({"p_detect": -0.1}, "p_detect"),
        ({"dt": 0.0}, "dt"),
        ({"frames": (5, 2)}, "frames"),
        ({"region": ((0.0, 0.0), (0.0, 1.0))}, "region"),
        ({"max_tracks": 0}, "max_tracks"),
    ],
)
def test_bad_arguments_name_the_problem(recording, kwargs, message):
    path, _ = recording
    with pytest.raises(ValueError, match=message):
        gym.make("BeltReplay-v0", path=str(path), **kwargs)
