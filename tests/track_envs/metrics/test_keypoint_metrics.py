"""OKS parity with pycocotools and closed-form PoseTrack-style per-keypoint MOTA cases."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from track_envs.contracts.report import pack_report
from track_envs.metrics.keypoints import COCO_SIGMAS, KeypointMota, PoseOks, oks, pairwise_oks
from track_envs.wrappers import TrackingMetrics


def _coco_oks(gt, vis, area, bbox, dt):
    """pycocotools' COCOeval.computeOks on the same arrays (the oracle)."""
    pytest.importorskip("pycocotools")
    from pycocotools.coco import COCO
    from pycocotools.cocoeval import COCOeval

    coco_gt = COCO()
    coco_gt.dataset = {
        "images": [{"id": 1}],
        "categories": [{"id": 1, "name": "person"}],
        "annotations": [
            {
                "id": i + 1, "image_id": 1, "category_id": 1, "iscrowd": 0, "area": float(area[i]),
                "bbox": [float(b) for b in bbox[i]],
                "keypoints": np.column_stack([gt[i], 2 * vis[i]]).reshape(-1).tolist(),
                "num_keypoints": int(vis[i].sum()),
            }
            for i in range(len(gt))
        ],
    }  # fmt: skip
    coco_gt.createIndex()
    dts = [
        {"image_id": 1, "category_id": 1, "score": 1.0 - 0.01 * j,
         "keypoints": np.column_stack([dt[j], np.ones(17)]).reshape(-1).tolist()}
        for j in range(len(dt))
    ]  # fmt: skip
    coco_dt = coco_gt.loadRes(dts)
    ev = COCOeval(coco_gt, coco_dt, "keypoints")
    ev.params.imgIds = [1]
    ev._prepare()
    return np.asarray(ev.computeOks(1, 1))


def test_oks_matches_pycocotools_compute_oks():
    rng = np.random.default_rng(0)
    m, n = 4, 6
    gt = rng.uniform(0, 500, (m, 17, 2))
    vis = rng.random((m, 17)) < 0.7
    vis[3] = False  # no labelled keypoint: pycocotools' box rule
    area = rng.uniform(2e3, 4e4, m)
    bbox = np.column_stack([gt.min(1), gt.max(1) - gt.min(1)])
    dt = np.concatenate([gt + rng.normal(0, 8, (m, 17, 2)), rng.uniform(0, 500, (n - m, 17, 2))])
    expected = _coco_oks(gt, vis, area, bbox, dt)
    np.testing.assert_allclose(oks(gt, vis, area, dt, truth_bbox=bbox), expected, rtol=1e-12, atol=1e-15)


def test_pairwise_oks_equals_oks_when_every_keypoint_counts():
    rng = np.random.default_rng(1)
    a = rng.uniform(0, 300, (5, 17, 2))
    b = a[:3] + rng.normal(0, 5, (3, 17, 2))
    area = np.full(3, 1e4)
    np.testing.assert_allclose(
        pairwise_oks(a, b, np.ones((3, 17), bool), area), oks(b, np.ones((3, 17)), area, a), rtol=1e-12
    )
    assert COCO_SIGMAS.shape == (17,)


def _truth(ids, keypoints, visible=None, head=10.0):
    ids = np.asarray(ids, dtype=np.int64)
    kp = np.asarray(keypoints, dtype=np.float64)
    vis = np.ones((len(ids), 17), bool) if visible is None else np.asarray(visible, bool)
    return {
        "ids": ids, "positions": kp, "keypoints": kp, "keypoint_visible": vis, "visible": vis.any(1),
        "scale": np.full(len(ids), 100.0), "head_size": np.full(len(ids), head),
    }  # fmt: skip


def _report(ids, poses):
    return pack_report(np.asarray(ids), np.asarray(poses, np.float32), np.full(len(ids), -1), 8)


POSE_A = np.stack([np.arange(17) * 10.0, np.zeros(17)], axis=1)
POSE_B = POSE_A + np.array([0.0, 500.0])


def _run(frames, **kw):
    metric = KeypointMota(**kw)
    for truth, report in frames:
        metric.update(truth, np.full(4, -1), report)
    return metric.compute()


def test_perfect_tracking_scores_mota_one():
    frames = [(_truth([0, 1], [POSE_A, POSE_B]), _report([5, 6], [POSE_A + 1, POSE_B])) for _ in range(3)]
    out = _run(frames)
    assert out["mota"] == 1.0 and out["id_switches"] == 0 and out["num_objects"] == 2 * 17 * 3


