"""SineTarget-v0 / PiecewiseTarget-v0: truth formula, detection statistics, occlusion, rotation."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401  (registers the ids)
from track_envs.contracts.report import empty_report
from track_envs.envs.single_target import n_frames_for
from track_envs.wrappers import TrackingMetrics


def episode(env_id: str, seed: int, **kwargs):
    """Truth (F, 2), detections per frame (list of (k, 2)) and their source ids of one episode."""
    env = gym.make(env_id, **kwargs)
    spec = env.unwrapped.sensor_spec
    obs, info = env.reset(seed=seed)
    truth, dets, ids = [], [], []
    report = empty_report(spec.max_tracks, (2,))
    while True:
        truth.append(info["truth"]["positions"][0].copy())
        m = obs["mask"] == 1
        dets.append(obs["detections"][m].astype(np.float64))
        ids.append(info["detection_ids"][m])
        obs, _, terminated, truncated, info = env.step(report)
        assert not truncated
        if terminated:
            break
    return np.array(truth), dets, ids


def test_sine_truth_equals_the_formula_rotated_and_shifted_exactly():
    rot, off = 30.0, (2.5, -1.0)
    truth, _, _ = episode("SineTarget-v0", 0, periods=1.0, rotation_deg=rot, offset=off)
    t = np.arange(n_frames_for(1.0), dtype=np.float64)
    x, y = t * 0.2, np.sin(t * 0.2)
    a = np.deg2rad(rot)
    c, s = np.cos(a), np.sin(a)
    expected = np.stack([c * x - s * y + off[0], s * x + c * y + off[1]], axis=1)
    np.testing.assert_array_equal(truth, expected)


def test_full_episode_has_786_frames_and_terminates():
    env = gym.make("SineTarget-v0")
    env.reset(seed=0)
    assert env.unwrapped.n_frames == 786
    report = empty_report(env.unwrapped.sensor_spec.max_tracks, (2,))
    steps = 0
    while True:
        steps += 1
        *_, terminated, truncated, _ = env.step(report)
        if terminated or truncated:
            break
    assert steps == 786 and terminated


def test_piecewise_steps_have_length_delta():
    truth, _, _ = episode("PiecewiseTarget-v0", 3, periods=3.0)
    np.testing.assert_allclose(np.linalg.norm(np.diff(truth, axis=0), axis=1), 0.2, rtol=1e-9)
    other, _, _ = episode("PiecewiseTarget-v0", 4, periods=3.0)
    assert not np.allclose(truth, other)


@pytest.mark.parametrize("env_id", ["SineTarget-v0", "PiecewiseTarget-v0"])
def test_detection_rate_matches_p_detect_within_binomial_bounds(env_id):
    p = 0.7
    _, dets, _ = episode(env_id, 1, p_detect=p)
    n = len(dets)
    hits = sum(len(d) for d in dets)
    assert abs(hits - n * p) <= 4 * np.sqrt(n * p * (1 - p))


@pytest.mark.parametrize("env_id", ["SineTarget-v0", "PiecewiseTarget-v0"])
def test_no_detection_inside_the_occlusion(env_id):
    _, dets, _ = episode(env_id, 2, p_detect=1.0, occlusion_start=40, occlusion_length=30, clutter_rate=0.0)
    counts = np.array([len(d) for d in dets])
    assert np.all(counts[40:70] == 0)
    assert np.all(counts[:40] == 1) and np.all(counts[70:] == 1)


@pytest.mark.parametrize("env_id", ["SineTarget-v0", "PiecewiseTarget-v0"])
def test_occlusion_silences_the_clutter_too(env_id):
    _, dets, _ = episode(env_id, 2, p_detect=1.0, occlusion_start=40, occlusion_length=30, clutter_rate=3.0)
    counts = np.array([len(d) for d in dets])
    assert np.all(counts[40:70] == 0)
    assert counts[:40].mean() > 3.0 and counts[70:100].mean() > 3.0


def test_measurement_noise_is_sigma_m_times_delta():
    truth, dets, _ = episode("SineTarget-v0", 5, p_detect=1.0, sigma_m=2.0)
    err = np.concatenate(dets) - truth
    assert np.std(err) == pytest.approx(2.0 * 0.2, rel=0.1)
    assert gym.make("SineTarget-v0", sigma_m=2.0).unwrapped.sensor_spec.noise_std == pytest.approx(0.4)


@pytest.mark.parametrize("env_id", ["SineTarget-v0", "PiecewiseTarget-v0"])
def test_rotated_scene_is_the_rotation_of_the_unrotated_one(env_id):
    kw = {"p_detect": 0.8, "clutter_rate": 1.0, "periods": 2.0}
    t0, d0, i0 = episode(env_id, 7, **kw)
    t1, d1, i1 = episode(env_id, 7, rotation_deg=45.0, offset=(3.0, 4.0), **kw)
    a = np.deg2rad(45.0)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    np.testing.assert_allclose(t1, t0 @ rot.T + [3.0, 4.0], atol=1e-12)
    for a0, a1, s0, s1 in zip(d0, d1, i0, i1, strict=True):
        np.testing.assert_array_equal(s0, s1)
        np.testing.assert_allclose(a1, a0 @ rot.T + [3.0, 4.0], atol=1e-4)  # float32 observations


def test_clutter_lies_around_the_target():
    truth, dets, ids = episode("SineTarget-v0", 8, clutter_rate=3.0, clutter_half_width=1.5, periods=2.0)
    clutter = [d[i == -1] - x for d, i, x in zip(dets, ids, truth, strict=True)]
    pts = np.concatenate(clutter)
    assert len(pts) > 50 and np.all(np.abs(pts) <= 1.5 + 1e-5)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"sigma_m": -1.0}, "sigma_m"),
        ({"noise_std": -0.1}, "noise_std"),
        ({"p_detect": 1.5}, "p_detect"),
        ({"occlusion_length": -3}, "occlusion_length"),
        ({"occlusion_start": 2.5}, "occlusion_start"),
        ({"clutter_rate": -1.0}, "clutter_rate"),
        ({"periods": 0.0}, "periods"),
        ({"offset": (1.0,)}, "offset"),
        ({"max_tracks": 0}, "max_tracks"),
    ],
)
def test_bad_kwargs_raise_errors_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make("SineTarget-v0", **kwargs)


def test_piecewise_bad_kwargs_are_named():
    with pytest.raises(ValueError, match="segment_steps"):
        gym.make("PiecewiseTarget-v0", segment_steps=(5, 2))
    with pytest.raises(ValueError, match="max_heading_deg"):
        gym.make("PiecewiseTarget-v0", max_heading_deg=95.0)


def test_default_metrics_score_the_episode():
    env = TrackingMetrics(gym.make("SineTarget-v0", periods=1.0, occlusion_start=5, occlusion_length=3))
    _, info = env.reset(seed=0)
    spec = env.get_wrapper_attr("sensor_spec")
    while True:
        report = empty_report(spec.max_tracks, (2,))
        report["mask"][0] = 1
        report["positions"][0] = info["truth"]["positions"][0] + [0.3, 0.4]
        _, _, terminated, _, info = env.step(report)
        if terminated:
            break
    m = info["episode_metrics"]
    assert m["mean_error"] == pytest.approx(0.5, abs=1e-6) and m["lost"] == 0.0
    assert m["occlusion_error"] == pytest.approx(0.5, abs=1e-6)
