"""DetectionReplay-v0: a detection file replayed without truth (the conformance tests run it too)."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401  (registers the envs)
from track_envs.contracts.report import empty_report
from track_envs.envs.detection_replay import SAMPLE_NOISE_STD, SAMPLE_READ_OPTIONS, sample_detections_path
from track_envs.io.detections import read_wide_detections, write_mot_detections, write_wide_detections
from track_envs.metrics.base import metric_traits
from track_envs.values.detections import Detections
from track_envs.wrappers import TrackingMetrics


def small_stream(times: bool = True) -> Detections:
    rng = np.random.default_rng(0)
    frames = [rng.uniform(0, 1, (rng.integers(2, 6), 2)) for _ in range(12)]
    return Detections.from_frames(frames, times=np.arange(12) * 0.02 if times else None)


def episode(env) -> list[tuple[dict, float, dict]]:
    obs, info = env.reset(seed=0)
    frames = []
    report = empty_report(env.unwrapped.sensor_spec.max_tracks, (2,))
    while True:
        frames.append((obs, info))
        obs, reward, terminated, truncated, info = env.step(report)
        frames[-1] += (reward, info)
        if terminated or truncated:
            return frames


def test_the_sample_replays_its_detections_with_no_truth_and_reward_zero():
    env = gym.make("DetectionReplay-v0")
    stream = read_wide_detections(sample_detections_path(), **SAMPLE_READ_OPTIONS)
    spec = env.unwrapped.sensor_spec
    assert spec.dt == pytest.approx(0.01) and spec.noise_std == SAMPLE_NOISE_STD
    frames = episode(env)
    assert len(frames) == stream.n_frames
    for t, (obs, info, reward, _) in enumerate(frames):
        rows = obs["detections"][obs["mask"] == 1]
        order = np.lexsort(rows.T[::-1])
        expected = stream.frame(t).astype(np.float32)
        np.testing.assert_array_equal(rows[order], expected[np.lexsort(expected.T[::-1])])
        assert info["has_truth"] is False and "no truth" in info["truth_note"]
        assert np.all(info["truth"]["ids"] == -1) and np.all(info["detection_ids"] == -1)
        assert reward == 0.0


def test_tracking_metrics_skip_truth_metrics_with_a_note():
    env = TrackingMetrics(gym.make("DetectionReplay-v0"))
    info = episode(env)[-1][3]
    assert info["episode_metrics"] == {}
    assert "no ground truth" in info["episode_metrics_note"]


class TrackCount:
    """Reads only the reports, so it declares no need of truth (the default)."""

    def reset(self):
        self.tracks = 0

    def update(self, truth, detection_ids, report):
        self.tracks += int(np.sum(report["mask"] == 1))

    def compute(self):
        return {"reported_tracks": float(self.tracks)}


def test_a_metric_that_declares_no_need_of_truth_runs_without_truth():
    from track_envs.metrics import ClearMot

    env = TrackingMetrics(gym.make("DetectionReplay-v0"), [ClearMot(threshold=1.0), TrackCount()])
    info = episode(env)[-1][3]
    assert info["episode_metrics"] == {"reported_tracks": 0.0}
    assert "(ClearMot)" in info["episode_metrics_note"]


def test_every_truth_metric_declares_its_need():
    import inspect

    import track_envs.metrics as metrics

    streaming = [
        c
        for c in vars(metrics).values()
        if inspect.isclass(c)
        and c is not metrics.Metric
        and hasattr(c, "update")
        and list(inspect.signature(c.update).parameters)[1:] == ["truth", "detection_ids", "report"]
    ]
    assert len(streaming) == 11  # with BoxClearMot, Hota, BoxHota and PoseHota
    assert all(metric_traits(c).needs_truth is True for c in streaming)


def test_unshuffled_rows_keep_the_file_order(tmp_path: Path):
    stream = small_stream()
    write_wide_detections(tmp_path / "d.csv", stream)
    env = gym.make(
        "DetectionReplay-v0",
        path=str(tmp_path / "d.csv"),
        read_options={"time_column": "time"},
        shuffle=False,
    )
    for t, (obs, *_) in enumerate(episode(env)):
        np.testing.assert_array_equal(obs["detections"][obs["mask"] == 1], stream.frame(t).astype(np.float32))


def test_dt_region_and_declared_noise_are_given_or_inferred(tmp_path: Path):
    stream = small_stream(times=False)
    write_mot_detections(tmp_path / "det.txt", stream)
    with pytest.raises(ValueError, match=r"dt .* is not given"):
        gym.make("DetectionReplay-v0", path=str(tmp_path / "det.txt"))
    env = gym.make(
        "DetectionReplay-v0",
        path=str(tmp_path / "det.txt"),
        dt=0.005,
        measurement_noise_std=3e-4,
        region=((-1.0, -1.0), (2.0, 2.0)),
        max_detections=9,
        max_tracks=20,
    )
    spec = env.unwrapped.sensor_spec
    assert (spec.dt, spec.noise_std, spec.region_low, spec.region_high) == (
        0.005,
        3e-4,
        (-1.0, -1.0),
        (2.0, 2.0),
    )
    assert (spec.max_detections, spec.max_tracks) == (9, 20)
    inferred = gym.make("DetectionReplay-v0", detections=small_stream()).unwrapped.sensor_spec
    lo, hi = small_stream().bounds()
    assert inferred.dt == pytest.approx(0.02) and inferred.noise_std == 0.0
    assert np.all(np.asarray(inferred.region_low) < lo) and np.all(np.asarray(inferred.region_high) > hi)


def test_path_and_detections_together_are_refused():
    with pytest.raises(ValueError, match="either path or detections"):
        gym.make("DetectionReplay-v0", path="x.csv", detections=small_stream())
