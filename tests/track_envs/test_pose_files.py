"""Pose files: COCO keypoint results and PoseTrack 2018 in, PoseTrack results out, bad values named."""

from __future__ import annotations

import json

import numpy as np
import pytest

from track_envs.envs.pose_recording import record_keypoint_walkers
from track_envs.io.poses import (
    coco_results_json,
    image_list,
    json_pose_format,
    posetrack_json,
    posetrack_track_ids,
    read_pose_file,
    write_coco_results,
    write_posetrack,
)
from track_envs.values.poses import PoseStream, pose_observation, pose_sensor_spec


@pytest.fixture(scope="module")
def episode() -> tuple[PoseStream, PoseStream]:
    return record_keypoint_walkers(25, seed=3, num_people=4, clutter_rate=0.3)


def remapped(stream: PoseStream) -> PoseStream:
    return stream.with_rows(track_ids=posetrack_track_ids(stream.frame_index(), stream.track_ids))


def test_recorded_episode_is_what_the_env_saw(episode):
    det, gt = episode
    assert det.n_frames == gt.n_frames == 25
    assert len(det) > 0 and len(gt) > 0
    # detections: v = 2 exactly where a score was drawn; truth: v = 1 where visible, head boxes everywhere
    assert set(np.unique(det.visibility).tolist()) <= {0, 2}
    assert np.array_equal(det.keypoint_scores > 0, det.visibility == 2)
    assert set(np.unique(gt.visibility).tolist()) == {0, 1}
    assert np.all(np.isfinite(gt.head_boxes)) and np.all(gt.track_ids >= 0)


def test_posetrack_ground_truth_round_trips(episode, tmp_path):
    _, gt = episode
    write_posetrack(tmp_path / "gt.json", gt)
    back = read_pose_file(tmp_path / "gt.json")
    assert back.equals(remapped(gt))
    assert back.video_id == "000001" and back.file_names == gt.file_names


def test_coco_results_round_trip_in_sorted_and_given_frame_order(episode, tmp_path):
    det, _ = episode
    write_coco_results(tmp_path / "det.json", det)
    assert json_pose_format(json.loads((tmp_path / "det.json").read_text())) == "coco"
    given = read_pose_file(tmp_path / "det.json", frames=det.image_ids.tolist(), file_names=det.file_names)
    assert given.equals(det.with_rows(video_id=None))
    sorted_ids = read_pose_file(tmp_path / "det.json")  # only the frames with a pose, by image id
    kept = det.image_ids[det.counts > 0]
    assert np.array_equal(sorted_ids.image_ids, kept) and sorted_ids.file_names is None
    assert np.array_equal(sorted_ids.keypoints, det.keypoints)
    # frame order from a PoseTrack file's images, reversed: the poses follow their images
    write_posetrack(tmp_path / "order.json", det.with_rows(track_ids=np.arange(len(det))))
    ids, names = image_list(tmp_path / "order.json")
    assert ids == det.image_ids.tolist() and names == list(det.file_names or ())
    rev = read_pose_file(tmp_path / "det.json", frames=ids[::-1])
    assert np.array_equal(rev.counts, det.counts[::-1])
    (tmp_path / "ids.txt").write_text("\n".join(map(str, ids)) + "\n")
    assert image_list(tmp_path / "ids.txt") == (ids, None)


def test_observation_packs_as_keypoint_walkers(episode):
    det, _ = episode
    spec = pose_sensor_spec(det, image_size=(1280, 720))
    t = int(np.argmax(det.counts))
    obs = pose_observation(det, t, spec)
    m = det.counts[t]
    assert obs["detections"].shape == (spec.max_detections, 17, 3) and obs["detections"].dtype == np.float32
    assert obs["mask"].tolist() == [1] * m + [0] * (spec.max_detections - m)
    rows = det.frame_rows(t)
    np.testing.assert_array_equal(obs["detections"][:m, :, 2], det.keypoint_scores[rows].astype(np.float32))
    np.testing.assert_array_equal(obs["detections"][:m, :, :2], det.keypoints[rows].astype(np.float32))
    assert spec.region_high == (1280.0, 720.0) and spec.units == "px" and spec.max_detections >= 16


