"""Pose files a user may have: frames in any list order, bad bytes, bad values, repeats, ground
truth checked whole — each read correctly or stopped with a PoseFileError naming the file, the
annotation (and image id), the keypoint and the value; writes that fail leave the old file."""

from __future__ import annotations

import errno
import json
import os

import numpy as np
import pytest

from track_envs.envs.pose_recording import record_keypoint_walkers
from track_envs.infra.atomic import FileWriteError
from track_envs.io.csv_parser import TrackFileError
from track_envs.io.poses import (
    PoseFileError,
    PoseFileWarning,
    image_list,
    read_pose_file,
    write_coco_results,
    write_posetrack,
)


@pytest.fixture(scope="module")
def episode(tmp_path_factory):
    root = tmp_path_factory.mktemp("checks")
    det, gt = record_keypoint_walkers(12, seed=5, num_people=3, initial_people=3)
    write_coco_results(root / "det.json", det)
    write_posetrack(root / "gt.json", gt)
    return root, det, gt


def test_pose_file_error_is_a_track_file_error():
    assert issubclass(PoseFileError, TrackFileError) and issubclass(PoseFileError, ValueError)


def test_shuffled_images_read_as_the_ordered_file(episode, tmp_path):
    root, _, _ = episode
    data = json.loads((root / "gt.json").read_text())
    ordered = read_pose_file(root / "gt.json")
    for seed in range(3):
        shuffled = dict(data, images=list(np.random.default_rng(seed).permutation(data["images"])))
        (tmp_path / "s.json").write_text(json.dumps(shuffled))
        assert read_pose_file(tmp_path / "s.json").equals(ordered)
        assert image_list(tmp_path / "s.json") == image_list(root / "gt.json")


def test_frame_order_without_frame_id_follows_file_names_then_ids(tmp_path):
    names = ["v/000010.jpg", "v/000009.jpg", "v/000100.jpg"]  # natural order: 9, 10, 100
    images = [{"id": i, "file_name": n} for i, n in zip((30, 20, 10), names, strict=True)]
    (tmp_path / "a.json").write_text(json.dumps({"images": images, "annotations": []}))
    s = read_pose_file(tmp_path / "a.json")
    assert s.image_ids.tolist() == [20, 30, 10] and s.file_names == ("v/000009.jpg", names[0], names[2])
    (tmp_path / "b.json").write_text(json.dumps({"images": [{"id": 3}, {"id": 1}], "annotations": []}))
    assert read_pose_file(tmp_path / "b.json").image_ids.tolist() == [1, 3]


@pytest.mark.parametrize(
    ("images", "message"),
    [
        ([{"id": 1, "frame_id": 5}, {"id": 2}], r"images\[1\] \(id 2\) has no 'frame_id' while 1 of the 2"),
        (
            [{"id": 1, "frame_id": 5}, {"id": 2, "frame_id": 5}],
            r"1 images repeat the frame_id .* 5 is listed",
        ),
        ([{"id": 1, "frame_id": "5"}], r"images\[0\] \(id 1\): 'frame_id' must be an integer, got '5'"),
        ([{"id": 4}, {"id": 4}, {"id": 4}], r"2 images repeat the image id of another \(e.g. image id 4"),
        ([{"id": 2**64}], r"images\[0\]: 'id' = 18446744073709551616 is beyond 64 bits"),
    ],
)
def test_bad_frame_lists_are_named(tmp_path, images, message):
    path = tmp_path / "gt.json"
    path.write_text(json.dumps({"images": images, "annotations": []}))
    with pytest.raises(PoseFileError, match=message) as err:
        read_pose_file(path)
    assert str(err.value).startswith(f"{path}: ")


def _record(**fields):
    kp = [v for j in range(17) for v in (10.0 + j, 20.0 + j, 2)]
    return {"image_id": 7, "category_id": 1, "keypoints": kp, "score": 0.9} | fields


@pytest.mark.parametrize(
    ("record", "message"),
    [
        (
            _record(keypoints=[1e300, 20.0, 2] + [10.0, 20.0, 2] * 16),
            r"'nose': x = 1e\+300 is beyond 1e\+12 px",
        ),
        (
            _record(keypoints=[5.0, 10**400, 2] + [10.0, 20.0, 2] * 16),
            r"'nose': y is not a number \(or beyond any",
        ),
        (_record(keypoints=["10", 20.0, 2] + [10.0, 20.0, 2] * 16), r"'nose': x is not a number .*: '10'"),
        (
            _record(keypoints=[10.0, 20.0, 2] * 16 + [None, 1.0, 2]),
            r"'right_ankle': x is not a number .*: None",
        ),
        (_record(keypoints=[10.0, 20.0, 2] * 16 + [[1.0], 1.0, 2]), r"'right_ankle': x is not a number"),
        (_record(keypoints=[10.0, 20.0, True] * 17), r"'nose': v is not a number .*: True"),
        (_record(score=float("inf")), r"'score' must be a finite number, got inf"),
        (_record(scores=["0.5"] * 17), r"'scores' must hold numbers"),
        (_record(image_id=10**30), r"annotation 1: 'image_id' = 10+ is beyond 64 bits"),
    ],
)
def test_bad_values_name_file_annotation_image_keypoint_and_value(tmp_path, record, message):
    path = tmp_path / "det.json"
    path.write_text(json.dumps([_record(), record]))
    with pytest.raises(PoseFileError, match=message) as err:
        read_pose_file(path)
    text = str(err.value)
    assert text.startswith(f"{path}: annotation 1") and "\n" not in text
    if "image_id" not in record or record["image_id"] == 7:
        assert "annotation 1 (image id 7)" in text


