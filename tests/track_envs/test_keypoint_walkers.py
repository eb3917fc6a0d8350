"""KeypointWalkers-v0 behaviour (check_env, same-seed rollouts and pickle are in test_env_contract)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from track_envs.contracts.report import empty_report, pack_report
from track_envs.envs.skeleton import FLIP_INDEX, LIMBS, WalkerParams

CLEAN = {"clutter_rate": 0.0, "swap_prob": 0.0, "p_detect": 1.0, "p_keypoint": 1.0}


def rollout(steps: int, seed: int = 0, **kwargs):
    env = gym.make("KeypointWalkers-v0", **kwargs)
    obs, info = env.reset(seed=seed)
    report = empty_report(env.unwrapped.sensor_spec.max_tracks, (17, 2))
    frames = [(obs, info)]
    for _ in range(steps):
        obs, _, _, _, info = env.step(report)
        frames.append((obs, info))
    return env, frames


def test_limb_lengths_are_constant_per_person_up_to_scale():
    _, frames = rollout(150, num_people=8, camera_pan=400.0)
    ratios: dict[int, list[np.ndarray]] = {}
    for _, info in frames:
        t = info["truth"]
        for row in np.flatnonzero(t["ids"] >= 0):
            kp = t["keypoints"][row]
            length = np.linalg.norm(kp[LIMBS[:, 1]] - kp[LIMBS[:, 0]], axis=1)
            ratios.setdefault(int(t["ids"][row]), []).append(length / t["scale"][row])
    assert len(ratios) >= 5
    spread = [np.ptp(np.array(r), axis=0).max() for r in ratios.values() if len(r) > 10]
    assert max(spread) < 1e-9
    means = np.array([np.mean(r, axis=0) for r in ratios.values()])
    assert np.ptp(means[:, 4]) > 0.005, "proportions differ between people"


def hidden_fraction(num_people: int) -> float:
    _, frames = rollout(120, seed=1, num_people=num_people, initial_people=num_people, num_occluders=0,
                        vanish_rate=0.0, arrival_rate=5.0)  # fmt: skip
    fractions = []
    for _, info in frames:
        t = info["truth"]
        keep = (t["ids"] >= 0) & t["visible"]
        fractions.append(1 - t["keypoint_visible"][keep].mean())
    return float(np.mean(fractions))


def test_hidden_keypoint_fraction_grows_with_the_number_of_people():
    few, many = hidden_fraction(2), hidden_fraction(25)
    assert 0.1 < few < 0.35  # frame border and self-occlusion only
    assert many > few + 0.1


def test_occlusion_switch_leaves_only_the_frame_border():
    _, frames = rollout(60, num_people=10, occlusion=False, num_occluders=0, vanish_rate=0.0)
    for _, info in frames:
        t = info["truth"]
        kp = t["keypoints"]
        inside = (kp[..., 0] >= 0) & (kp[..., 0] < 1280) & (kp[..., 1] >= 0) & (kp[..., 1] < 720)
        real = t["ids"] >= 0
        np.testing.assert_array_equal(t["keypoint_visible"][real], inside[real])


def test_people_vanish_and_reappear():
    _, frames = rollout(200, num_people=4, vanish_rate=1.0, num_occluders=0)
    seen: dict[int, list[bool]] = {}
    for _, info in frames:
        t = info["truth"]
        for i, v in zip(t["ids"], t["visible"], strict=True):
            if i >= 0:
                seen.setdefault(int(i), []).append(bool(v))
    gaps = [s for s in seen.values() if "10" in "".join(str(int(v)) for v in s).strip("0")]
    assert gaps, "some person is hidden for a while and seen again"


def test_zero_noise_detections_are_the_visible_truth_keypoints():
    _, frames = rollout(20, noise_std=0.0, **CLEAN)
    for obs, info in frames:
        t = info["truth"]
        lookup = {int(i): r for r, i in enumerate(t["ids"]) if i >= 0}
        for row in np.flatnonzero(obs["mask"]):
            r = lookup[int(info["detection_ids"][row])]
            det = obs["detections"][row]
            np.testing.assert_array_equal(det[:, 2] > 0, t["keypoint_visible"][r])
            found = det[:, 2] > 0
            np.testing.assert_array_equal(det[found, :2], t["keypoints"][r][found].astype(np.float32))
            assert np.all(det[~found] == 0)


def test_left_right_swaps_and_noise_scale():
    _, frames = rollout(10, noise_std=0.0, **{**CLEAN, "swap_prob": 1.0})
    obs, info = frames[-1]
    t = info["truth"]
    row = int(np.flatnonzero(obs["mask"])[0])
    r = int(np.flatnonzero(t["ids"] == info["detection_ids"][row])[0])
    found = obs["detections"][row, :, 2] > 0
    flipped = t["keypoints"][r][FLIP_INDEX].astype(np.float32)
    np.testing.assert_array_equal(obs["detections"][row, found, :2], flipped[found])
    # noise: standardised by 2σ_k · sqrt(area_factor) · scale, the error has std keypoint_noise per axis
    _, frames = rollout(60, keypoint_noise=0.5, **CLEAN)
    from track_envs.metrics.keypoints import COCO_SIGMAS

    z = []
    for obs, info in frames:
        t = info["truth"]
        lookup = {int(i): r for r, i in enumerate(t["ids"]) if i >= 0}
        for row in np.flatnonzero(obs["mask"]):
            r = lookup[int(info["detection_ids"][row])]
            found = obs["detections"][row, :, 2] > 0
            inner = found & np.all(
                (obs["detections"][row, :, :2] > 0) & (obs["detections"][row, :, :2] < 720), 1
            )
            err = obs["detections"][row, :, :2] - t["keypoints"][r]
            std = 2 * COCO_SIGMAS * np.sqrt(0.2) * t["scale"][r]
            z.append((err / std[:, None])[inner])
    assert np.std(np.concatenate(z)) == pytest.approx(0.5, rel=0.1)


def test_perfect_report_earns_zero_reward_and_an_empty_one_a_penalty():
    env = gym.make("KeypointWalkers-v0")
    _, info = env.reset(seed=0)
    t = info["truth"]
    keep = (t["ids"] >= 0) & t["visible"]
    n = env.unwrapped.sensor_spec.max_tracks
    _, reward, *_ = env.step(pack_report(t["ids"][keep], t["keypoints"][keep], np.full(keep.sum(), -1), n))
    assert reward == pytest.approx(0.0, abs=1e-9)
    env.reset(seed=0)
    _, reward, *_ = env.step(empty_report(n, (17, 2)))
    assert reward == pytest.approx(-0.5 * keep.sum())


def test_camera_pan_shifts_the_view():
    env, _ = rollout(60, num_people=4, camera_pan=800.0)
    assert np.abs(env.unwrapped.crowd.pan).max() > 10


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"num_people": 0}, "num_people"),
        ({"num_people": 2, "initial_people": 3}, "initial_people"),
        ({"p_detect": 1.5}, "p_detect"),
        ({"keypoint_noise": -1.0}, "keypoint_noise"),
        ({"keypoint_noise": 0.1, "noise_std": 0.1}, "noise_std"),
        ({"camera_pan": np.inf}, "camera_pan"),
        ({"swap_prob": 2.0}, "swap_prob"),
        ({"max_tracks": 0}, "max_tracks"),
        ({"params": {"width": 3}}, "params"),
        ({"min_keypoints": 1.5}, "min_keypoints"),
    ],
)
def test_bad_arguments_are_named(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make("KeypointWalkers-v0", **kwargs)


def test_malformed_pose_reports_are_rejected():
    env = gym.make("KeypointWalkers-v0").unwrapped
    env.reset(seed=0)
    n = env.sensor_spec.max_tracks
    with pytest.raises(ValueError, match=r"report\['positions'\] must have shape \(28, 17, 2\)"):
        env.step(empty_report(n, (2,)))
    bad = empty_report(n, (17, 2))
    bad["mask"][0] = 1
    bad["positions"][0, 5] = np.inf
    with pytest.raises(ValueError, match=r"non-finite values in masked-in rows \[0\]"):
        env.step(bad)


def test_rendering_draws_people_detections_and_tracks():
    env = gym.make("KeypointWalkers-v0", render_mode="rgb_array")
    _, info = env.reset(seed=0)
    t = info["truth"]
    keep = (t["ids"] >= 0) & t["visible"]
    n = env.unwrapped.sensor_spec.max_tracks
    plain = env.render()
    env.step(pack_report(t["ids"][keep] + 100, t["keypoints"][keep] + 3, np.full(keep.sum(), -1), n))
    frame = env.render()
    assert frame.shape[1:] == (1280, 3) and frame.shape[0] > 720 and frame.dtype == np.uint8  # + footer
    assert (frame != plain).any(axis=2).sum() > 500


@pytest.mark.parametrize(
    "fields, name",
    [
        ({"fps": 0.0}, "fps"),
        ({"width": 1.5}, "width"),
        ({"focal": -900.0}, "focal"),
        ({"turn_std": np.nan}, "turn_std"),
        ({"depth_range": (14.0, 4.0)}, "depth_range"),
        ({"speed_range": (1.0,)}, "speed_range"),
        ({"height_range": (0.0, 1.9)}, r"height_range\[0\]"),
    ],
)
def test_bad_walker_params_are_named(fields, name):
    with pytest.raises(ValueError, match=name):
        WalkerParams(**fields)
