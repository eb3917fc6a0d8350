"""Per-joint MOTA (PoseTrack's PCKh rule) and HOTA (OKS) of tracked poses against PoseTrack ground truth."""

from __future__ import annotations

import motmetrics as mm
import numpy as np
import pytest

from track_envs.envs.pose_recording import record_keypoint_walkers
from track_envs.metrics.keypoints import KEYPOINT_NAMES
from track_envs.metrics.pose_scoring import per_joint_mota, pose_hota, score_poses
from track_envs.values.poses import PoseStream

HEAD = 10 / 0.6 / np.sqrt(2)  # a square head box of head size 0.6 · diagonal = 10 px


def poses(frames, **columns):
    """A stream of ``frames`` (one list of (track id, {keypoint index: (x, y)}) per frame)."""
    rows = [pose for frame in frames for pose in frame]
    kp = np.zeros((len(rows), 17, 2))
    vis = np.zeros((len(rows), 17), np.int8)
    for i, (_, points) in enumerate(rows):
        for j, xy in points.items():
            kp[i, j], vis[i, j] = xy, 1
    return PoseStream(
        keypoints=kp,
        visibility=vis,
        keypoint_scores=vis.astype(float),
        offsets=np.concatenate([[0], np.cumsum([len(f) for f in frames])]),
        image_ids=np.arange(1, len(frames) + 1),
        track_ids=np.array([tid for tid, _ in rows], np.int64),
        head_boxes=np.tile([0.0, 0.0, HEAD, HEAD], (len(rows), 1)),
        **columns,
    )


def test_tiny_case_by_hand():
    # PCKh radius 0.5 · 10 px = 5 px. Nose (0): truths A (id 1) and B (id 2); hypotheses 7 and 8.
    # frame 1: 7 matches A (1 px), 8 is 100 px from both: a false positive; B a miss; the left eye (1)
    #          of A is labelled, 7's eye is 50 px away: a miss and a false positive.
    # frame 2: 7 matches B, 8 matches A: A switches from 7 to 8 (one switch; B's first match is none).
    # frame 3: no hypotheses: two misses. 7's right ankle (16) is never labelled in the truth.
    truth = poses(
        [
            [(1, {0: (10, 10), 1: (12, 8)}), (2, {0: (100, 10)})],
            [(1, {0: (10, 10)}), (2, {0: (100, 10)})],
            [(1, {0: (10, 10)}), (2, {0: (100, 10)})],
        ]
    )
    tracks = poses(
        [
            [(7, {0: (11, 10), 1: (62, 8), 16: (5, 5)}), (8, {0: (200, 10)})],
            [(7, {0: (101, 10)}), (8, {0: (10, 13)})],
            [],
        ]
    )
    m = per_joint_mota(tracks, truth)
    # nose: GT 6, FN 1 + 0 + 2, FP 1, IDSW 1 -> 1 - 5/6; left eye: GT 1, FN 1, FP 1 -> -1
    assert m["mota_nose"] == pytest.approx(1 / 6)
    assert m["mota_left_eye"] == pytest.approx(-1.0)
    assert np.isnan(m["mota_right_ankle"]) and np.isnan(m["mota_left_hip"])
    assert m["mota"] == pytest.approx(1 - 7 / 7)
    assert (m["num_objects"], m["num_misses"], m["num_false_positives"], m["id_switches"]) == (7, 4, 2, 1)


def test_frames_without_truth_annotations_are_not_scored():
    truth = poses([[(1, {0: (10, 10)})], [], [(1, {0: (10, 10)})]])
    tracks = poses([[(5, {0: (10, 10)})], [(6, {0: (300, 300)}), (7, {0: (9, 9)})], [(5, {0: (10, 11)})]])
    metrics, notes = score_poses(tracks, truth)
    assert metrics["mota"] == 1.0 and metrics["mota_nose"] == 1.0
    assert notes[0] == "1 ground-truth frames without annotations are not scored"