@pytest.mark.parametrize(
    ("raw", "message"),
    [
        (bytes(range(256)), r"not a UTF-8 JSON text file \(byte 0x80 at position 128"),
        ('[{"image_id": "é"}]'.encode("latin-1"), r"not a UTF-8 JSON text file \(byte 0xe9 at position 15"),
        (json.dumps([_record()]).encode("utf-16"), r"not a UTF-8 JSON text file"),
        (b'[{"image_id": 1}]\x00', r"a NUL byte at position 17"),
        (
            json.dumps([_record(), _record()]).encode()[:-40],
            r"not JSON: .* \(the file ends early: cut short\?\)",
        ),
        (b"[" * 100_000, r"not (JSON|a pose file)"),
    ],
)
def test_unreadable_files_are_named(tmp_path, raw, message):
    path = tmp_path / "det.json"
    path.write_bytes(raw)
    with pytest.raises(PoseFileError, match=message) as err:
        read_pose_file(path)
    assert str(err.value).startswith(f"{path}: ")


def test_missing_file_and_byte_order_mark(tmp_path):
    with pytest.raises(PoseFileError, match=r"nope.json: cannot read: No such file"):
        read_pose_file(tmp_path / "nope.json")
    path = tmp_path / "bom.json"
    path.write_bytes(b"\xef\xbb\xbf" + json.dumps([_record()]).encode())
    assert len(read_pose_file(path)) == 1


def test_unlabelled_keypoints_may_hold_any_number(tmp_path):
    path = tmp_path / "det.json"
    path.write_text(json.dumps([_record(keypoints=[1e300, -5.0, 0] + [10.0, 20.0, 2] * 16)]))
    s = read_pose_file(path)
    assert s.visibility[0, 0] == 0 and s.keypoints[0, 0].tolist() == [0.0, 0.0]


def test_repeated_detections_are_read_with_a_warning_and_their_count(tmp_path):
    path = tmp_path / "det.json"
    path.write_text(json.dumps([_record(), _record(), _record(image_id=8), _record(), _record(image_id=8)]))
    with pytest.warns(
        PoseFileWarning, match=r"annotation 1 \(image id 7\) repeats .*: 3 poses of 5 are such"
    ):
        s = read_pose_file(path)
    assert len(s) == 5


def test_ground_truth_is_checked_whole(episode, tmp_path):
    root, _, _ = episode
    data = json.loads((root / "gt.json").read_text())
    for key, why in (("bbox_head", "PCKh"), ("track_id", "id of its person")):
        broken = json.loads(json.dumps(data))
        del broken["annotations"][-1][key]
        (tmp_path / "gt.json").write_text(json.dumps(broken))
        read_pose_file(tmp_path / "gt.json")  # fine as detections
        last = len(broken["annotations"]) - 1
        image = broken["annotations"][-1]["image_id"]
        with pytest.raises(
            PoseFileError, match=rf"annotation {last} \(image id {image}\) has no '{key}': .*{why}"
        ):
            read_pose_file(tmp_path / "gt.json", ground_truth=True)
    twice = json.loads(json.dumps(data))
    twice["annotations"].append(dict(twice["annotations"][0], keypoints=[1.0, 2.0, 1] * 17))
    (tmp_path / "gt.json").write_text(json.dumps(twice))
    with pytest.raises(
        PoseFileError, match=r"track_id \d+ appears twice in this image \(1 annotations repeat"
    ):
        read_pose_file(tmp_path / "gt.json", ground_truth=True)


def test_coco_frames_from_a_shuffled_image_list_follow_frame_id(episode, tmp_path):
    root, _, _ = episode
    data = json.loads((root / "gt.json").read_text())
    data["images"] = data["images"][::-1]
    (tmp_path / "gt.json").write_text(json.dumps(data))
    ordered = read_pose_file(root / "det.json", frames=image_list(root / "gt.json")[0])
    shuffled = read_pose_file(root / "det.json", frames=image_list(tmp_path / "gt.json")[0])
    assert shuffled.equals(ordered)


def test_binary_frame_list_is_named(tmp_path):
    path = tmp_path / "frames.txt"
    path.write_bytes(b"1\n2\n\xff\xfe\n")
    with pytest.raises(PoseFileError, match=r"frames.txt: not a UTF-8 text file of image ids"):
        image_list(path)


@pytest.mark.parametrize("writer", [write_posetrack, write_coco_results])
def test_a_failed_write_keeps_the_old_file_and_names_it(episode, tmp_path, monkeypatch, writer):
    _, _, gt = episode
    path = tmp_path / "tracks.json"
    path.write_text("old")

    def full_disk(data, f):
        f.write('{"images": [')
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr("track_envs.io.poses.json.dump", full_disk)
    with pytest.raises(FileWriteError, match=rf"{path}: cannot write: No space left on device \(ENOSPC\)"):
        writer(path, gt)
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["tracks.json"]
