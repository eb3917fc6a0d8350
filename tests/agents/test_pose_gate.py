"""pose-baseline's gate sized from the data, the pose runs' warnings, and ``track run`` on pose
files stopping before any tracking (and any output) on bad ground truth."""

from __future__ import annotations

import json

import numpy as np
import pytest

from agents.pose.gate import DEFAULT_AREA_FACTOR, MARGIN, needed_area_factor, pose_gate
from track_apps.cli.run import main
from track_envs.envs.pose_recording import record_keypoint_walkers
from track_envs.io.poses import read_pose_file, write_coco_results, write_posetrack
from track_envs.metrics.keypoints import COCO_SIGMAS

#: A standing person's 17 COCO keypoints (x, y) in a 40 × 100 box (COCO order).
PERSON = np.array(
    [
        [20, 5], [23, 3], [17, 3], [27, 4], [13, 4], [30, 20], [10, 20], [34, 40], [6, 40],
        [36, 58], [4, 58], [27, 58], [13, 58], [28, 80], [12, 80], [29, 100], [11, 100],
    ],
    float,
)  # fmt: skip


def walkers(step: float, *, size: float = 200.0, people: int = 4, frames: int = 40, seed: int = 0):
    """COCO detections and PoseTrack truth of ``people`` people ``size`` tall walking ``step`` a frame."""
    rng = np.random.default_rng(seed)
    pose = PERSON * size / 100.0
    records, images, annotations = [], [], []
    for t in range(frames):
        images.append({"id": t + 1, "file_name": f"v/{t:06d}.jpg", "frame_id": t + 1})
        for p in range(people):
            xy = pose + np.array([50 + step * t, 60 + 1.6 * size * p]) + rng.normal(0, 1.0, (17, 2))
            kp = np.concatenate([xy, np.full((17, 1), 2.0)], axis=1).reshape(-1).tolist()
            records.append({"image_id": t + 1, "category_id": 1, "keypoints": kp, "score": 0.9})
            head = [float(xy[:, 0].min()), float(xy[:, 1].min()), size / 10, size / 10]
            annotations.append({"image_id": t + 1, "track_id": p, "keypoints": kp, "bbox_head": head})
    return records, {"images": images, "annotations": annotations}


@pytest.fixture(scope="module")
def fast(tmp_path_factory):
    root = tmp_path_factory.mktemp("fast")
    det, gt = walkers(25.0)
    (root / "det.json").write_text(json.dumps(det))
    (root / "gt.json").write_text(json.dumps(gt))
    return root


def run(capsys, *argv):
    code = main([*map(str, argv), "--no-progress"])
    captured = capsys.readouterr()
    table = dict(line.split() for line in captured.out.splitlines()[2:]) if code == 0 else {}
    return code, table, captured.err


def test_needed_area_factor_scores_the_threshold_at_the_margin():
    a = needed_area_factor(0.25, 0.3)
    kappa2 = (2 * COCO_SIGMAS) ** 2
    assert np.mean(np.exp(-(0.25**2) / (2 * a * kappa2))) == pytest.approx(0.3, abs=1e-9)
    assert needed_area_factor(0.0, 0.3) == 0.0


def test_the_gate_is_sized_from_the_motion_and_is_unit_free(fast, tmp_path):
    gate = pose_gate(read_pose_file(fast / "det.json"))
    # 25 px a frame for people 200 px tall: r = 0.125 of their size
    assert gate.motion == pytest.approx(0.125, abs=0.01) and gate.size == pytest.approx(200, abs=5)
    assert gate.n_pairs == 39 * 4
    assert gate.area_factor == gate.needed == pytest.approx(needed_area_factor(MARGIN * gate.motion, 0.3))
    assert gate.area_factor > 1.0
    det, _ = walkers(25.0 * 3, size=600.0)  # the same scene, three times as large
    (tmp_path / "big.json").write_text(json.dumps(det))
    big = pose_gate(read_pose_file(tmp_path / "big.json"))
    assert big.motion == pytest.approx(gate.motion, rel=0.02) and big.area_factor == pytest.approx(
        gate.area_factor, rel=0.05
    )


def test_slow_people_keep_the_default_gate():
    det, _ = record_keypoint_walkers(15, seed=1, num_people=4, initial_people=4)
    gate = pose_gate(det)
    assert gate.area_factor == DEFAULT_AREA_FACTOR and gate.needed < DEFAULT_AREA_FACTOR
    assert "the default, wide enough" in gate.describe()