def test_swapped_identities_switch_every_keypoint():
    truth = _truth([0, 1], [POSE_A, POSE_B])
    frames = [(truth, _report([5, 6], [POSE_A, POSE_B]))] * 2 + [(truth, _report([5, 6], [POSE_B, POSE_A]))]
    out = _run(frames)
    # 34 switches over 102 truth keypoints: MOTA = 1 - 34 / 102
    assert out["id_switches"] == 34 and out["id_switches_nose"] == 2
    assert out["mota"] == pytest.approx(1 - 34 / 102)


def test_a_keypoint_beyond_pckh_is_a_miss_and_a_false_positive():
    off = POSE_A.copy()
    off[0] += [5.1, 0.0]  # head size 10: beyond 0.5 · 10
    frames = [(_truth([0], [POSE_A]), _report([1], [POSE_A]))] * 2 + [
        (_truth([0], [POSE_A]), _report([1], [off]))
    ]
    out = _run(frames)
    assert out["mota_nose"] == pytest.approx(1 - 2 / 3)
    assert out["mota"] == pytest.approx(1 - 2 / 51)
    assert out["num_misses"] == 1 and out["num_false_positives"] == 1
    near = POSE_A.copy()
    near[0] += [4.9, 0.0]
    assert _run([(_truth([0], [POSE_A]), _report([1], [near]))])["mota"] == 1.0


def test_hidden_truth_keypoints_are_dont_care_for_the_assigned_track():
    vis = np.ones((1, 17), bool)
    vis[0, 15:] = False  # ankles hidden
    frames = [(_truth([0], [POSE_A], vis), _report([1], [POSE_A]))]
    assert _run(frames)["mota"] == 1.0
    strict = _run(frames, ignore_hidden=False)
    assert strict["num_false_positives"] == 2 and strict["mota"] == pytest.approx(1 - 2 / 15)


def test_an_unassigned_track_counts_17_false_positives_and_a_missed_person_17_misses():
    frames = [(_truth([0, 1], [POSE_A, POSE_B]), _report([1, 2], [POSE_A, POSE_A + np.array([0.0, 900.0])]))]
    out = _run(frames)
    assert out["num_false_positives"] == 17 and out["num_misses"] == 17
    assert out["mota"] == pytest.approx(1 - 34 / 34)


def test_pose_oks_metric_and_bad_arguments():
    metric = PoseOks()
    metric.update(_truth([0], [POSE_A]), np.zeros(1), _report([1, 2], [POSE_A, POSE_B]))
    out = metric.compute()
    assert out["oks_mean"] == pytest.approx(1.0) and out["oks_recall"] == 1.0 and out["oks_precision"] == 0.5
    with pytest.raises(ValueError, match="pckh"):
        KeypointMota(pckh=0.0)
    with pytest.raises(ValueError, match="threshold"):
        PoseOks(threshold=2.0)
    with pytest.raises(ValueError, match=r"report positions \(max_tracks, 17, 2\)"):
        KeypointMota().update(_truth([0], [POSE_A]), np.zeros(1), pack_report([1], np.zeros((1, 2)), [-1], 4))


def test_tracking_metrics_reports_keypoint_mota_at_episode_end():
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
    assert out["mota"] == 1.0 and out["id_switches_nose"] == 0 and out["oks_mean"] == pytest.approx(1.0)


def test_paired_oks_is_pairwise_oks_of_chosen_pairs_and_the_box_bound_holds():
    from track_envs.metrics.keypoints import oks_upper_bound, paired_oks, pairwise_oks

    rng = np.random.default_rng(3)
    a = rng.normal(300, 40, (4, 30, 17, 2))  # 4 sets of 30 poses
    a_valid = rng.random((4, 30, 17)) < 0.8
    b = rng.normal(300, 40, (5, 17, 2))
    b_valid = rng.random((5, 17)) < 0.8
    area = rng.uniform(500, 5000, 5)
    full = pairwise_oks(a.reshape(-1, 17, 2), b, b_valid, area, a_valid=a_valid.reshape(-1, 17)).reshape(
        4, 30, 5
    )
    ki, di = np.array([0, 3, 3, 1]), np.array([4, 0, 2, 2])
    np.testing.assert_array_equal(
        paired_oks(a[ki], a_valid[ki], b[di], b_valid[di], area[di]), full[ki, :, di]
    )
    inside = a_valid[..., None]
    low, high = np.min(np.where(inside, a, np.inf), axis=1), np.max(np.where(inside, a, -np.inf), axis=1)
    bound = oks_upper_bound(low, high, a_valid.any(axis=1), b, b_valid, area)
    assert bound.shape == (4, 5) and np.all(full.max(axis=1) <= bound + 1e-15)
    one = oks_upper_bound(b[:1], b[:1], b_valid[:1], b[:1], b_valid[:1], area[:1])  # a pose in its own box
    np.testing.assert_allclose(one, 1.0)
