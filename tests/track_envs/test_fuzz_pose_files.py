"""Fuzzed pose files: every mutation of a valid COCO results or PoseTrack file is either read or
stopped with a [`PoseFileError`][track_envs.io.PoseFileError] — never another exception — and
``track run`` on it ends with exit code 0 and a whole results file, or a one-line error and no
file at all.

Mutations: bytes (cut short, flipped, inserted, the file re-encoded as UTF-16 / Latin-1, a binary
prefix), records (dropped, repeated, shuffled; images too) and values (a field or a keypoint
value replaced by a string, null, a nested list, an object, true, an integer or float beyond any
image or any float, a non-finite number, a negative number).
"""

from __future__ import annotations

import contextlib
import copy
import io
import json
import math
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from track_apps.cli.run import main
from track_envs.io.poses import PoseFileError, image_list, read_pose_file

# repeated poses are read with a PoseFileWarning (tested in test_pose_file_checks)
pytestmark = pytest.mark.filterwarnings("ignore::track_envs.io.poses.PoseFileWarning")

FRAMES, PEOPLE, K = 4, 2, 17

#: Values a field or a keypoint value is replaced with.
ODD_VALUES: list[Any] = [
    "12.5",
    "",
    None,
    [1.0, 2.0],
    [[1.0]],
    {"x": 1},
    True,
    False,
    10**400,
    -(10**30),
    2**63,
    1e300,
    -1e300,
    float("nan"),
    float("inf"),
    -float("inf"),
    -1,
    0,
    3,
    0.5,
    1e12 + 1,
]


def _pose(t: int, p: int) -> list[float]:
    rng = np.random.default_rng(100 * t + p)
    xy = rng.uniform(0, 60, (K, 2)) + np.array([40 + 6 * t, 200 * p + 30])
    return np.concatenate([xy.round(2), np.full((K, 1), 2.0)], axis=1).reshape(-1).tolist()


def coco_file() -> list[dict[str, Any]]:
    """A small valid COCO keypoint results list."""
    return [
        {"image_id": t + 1, "category_id": 1, "keypoints": _pose(t, p), "score": 0.9}
        for t in range(FRAMES)
        for p in range(PEOPLE)
    ]


def posetrack_file() -> dict[str, Any]:
    """A small valid PoseTrack ground-truth file (head boxes, track ids)."""
    images = [
        {"id": t + 1, "file_name": f"images/v/{t:06d}.jpg", "frame_id": t + 1, "vid_id": "1"}
        for t in range(FRAMES)
    ]
    annotations = [
        {
            "id": len(images) * p + t,
            "image_id": t + 1,
            "track_id": p,
            "keypoints": _pose(t, p),
            "bbox_head": [40.0 + 6 * t, 200.0 * p + 10, 20.0, 20.0],
            "scores": [],
        }
        for t in range(FRAMES)
        for p in range(PEOPLE)
    ]
    return {"images": images, "annotations": annotations, "categories": [{"id": 1, "name": "person"}]}


@st.composite
def mutated_value(draw: st.DrawFn, data: Any) -> Any:
    """``data`` (a JSON value) with one structural or value mutation."""
    data = copy.deepcopy(data)
    lists = []  # (parent list, its name) the mutation may act on

    def walk(value: Any) -> None:
        if isinstance(value, list):
            lists.append(value)
            for v in value:
                walk(v)
        elif isinstance(value, dict):
            for v in value.values():
                walk(v)

    walk(data)
    kind = draw(st.sampled_from(["drop", "repeat", "shuffle", "replace", "replace_field", "delete_field"]))
    target = draw(st.sampled_from(lists))
    if kind == "drop" and target:
        del target[draw(st.integers(0, len(target) - 1))]
    elif kind == "repeat" and target:
        i = draw(st.integers(0, len(target) - 1))
        target.insert(draw(st.integers(0, len(target))), copy.deepcopy(target[i]))
    elif kind == "shuffle":
        order = draw(st.permutations(range(len(target))))
        target[:] = [target[i] for i in order]
    elif kind == "replace" and target:
        target[draw(st.integers(0, len(target) - 1))] = draw(st.sampled_from(ODD_VALUES))
    elif kind in ("replace_field", "delete_field"):
        objects = [v for v in target if isinstance(v, dict) and v]
        if objects:
            obj = draw(st.sampled_from(objects))
            key = draw(st.sampled_from(sorted(obj)))
            if kind == "delete_field":
                del obj[key]
            else:
                obj[key] = draw(st.sampled_from(ODD_VALUES))
    return data


@st.composite
def mutated_bytes(draw: st.DrawFn, data: Any) -> bytes:
    """The JSON text of ``data`` (mutated, or not) as bytes, mutated, or not, at the byte level."""
    data = copy.deepcopy(data)
    if draw(st.booleans()):
        data = draw(mutated_value(data))
    images = data.get("images") if isinstance(data, dict) else None
    if isinstance(images, list) and images and isinstance(images[0], dict) and draw(st.booleans()):
        images[0]["file_name"] = "images/v/é000000.jpg"  # non-ASCII for the encodings
    raw = json.dumps(data).encode()
    kind = draw(st.sampled_from(["none", "cut", "flip", "insert", "utf16", "latin1", "binary", "bom"]))
    if kind == "cut":
        raw = raw[: draw(st.integers(0, len(raw) - 1))]
    elif kind == "flip":
        for _ in range(draw(st.integers(1, 4))):
            i = draw(st.integers(0, len(raw) - 1))
            raw = raw[:i] + bytes([raw[i] ^ draw(st.integers(1, 255))]) + raw[i + 1 :]
    elif kind == "insert":
        i = draw(st.integers(0, len(raw)))
        raw = raw[:i] + draw(st.binary(min_size=1, max_size=8)) + raw[i:]
    elif kind == "utf16":
        raw = raw.decode().encode("utf-16")
    elif kind == "latin1":
        raw = raw.decode().encode("latin-1", errors="replace")
    elif kind == "binary":
        raw = bytes(range(256)) + raw
    elif kind == "bom":
        raw = b"\xef\xbb\xbf" + raw
    return raw