def test_track_ids_fit_0_to_999_reusing_ended_tracks():
    # 5 tracks, limit 3: ids by first frame, then the smallest id of a track that has ended
    frame = np.array([0, 0, 1, 2, 3, 4, 4])
    ids = np.array([70, 50, 60, 50, 80, 90, 80])
    # tracks: 50 (frames 0-2) -> 0, 70 (0) -> 1, 60 (1) -> 2; at frame 3 all three have ended:
    # 80 (3-4) takes 0, then 90 (4) takes 1
    np.testing.assert_array_equal(posetrack_track_ids(frame, ids, limit=3), [1, 0, 2, 0, 0, 1, 0])
    np.testing.assert_array_equal(posetrack_track_ids(frame, ids), [1, 0, 2, 0, 3, 4, 3])
    with pytest.raises(ValueError, match="more than 2 tracks overlap in time at frame 1"):
        posetrack_track_ids(np.array([0, 0, 1, 1, 1]), np.array([1, 2, 1, 2, 3]), limit=2)
    many = np.arange(2500)
    out = posetrack_track_ids(many // 2, many)  # 2,500 tracks, two a frame, one frame each
    assert out.min() == 0 and out.max() == 999


def test_writer_needs_track_ids(episode):
    det, _ = episode
    with pytest.raises(ValueError, match="needs a track id"):
        posetrack_json(det)
    records = coco_results_json(det)
    assert len(records) == len(det) and len(records[0]["keypoints"]) == 51


def coco_record(**change):
    kp = [10.0, 20.0, 2] * 17
    record = {"image_id": 1, "category_id": 1, "keypoints": kp, "score": 0.9}
    record.update(change)
    return record


def with_keypoint(j, values):
    kp = [10.0, 20.0, 2] * 17
    kp[3 * j : 3 * j + 3] = values
    return kp


@pytest.mark.parametrize(
    ("record", "message"),
    [
        (
            coco_record(keypoints=with_keypoint(5, [10.0, 20.0, 3])),
            r"annotation 1 \(image id \d+\): keypoint 'left_shoulder': v = 3\.0 is not a COCO visibility",
        ),
        (
            coco_record(keypoints=with_keypoint(0, [10.0, 20.0, 0.87])),
            r"annotation 1 \(image id \d+\): keypoint 'nose': v = 0\.87 is not a COCO",
        ),
        (
            coco_record(keypoints=with_keypoint(16, [-4.0, 20.0, 1])),
            r"annotation 1 \(image id \d+\): keypoint 'right_ankle': x = -4\.0 is negative",
        ),
        (
            coco_record(keypoints=with_keypoint(9, [4.0, -0.5, 2])),
            r"annotation 1 \(image id \d+\): keypoint 'left_wrist': y = -0\.5 is negative",
        ),
        (
            coco_record(keypoints=with_keypoint(2, [float("nan"), 1.0, 2])),
            r"annotation 1 \(image id \d+\): keypoint 'right_eye': x = nan is not finite",
        ),
        (
            coco_record(keypoints=with_keypoint(2, [1.0, 1.0, float("inf")])),
            r"annotation 1 \(image id \d+\): keypoint 'right_eye': v = inf is not finite",
        ),
        (
            coco_record(keypoints=[1.0] * 50),
            r"annotation 1 \(image id \d+\): 'keypoints' must hold 51 values \(17 × x, y, v\), got 50 values",
        ),
        (
            coco_record(keypoints=with_keypoint(1, ["a", 1.0, 2])),
            r"annotation 1 \(image id \d+\): keypoint 'left_eye': "
            r"x is not a number \(or beyond any float\): 'a'",
        ),
        (
            coco_record(scores=[0.5] * 16 + [1.5]),
            r"annotation 1 \(image id \d+\): keypoint 'right_ankle': score = 1\.5 is not in \[0, 1\]",
        ),
        (
            coco_record(scores=[0.5] * 3),
            r"annotation 1 \(image id \d+\): 'scores' must hold 17 keypoint confidences",
        ),
        (
            coco_record(score="high"),
            r"annotation 1 \(image id \d+\): 'score' must be a finite number, got 'high'",
        ),
        (coco_record(image_id="1"), r"annotation 1: 'image_id' must be an integer, got '1'"),
    ],
)
def test_bad_coco_values_are_named(tmp_path, record, message):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps([coco_record(), record]))
    with pytest.raises(ValueError, match=message) as err:
        read_pose_file(path)
    assert str(path) in str(err.value)


def test_unlabelled_keypoints_read_as_zero_and_negative_is_fine_there(tmp_path):
    path = tmp_path / "ok.json"
    path.write_text(json.dumps([coco_record(keypoints=with_keypoint(3, [-5.0, 7.0, 0]))]))
    s = read_pose_file(path)
    assert (
        s.visibility[0, 3] == 0 and s.keypoints[0, 3].tolist() == [0.0, 0.0] and s.keypoint_scores[0, 3] == 0
    )
    assert s.keypoint_scores[0, 0] == 1.0 and s.scores[0] == 0.9 and s.track_ids[0] == -1


def posetrack_file(annotations, images=None):
    images = images if images is not None else [{"id": 1, "file_name": "images/v/000000.jpg"}]
    return {"images": images, "annotations": annotations}


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (
            posetrack_file([coco_record(track_id=-2)]),
            r"annotation 0 \(image id \d+\): 'track_id' must be an integer >= 0 \(64 bits\), got -2",
        ),
        (
            posetrack_file([coco_record(bbox_head=[1, 2, -3, 4])]),
            r"annotation 0 \(image id \d+\): 'bbox_head' must be 4 finite numbers",
        ),
        (
            posetrack_file([coco_record(image_id=7)]),
            r"annotation 0 has image_id 7, which is not among the 1 frames",
        ),
        (posetrack_file([], images=[{"id": 1}, {"id": 1}]), r"image id 1 is listed twice"),
        (posetrack_file([], images=[{"file_name": "x.jpg"}]), r"images\[0\]: 'id' must be an integer"),
        ({"annotations": []}, r"neither COCO keypoint results .* nor PoseTrack"),
    ],
)
def test_bad_posetrack_values_are_named(tmp_path, data, message):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=message) as err:
        read_pose_file(path)
    assert str(path) in str(err.value)


def test_not_json_is_named(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text("[{")
    with pytest.raises(ValueError, match=r"broken\.json: not JSON"):
        read_pose_file(path)
