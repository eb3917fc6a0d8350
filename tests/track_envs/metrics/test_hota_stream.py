"""The streaming HOTA metrics of the environments: the similarity they build, against TrackEval."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401  (registers the environments)
from track_envs.contracts.report import pack_report
from track_envs.metrics import Hota, Metric, PoseHota
from track_envs.metrics.hota import HOTA_FIELDS
from track_envs.metrics.hota_stream import HOTA_KEYS
from track_envs.metrics.keypoints import oks
from track_envs.metrics.track_scoring import score_tracks
from track_envs.values.tracks import Tracks
from track_envs.wrappers import TrackingMetrics
from track_envs.wrappers.tracking_metrics import point_metrics

trackeval = pytest.importorskip("trackeval")


def trackeval_summary(frames: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> dict[str, float]:
    """TrackEval's HOTA (α-averaged) under our metric keys."""
    gt_values = np.unique(np.concatenate([f[0] for f in frames]))
    tr_values = np.unique(np.concatenate([f[1] for f in frames]))
    data = {
        "num_gt_dets": sum(f[0].size for f in frames),
        "num_tracker_dets": sum(f[1].size for f in frames),
        "num_gt_ids": gt_values.size,
        "num_tracker_ids": tr_values.size,
        "gt_ids": [np.searchsorted(gt_values, f[0]) for f in frames],
        "tracker_ids": [np.searchsorted(tr_values, f[1]) for f in frames],
        "similarity_scores": [f[2] for f in frames],
    }
    res = trackeval.metrics.HOTA({"PRINT_CONFIG": False}).eval_sequence(data)
    return {HOTA_KEYS[name]: float(np.mean(res[name])) for name in HOTA_FIELDS}


def test_point_hota_uses_one_minus_distance_over_threshold():
    """Padded frames in, the visible truth and the mask-1 rows scored with S = max(0, 1 − d/τ)."""
    rng = np.random.default_rng(5)
    tau = 0.7
    metric = Hota(threshold=tau)
    assert isinstance(metric, Metric)
    frames = []
    positions = rng.uniform(0, 3, (10, 2))
    for _ in range(40):
        positions += rng.normal(0, 0.05, positions.shape)
        ids = np.where(rng.random(10) < 0.9, np.arange(10) + 3, -1)
        visible = rng.random(10) < 0.9
        n = int(rng.integers(0, 8))
        tracker_ids = rng.permutation(12)[:n] * 5
        mask = np.zeros(8, np.int8)
        mask[:n] = 1
        tracks = np.zeros((8, 2))
        tracks[:n] = positions[rng.integers(0, 10, n)] + rng.normal(0, 0.3, (n, 2))
        report = {"ids": np.pad(tracker_ids, (0, 8 - n)), "positions": tracks, "detection": np.full(8, -1)}
        metric.update(
            {"ids": ids, "positions": positions, "visible": visible}, np.full(4, -1), {**report, "mask": mask}
        )
        live = (ids >= 0) & visible
        d = np.linalg.norm(positions[live][:, None] - tracks[:n][None], axis=-1)
        frames.append((ids[live], tracker_ids, np.maximum(0.0, 1.0 - d / tau)))
    ours, theirs = metric.compute(), trackeval_summary(frames)
    assert ours.keys() == theirs.keys()
    assert max(abs(ours[k] - theirs[k]) for k in ours) < 1e-9
    assert 0.0 < ours["hota"] < 1.0
    metric.reset()
    assert metric.compute()["hota"] == 0.0
    with pytest.raises(ValueError, match="threshold must be > 0 and finite"):
        Hota(threshold=-1.0)