def test_fast_walkers_keep_their_ids_with_the_gate_from_the_data(fast, tmp_path, capsys):
    """Measured: 4 people walking 25 px a frame, 40 frames — the default gate gives 160 ids (one per
    pose), MOTA 0.025; the gate from the data 4 ids, MOTA 1.0 (as pose-smc)."""
    out = tmp_path / "t.json"
    det, gt = fast / "det.json", fast / "gt.json"
    code, table, err = run(capsys, det, "--gt", gt, "--metrics", "--out", out)
    assert code == 0 and float(table["mota"]) == 1.0 and float(table["id_switches"]) == 0
    assert len(set(read_pose_file(out).track_ids.tolist())) == 4
    assert "gate: poses move 0.12" in err and "widened from the default 0.25" in err
    assert "warning" not in err
    code, table, err = run(
        capsys, det, "--gt", gt, "--metrics", "--agent-kwargs", "area_factor=0.25", "--out", out
    )
    assert code == 0 and float(table["mota"]) == pytest.approx(0.025)
    assert len(set(read_pose_file(out).track_ids.tolist())) == 160
    assert "gate:" not in err
    assert (
        "warning: most poses start a track: 160 ids for 160 poses (ids/poses = 1.00 > 0.5; 40.0 ids per "
        "person for at most 4 poses in a frame)" in err
    )
    assert err.count("most poses start a track") == 1
    assert "warning: most poses are in tracks 1-2 frames long: 100% of the 160 tracked poses" in err


def test_a_well_tracked_episode_is_not_warned_about(tmp_path, capsys):
    """KeypointWalkers-v0, 60 frames, 10 people: 20 ids, 13 of them a false positive's 1-2 frames
    (17 of the 250 poses, 7%) — no warning."""
    det, _ = record_keypoint_walkers(60, seed=0, num_people=10)
    write_coco_results(tmp_path / "det.json", det)
    code, _, err = run(capsys, tmp_path / "det.json", "--out", tmp_path / "t.json")
    assert code == 0 and "20 tracks" in err and "warning" not in err


def test_shuffled_ground_truth_gives_the_same_tracks_and_scores(tmp_path, capsys):
    det, gt = record_keypoint_walkers(15, seed=1, num_people=4, initial_people=4)
    write_coco_results(tmp_path / "det.json", det)
    write_posetrack(tmp_path / "gt.json", gt)
    data = json.loads((tmp_path / "gt.json").read_text())
    data["images"] = list(np.random.default_rng(0).permutation(data["images"]))
    (tmp_path / "shuffled.json").write_text(json.dumps(data))
    results = []
    for name in ("gt", "shuffled"):
        out = tmp_path / f"{name}-tracks.json"
        code, table, _ = run(
            capsys, tmp_path / "det.json", "--gt", tmp_path / f"{name}.json", "--metrics", "--out", out
        )
        assert code == 0
        results.append((table, read_pose_file(out)))
    assert results[0][0] == results[1][0] and results[0][1].equals(results[1][1])
    assert float(results[0][0]["mota"]) == pytest.approx(0.6554, abs=5e-4)  # as the ordered file always gave


@pytest.mark.parametrize("key", ["bbox_head", "track_id"])
def test_bad_ground_truth_stops_the_run_before_tracking_and_output(fast, tmp_path, capsys, key):
    _, gt = walkers(25.0)
    del gt["annotations"][5][key]
    (tmp_path / "gt.json").write_text(json.dumps(gt))
    out = tmp_path / "t.json"
    code, _, err = run(capsys, fast / "det.json", "--gt", tmp_path / "gt.json", "--metrics", "--out", out)
    assert code == 2 and not out.exists()
    assert f"error: {tmp_path / 'gt.json'}: annotation 5 (image id 2) has no '{key}'" in err
    assert "gate:" not in err and "frames" not in err  # stopped before the gate and the tracking


def test_unwritable_out_stops_the_run_first(fast, tmp_path, capsys):
    code, _, err = run(capsys, fast / "det.json", "--out", tmp_path / "nowhere" / "t.json")
    assert code == 2 and "t.json: cannot write: directory" in err and "gate:" not in err


def test_repeated_detections_are_warned_with_their_count(tmp_path, capsys):
    det, _ = walkers(5.0, frames=5)
    det += det[:3]
    (tmp_path / "det.json").write_text(json.dumps(det))
    code, _, err = run(capsys, tmp_path / "det.json", "--out", tmp_path / "t.json")
    assert code == 0 and "warning:" in err and "3 poses of 23 are such repeats" in err