def test_truth_without_head_box_is_named():
    truth = poses([[(1, {0: (10, 10)})]])
    truth = truth.with_rows(head_boxes=np.full((1, 4), np.nan))
    with pytest.raises(ValueError, match=r"ground-truth pose 0 \(image id 1, track 1\) has no bbox_head"):
        per_joint_mota(truth, truth)


@pytest.fixture(scope="module")
def episode() -> tuple[PoseStream, PoseStream]:
    return record_keypoint_walkers(40, seed=5, num_people=5, clutter_rate=0.5)


def reference_mota(tracks: PoseStream, truth: PoseStream, pckh: float = 0.5) -> dict[str, float]:
    """poseval's per-joint MOTA, written out with loops, on py-motmetrics' accumulator."""
    accs = [mm.MOTAccumulator(auto_id=True) for _ in range(17)]
    for t in range(truth.n_frames):
        g = range(truth.offsets[t], truth.offsets[t + 1])
        if not len(g):
            continue
        h = range(tracks.offsets[t], tracks.offsets[t + 1])
        for j in range(17):
            gr = [i for i in g if truth.visibility[i, j] > 0]
            hr = [i for i in h if tracks.visibility[i, j] > 0]
            dist = np.full((len(gr), len(hr)), np.nan)
            for a, i in enumerate(gr):
                w, hh = truth.head_boxes[i, 2:]
                head = 0.6 * np.sqrt(w * w + hh * hh)
                for b, k in enumerate(hr):
                    d = np.linalg.norm(truth.keypoints[i, j] - tracks.keypoints[k, j]) / head
                    if d <= pckh:
                        dist[a, b] = d
            accs[j].update(truth.track_ids[gr].tolist(), tracks.track_ids[hr].tolist(), dist)
    out, errors, objects = {}, 0.0, 0.0
    mh = mm.metrics.create()
    for j, acc in enumerate(accs):
        df = mh.compute(acc, metrics=["num_misses", "num_false_positives", "num_switches", "num_objects"])
        s = {key: float(df[key].iloc[0]) for key in df.columns}
        e = s["num_misses"] + s["num_false_positives"] + s["num_switches"]
        if s["num_objects"] > 0:
            out[f"mota_{KEYPOINT_NAMES[j]}"] = 1 - e / s["num_objects"]
            errors += e
            objects += s["num_objects"]
    out["mota"] = 1 - errors / objects
    return out


@pytest.mark.parametrize("agent", ["pose-baseline", "detections-as-tracks"])
def test_per_joint_mota_matches_motmetrics_on_a_walkers_episode(episode, agent):
    from agents import make_agent
    from agents.files.poses import run_pose_agent
    from track_envs.values.poses import pose_sensor_spec

    det, gt = episode
    if agent == "detections-as-tracks":  # every detection its own track: many switches
        tracks = det.with_rows(track_ids=np.arange(len(det)))
    else:
        tracks = run_pose_agent(make_agent(agent), det, pose_sensor_spec(det, image_size=(1280, 720)))
    mine = per_joint_mota(tracks, gt)
    ref = reference_mota(tracks, gt)
    for key, value in ref.items():
        assert mine[key] == pytest.approx(value, abs=1e-12), key
    assert {k for k, v in mine.items() if k.startswith("mota_") and np.isfinite(v)} == set(ref) - {"mota"}


def test_perfect_tracks_score_one(episode):
    _, gt = episode
    metrics, _ = score_poses(gt, gt)
    assert (
        metrics["mota"] == 1.0
        and metrics["hota"] == pytest.approx(1.0)
        and metrics["ass_a"] == pytest.approx(1.0)
    )


def test_hota_uses_oks_and_drops_with_identity_errors(episode):
    _, gt = episode
    # the truth with ids swapped halfway: detection stays, association halves
    half = gt.frame_index() >= gt.n_frames // 2
    swapped = gt.with_rows(track_ids=np.where(half, gt.track_ids + 1000, gt.track_ids))
    h = pose_hota(swapped, gt)
    assert h["det_a"] == pytest.approx(1.0) and h["loc_a"] == pytest.approx(1.0)
    assert 0.3 < h["ass_a"] < 0.75 and h["hota"] == pytest.approx(np.sqrt(h["ass_a"]))