def test_pose_hota_uses_oks():
    rng = np.random.default_rng(2)
    metric = PoseHota(area_factor=0.2)
    frames = []
    base = rng.uniform(0, 200, (6, 17, 2))
    for _ in range(15):
        visible = rng.random(6) < 0.85
        keypoint_visible = rng.random((6, 17)) < 0.8
        scale = rng.uniform(40, 80, 6)
        truth = {
            "ids": np.arange(6),
            "keypoints": base,
            "keypoint_visible": keypoint_visible,
            "scale": scale,
            "visible": visible,
        }
        n = int(rng.integers(0, 6))
        tracker_ids = rng.permutation(9)[:n]
        poses = base[rng.permutation(6)[:n]] + rng.normal(0, 6, (n, 17, 2))
        report = pack_report(tracker_ids, poses, np.full(n, -1), 8)
        metric.update(truth, np.full(4, -1), report)
        reported = report["positions"][:n].astype(np.float64)
        sim = oks(base[visible], keypoint_visible[visible], 0.2 * scale[visible] ** 2, reported).T
        frames.append((np.arange(6)[visible], tracker_ids, sim))
    ours, theirs = metric.compute(), trackeval_summary(frames)
    assert max(abs(ours[k] - theirs[k]) for k in ours) < 1e-9
    assert ours["hota"] > 0.05


def test_point_environments_report_hota_at_episode_end():
    assert any(isinstance(m, Hota) and m.threshold == 0.25 for m in point_metrics(0.25))
    env = TrackingMetrics(gym.make("BeltSorter-v0", max_episode_steps=30))
    _, info = env.reset(seed=0)
    spec = env.get_wrapper_attr("sensor_spec")
    while True:
        truth = info["truth"]
        keep = (truth["ids"] >= 0) & truth["visible"]
        report = pack_report(
            truth["ids"][keep], truth["positions"][keep], np.full(keep.sum(), -1), spec.max_tracks
        )
        _, _, terminated, truncated, info = env.step(report)
        if terminated or truncated:
            break
    out = info["episode_metrics"]
    assert [out[key] for key in HOTA_KEYS.values()] == pytest.approx([1.0] * 8, abs=1e-5)  # float32 reports


def test_keypoint_environment_reports_hota():
    env = TrackingMetrics(gym.make("KeypointWalkers-v0", max_episode_steps=5))
    _, info = env.reset(seed=0)
    while True:
        truth = info["truth"]
        keep = (truth["ids"] >= 0) & truth["visible"]
        report = pack_report(truth["ids"][keep], truth["keypoints"][keep], np.full(keep.sum(), -1), 28)
        _, _, terminated, truncated, info = env.step(report)
        if terminated or truncated:
            break
    out = info["episode_metrics"]
    assert out["hota"] == pytest.approx(1.0) and out["det_a"] == pytest.approx(1.0) and out["ass_a"] == 1.0


def test_scored_track_files_carry_hota():
    """``track run --metrics`` scores with point_metrics, so HOTA comes with MOTA and IDF1."""
    frame = np.repeat(np.arange(20), 2)
    ids = np.tile([1, 2], 20)
    truth_positions = np.stack([frame * 0.1, ids * 1.0], axis=1)
    truth = Tracks(frame, ids, truth_positions, 20)
    swapped = np.where(frame < 10, ids, 3 - ids) + 10
    tracks = Tracks(frame, swapped, truth_positions + np.array([0.032, 0.0]), 20)
    out, _ = score_tracks(tracks, truth, threshold=0.1)
    # Every pair at S = 1 − 0.032/0.1 = 0.68: a TP for the 13 α ≤ 0.65, with AssA 1/3 (swapped
    # halfway: 10 TPs of 20 + 20 frames); no TP above, where LocA is 1 by convention.
    assert out["det_a"] == pytest.approx(13 / 19)
    assert out["ass_a"] == pytest.approx(13 / 19 / 3)
    assert out["hota"] == pytest.approx(13 / 19 * np.sqrt(1 / 3))
    assert out["loc_a"] == pytest.approx((13 * 0.68 + 6) / 19)
    assert out["mota"] == pytest.approx(1 - 2 / 40)  # CLEAR MOT beside it: the two switches
