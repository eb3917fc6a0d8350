"""The pose-baseline tracker: lifetime counts, prediction fill-in, batched OKS, easy vs hard scenes."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from agents import agent_applies_to, make_agent
from agents.pose.tracker import PoseBaselineAgent
from track_envs.metrics.keypoints import COCO_SIGMAS, pairwise_oks
from track_envs.values.types import SensorSpec
from track_envs.wrappers import TrackingMetrics

EASY = {"num_people": 3, "occlusion": False, "num_occluders": 0, "vanish_rate": 0.0, "clutter_rate": 0.0,
        "swap_prob": 0.0}  # fmt: skip
HARD = {"num_people": 15, "initial_people": 12, "arrival_rate": 2.0, "camera_pan": 600.0, "num_occluders": 2,
        "vanish_rate": 0.1}  # fmt: skip
SPEC = SensorSpec(1 / 30, 2, 1.0, 1.0, 0.0, (0.0, 0.0), (1280.0, 720.0), 4, 4, "px")
POSE = np.stack([100 + np.arange(17) * 5.0, 200 + np.arange(17) * 10.0], axis=1)


def episode(seed: int, **kwargs) -> dict[str, float]:
    env = TrackingMetrics(gym.make("KeypointWalkers-v0", **kwargs))
    agent = make_agent("pose-baseline")
    obs, _ = env.reset(seed=seed)
    agent.reset(env.unwrapped.sensor_spec, seed=seed)
    while True:
        obs, _, terminated, truncated, info = env.step(agent.act(obs))
        if terminated or truncated:
            return info["episode_metrics"]


def test_easy_scene_is_tracked_well_and_the_hard_one_degrades():
    # measured (seeds 0, 1): easy MOTA 0.807 / 0.804, nose switches 2 / 1;
    # hard MOTA 0.485 / 0.578, nose switches 452 / 422
    for seed in (0, 1):
        easy, hard = episode(seed, **EASY), episode(seed, **HARD)
        assert easy["mota"] > 0.75 and easy["id_switches_nose"] <= 6
        assert hard["mota"] < 0.68 and hard["id_switches_nose"] > 150
        assert hard["mota"] < easy["mota"] - 0.15


def obs_of(*poses, found=None):
    det = np.zeros((4, 17, 3), np.float32)
    mask = np.zeros(4, np.int8)
    for i, p in enumerate(poses):
        det[i, :, :2] = p
        det[i, :, 2] = 0.9
        mask[i] = 1
    if found is not None:
        det[0, ~found] = 0
    return {"detections": det, "mask": mask}


def test_lifetime_counts_follow_algorithm_1():
    agent = PoseBaselineAgent(report_coasting=True)
    agent.reset(SPEC)
    empty = obs_of()
    for _ in range(3):
        agent.act(obs_of(POSE))
    assert agent.lifetime.tolist() == [2]  # born at 0, +1 per match
    for expected in ([1], [0], []):
        report = agent.act(empty)
        assert agent.lifetime.tolist() == expected  # -1 per miss, deactivated below 0
        assert report["mask"].sum() == len(expected)
    for _ in range(40):
        agent.act(obs_of(POSE))
    assert agent.lifetime.tolist() == [30]  # capped at 30


def test_keypoints_not_detected_are_filled_from_the_constant_velocity_prediction():
    agent = PoseBaselineAgent(smoothing=1.0)
    agent.reset(SPEC)
    step = np.array([3.0, -1.0])
    agent.act(obs_of(POSE))
    agent.act(obs_of(POSE + step))
    found = np.ones(17, bool)
    found[9] = False
    report = agent.act(obs_of(POSE + 2 * step, found=found))
    assert report["mask"].sum() == 1 and report["ids"][0] == 0 and report["detection"][0] == 0
    np.testing.assert_allclose(report["positions"][0], POSE + 2 * step, atol=1e-4)


def test_new_tracks_for_far_detections_and_greedy_agrees_on_easy_frames():
    for assignment in ("hungarian", "greedy"):
        agent = PoseBaselineAgent(assignment=assignment)
        agent.reset(SPEC)
        agent.act(obs_of(POSE))
        report = agent.act(obs_of(POSE + 1, POSE + np.array([600.0, 0.0])))
        assert sorted(report["ids"][report["mask"] == 1].tolist()) == [0, 1]


def test_batched_oks_equals_a_per_pair_loop():
    rng = np.random.default_rng(0)
    a = rng.uniform(0, 400, (6, 17, 2))
    b = rng.uniform(0, 400, (5, 17, 2))
    valid = rng.random((5, 17)) < 0.7
    known = rng.random((6, 17)) < 0.8
    area = rng.uniform(1e3, 1e4, 5)
    loop = np.zeros((6, 5))
    for i in range(6):
        for j in range(5):
            v = valid[j] & known[i]
            e = np.sum((a[i] - b[j]) ** 2, 1) / ((2 * COCO_SIGMAS) ** 2 * 2 * (area[j] + np.spacing(1)))
            loop[i, j] = np.exp(-e)[v].sum() / max(v.sum(), 1)
    np.testing.assert_allclose(pairwise_oks(a, b, valid, area, a_valid=known), loop, rtol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [({"oks_threshold": 1.0}, "oks_threshold"), ({"oks_threshold": 0.0}, "oks_threshold"),
     ({"assignment": "auction"}, "assignment"),
     ({"smoothing": 0.0}, "smoothing"), ({"min_keypoints": 0}, "min_keypoints")],
)  # fmt: skip
def test_bad_arguments_and_observations_are_named(kwargs, name):
    with pytest.raises(ValueError, match=name):
        PoseBaselineAgent(**kwargs)
    agent = PoseBaselineAgent()
    with pytest.raises(RuntimeError, match="reset"):
        agent.act(obs_of(POSE))
    agent.reset(SPEC)
    with pytest.raises(
        ValueError, match=r"observation\['detections'\] must be a float array of shape \(4, 17, 3\)"
    ):
        agent.act({"detections": np.zeros((4, 2), np.float32), "mask": np.zeros(4, np.int8)})
    bad = obs_of(POSE)
    bad["detections"][0, 3, 0] = np.nan
    with pytest.raises(ValueError, match=r"rows \[0\] hold NaN"):
        agent.act(bad)


def test_pose_baseline_applies_to_pose_envs_only():
    assert agent_applies_to("pose-baseline", (17, 2))
    assert not agent_applies_to("pose-baseline", (2,))
