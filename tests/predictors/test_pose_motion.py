"""The pose hypothesis motions (predictors/pose/, predictors/pose_lstm/motion.py): the SMC motion's
elites and resampling, the constant-velocity pose motion, the registry."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from agents import make_agent
from agents.pose.tracker import PoseTracker
from predictors.pose import POSE_MOTIONS, ConstantVelocityPose, centroid_fill, motion_models
from predictors.pose_lstm.motion import SmcPoseMotion, elite_mask, resample_indices
from track_envs.values.types import SensorSpec

SPEC = SensorSpec(1 / 30, 2, 1.0, 1.0, 0.0, (0.0, 0.0), (1280.0, 720.0), 4, 4, "px")
POSE = np.stack([100 + np.arange(17) * 5.0, 200 + np.arange(17) * 10.0], axis=1)


def test_elites_are_the_top_fraction_and_resampling_follows_the_weights():
    oks = np.array([[[0.1], [0.9], [0.5], [0.9], [0.2]]])  # (1 filter, 5 particles, 1 detection)
    mask = elite_mask(oks, 2)
    assert mask[0, :, 0].tolist() == [False, True, False, True, False]
    assert elite_mask(oks, 5).all()
    rng = np.random.default_rng(0)
    idx = resample_indices(np.array([[0.0, 0.0, 1.0, 0.0], [0.5, 0.5, 0.0, 0.0]]), rng)
    assert (idx[0] == 2).all() and set(idx[1].tolist()) <= {0, 1}
    many = resample_indices(np.full((1, 4000), 1.0) * np.r_[np.ones(1000), 3 * np.ones(3000)], rng)
    assert abs(np.mean(many >= 1000) - 0.9) < 0.03  # weight 9000 of 10000


def test_constant_velocity_pose_predicts_the_last_displacement_and_fills_births_at_the_centroid():
    motion = ConstantVelocityPose(smoothing=1.0)
    step = np.array([3.0, -1.0])
    motion.reset(SPEC, np.random.default_rng(0))
    found = np.ones((1, 17), bool)
    found[0, 3] = False
    motion.birth(POSE[None], found)
    np.testing.assert_allclose(motion.poses()[0, 3], POSE[found[0]].mean(axis=0))
    motion.predict()
    motion.update(np.array([0]), np.array([0]), (POSE + step)[None], np.ones((1, 17), bool))
    motion.predict()
    np.testing.assert_allclose(motion.predicted[0, found[0]], (POSE + 2 * step)[found[0]])
    motion.keep(np.array([False]))
    assert motion.poses().shape == (0, 17, 2)


def test_centroid_fill_puts_undetected_keypoints_at_the_centroid_of_the_detected_ones():
    xy = np.zeros((2, 17, 2))
    xy[0, :2] = [[0.0, 0.0], [2.0, 4.0]]
    found = np.zeros((2, 17), bool)
    found[0, :2] = True
    out = centroid_fill(xy, found)
    np.testing.assert_allclose(out[0, 2:], np.broadcast_to([1.0, 2.0], (15, 2)))
    np.testing.assert_array_equal(out[1], 0.0)  # nothing detected: the origin


def test_the_registry_builds_the_motions_of_the_pose_agents():
    assert POSE_MOTIONS.names() == ["constant-velocity", "smc"]
    assert motion_models() == [
        ("constant-velocity", "pose", ("pose-baseline",)),
        ("smc", "pose", ("pose-smc",)),
    ]
    assert type(make_agent("pose-baseline").motion) is type(POSE_MOTIONS.make("constant-velocity"))
    smc = POSE_MOTIONS.make("smc", particles=3, window=4)
    assert isinstance(smc, SmcPoseMotion) and (smc.P, smc.L) == (3, 4)
    assert type(make_agent("pose-smc", particles=2).motion) is SmcPoseMotion
    with pytest.raises(ValueError, match=r"pose motion 'smc' has no argument 'particle'"):
        POSE_MOTIONS.make("smc", particle=3)
    with pytest.raises(ValueError, match=r"unknown pose motion 'cv'; valid names are"):
        POSE_MOTIONS.make("cv")


def test_a_loop_with_the_registered_motion_is_the_baseline_agent():
    env = gym.make("KeypointWalkers-v0")
    a, b = make_agent("pose-baseline"), PoseTracker(POSE_MOTIONS.make("constant-velocity"))
    obs, _ = env.reset(seed=2)
    a.reset(env.unwrapped.sensor_spec, seed=2)
    b.reset(env.unwrapped.sensor_spec, seed=2)
    for _ in range(30):
        ra, rb = a.act(obs), b.act(obs)
        for key in ra:
            np.testing.assert_array_equal(ra[key], rb[key])
        obs, *_ = env.step(ra)