def read_or_named_error(path: Path, **kwargs: Any) -> Any:
    """Read ``path``; a PoseFileError must name the file. Returns the stream or the error."""
    try:
        stream = read_pose_file(path, **kwargs)
    except PoseFileError as exc:
        assert str(path) in str(exc), str(exc)
        assert "\n" not in str(exc)
        return exc
    assert np.all(np.isfinite(stream.keypoints))
    assert np.all(np.abs(stream.keypoints) <= 1e12)
    assert np.all(np.diff(stream.offsets) >= 0) and stream.offsets[-1] == len(stream)
    return stream


FUZZ = settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large]
)
FUZZ_MORE = settings(FUZZ, max_examples=2000)


def _check_readers(raw: bytes) -> None:
    with tempfile.TemporaryDirectory() as root:
        path = Path(root) / "poses.json"
        path.write_bytes(raw)
        read_or_named_error(path)
        read_or_named_error(path, format="coco")
        read_or_named_error(path, format="posetrack", ground_truth=True)
        try:
            image_list(path)
        except PoseFileError as exc:
            assert str(path) in str(exc)


@FUZZ
@given(raw=mutated_bytes(coco_file()))
def test_fuzzed_coco_results_are_read_or_named(raw):
    _check_readers(raw)


@FUZZ
@given(raw=mutated_bytes(posetrack_file()))
def test_fuzzed_posetrack_files_are_read_or_named(raw):
    _check_readers(raw)


@FUZZ
@given(data=mutated_value(posetrack_file()))
def test_posetrack_images_in_any_order_read_as_by_frame_id(data):
    """Shuffled or not, a PoseTrack file that reads gives the frames in frame_id order."""
    with tempfile.TemporaryDirectory() as root:
        path = Path(root) / "gt.json"
        path.write_text(json.dumps(data))
        stream = read_or_named_error(path)
        if isinstance(stream, PoseFileError):
            return
        frame_ids = {im["id"]: im["frame_id"] for im in data["images"]}
        ordered = [frame_ids[i] for i in stream.image_ids.tolist()]
        assert ordered == sorted(ordered)


@pytest.mark.slow
@FUZZ_MORE
@given(raw=st.one_of(mutated_bytes(coco_file()), mutated_bytes(posetrack_file())))
def test_fuzzed_pose_files_more_cases(raw):
    _check_readers(raw)


def _track_run(raw: bytes, gt: bytes | None) -> None:
    """``track run`` on a (mutated) detections file: exit 0 with a whole results file, or exit 2
    with one ``error:`` line and no results file (nor a temporary one) left."""
    with tempfile.TemporaryDirectory() as root:
        det, out = Path(root) / "det.json", Path(root) / "tracks.json"
        det.write_bytes(raw)
        argv = [str(det), "--agent", "pose-baseline", "--out", str(out), "--no-progress"]
        if gt is not None:
            (Path(root) / "gt.json").write_bytes(gt)
            argv += ["--gt", str(Path(root) / "gt.json"), "--metrics"]
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(argv)
        errors = [line for line in err.getvalue().splitlines() if ": error: " in line]
        if code == 0:
            assert not errors
            back = read_pose_file(out)
            assert back.n_frames == read_pose_file(det).n_frames >= 1
        else:
            assert code == 2 and len(errors) == 1, err.getvalue()
            assert not out.exists()
        assert sorted(p.name for p in Path(root).iterdir() if p.name.startswith(".")) == []


@settings(FUZZ, max_examples=60)
@given(raw=mutated_bytes(coco_file()))
def test_track_run_on_fuzzed_detections_exits_cleanly(raw):
    _track_run(raw, None)


@settings(FUZZ, max_examples=40)
@given(gt=mutated_bytes(posetrack_file()))
def test_track_run_against_fuzzed_ground_truth_exits_cleanly(gt):
    _track_run(json.dumps(coco_file()).encode(), gt)


def test_odd_values_cover_the_issue_cases():
    """The cases the fuzz draws from include those a user met (strings, non-finite, 1e300)."""
    assert "12.5" in ODD_VALUES and 1e300 in ODD_VALUES
    assert any(isinstance(v, float) and math.isnan(v) for v in ODD_VALUES)


@settings(FUZZ, max_examples=30)
@given(raw=mutated_bytes(posetrack_file()))
def test_track_run_on_fuzzed_posetrack_detections_exits_cleanly(raw):
    _track_run(raw, None)


@pytest.mark.slow
@settings(FUZZ, max_examples=400)
@given(raw=mutated_bytes(coco_file()), gt=st.one_of(st.none(), mutated_bytes(posetrack_file())))
def test_track_run_on_fuzzed_files_more_cases(raw, gt):
    _track_run(raw, gt)
