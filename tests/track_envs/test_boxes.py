"""Boxes carried: MOT boxes read, kept by Detections and Tracks, carried by run_agent, written,
read back, and scored by IoU (BoxClearMot) with py-motmetrics parity."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from agents.files.points import run_agent
from track_envs.io.detections import (
    CONSIDERED,
    DetectionFileError,
    read_mot_detections,
    read_mot_rows,
    write_mot_detections,
)
from track_envs.io.tracks import read_tracks, write_tracks
from track_envs.metrics import BoxClearMot, box_iou, iou_distances
from track_envs.metrics.track_scoring import match_kind, score_tracks
from track_envs.values.detections import Detections, detection_sensor_spec
from track_envs.values.tracks import Tracks, carried_boxes

BOXES = "1,-1,10,20,4,6,0.9\n1,-1,0,0,2,2,-1\n2,-1,11,21,4,6,0.3\n"


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


# ------------------------------------------------------------------------------------ reading


def test_mot_boxes_are_kept_and_their_centres_are_the_points(tmp_path: Path) -> None:
    d = read_mot_detections(write(tmp_path / "det.txt", BOXES))
    assert d.boxes is not None
    np.testing.assert_array_equal(d.boxes, [[10, 20, 4, 6], [0, 0, 2, 2], [11, 21, 4, 6]])
    np.testing.assert_array_equal(d.points, [[12, 23], [1, 1], [13, 24]])
    np.testing.assert_array_equal(d.frame_boxes(1), [[11, 21, 4, 6]])


def test_swap_xy_and_scale_apply_to_the_boxes_as_to_the_points(tmp_path: Path) -> None:
    d = read_mot_detections(write(tmp_path / "det.txt", BOXES), swap_xy=True, scale=0.5)
    assert d.boxes is not None
    np.testing.assert_array_equal(d.boxes[0], [10.0, 5.0, 3.0, 2.0])  # (top, left, h, w) * 0.5
    np.testing.assert_array_equal(d.points, d.boxes[:, :2] + d.boxes[:, 2:] / 2)  # centre = point


def test_a_file_of_points_has_no_boxes(tmp_path: Path) -> None:
    d = read_mot_detections(write(tmp_path / "det.txt", "1,-1,0.5,0.25,0,0,1\n2,-1,0.5,0.3,0,0,1\n"))
    assert d.boxes is None and d.points.tolist() == [[0.5, 0.25], [0.5, 0.3]]


def test_boxes_round_trip_bit_for_bit(tmp_path: Path) -> None:
    d = read_mot_detections(write(tmp_path / "det.txt", "1,-1,0.1,0.7,3.3,1.9,1\n3,4,2.2,0.3,1.1,0.4,1\n"))
    write_mot_detections(tmp_path / "back.txt", d)
    back = read_mot_detections(tmp_path / "back.txt")
    assert back.equals(d) and back.boxes is not None


def test_detections_validate_and_compare_their_boxes() -> None:
    points, offsets = np.zeros((2, 2)), np.array([0, 2])
    with pytest.raises(ValueError, match=r"Detections.boxes must have shape \(2, 4\)"):
        Detections(points, offsets, boxes=np.zeros((2, 3)))
    with pytest.raises(ValueError, match="width and height >= 0"):
        Detections(points, offsets, boxes=[[0, 0, -1, 1], [0, 0, 1, 1]])
    a = Detections(points, offsets, boxes=np.ones((2, 4)))
    assert a.equals(Detections(points, offsets, boxes=np.ones((2, 4))))
    assert not a.equals(Detections(points, offsets)) and not a.equals(
        Detections(points, offsets, boxes=np.zeros((2, 4)))
    )


def test_a_negative_box_size_is_named(tmp_path: Path) -> None:
    with pytest.raises(
        DetectionFileError, match=r"row 1, column index 5 \(bb_height\) holds -2.0; a box's size"
    ):
        read_mot_rows(write(tmp_path / "det.txt", "1,-1,0,0,1,-2,1\n"))


# --------------------------------------------------------------------------------- confidence


def test_a_confidence_of_minus_one_is_not_given_and_survives_the_filter(tmp_path: Path) -> None:
    d = read_mot_detections(write(tmp_path / "det.txt", BOXES), min_confidence=0.5)
    np.testing.assert_array_equal(d.points, [[12, 23], [1, 1]])  # 0.9 and -1 kept, 0.3 dropped
    assert d.counts.tolist() == [2, 0]


def test_a_filter_that_drops_every_detection_is_an_error(tmp_path: Path) -> None:
    path = write(tmp_path / "det.txt", "1,-1,0,0,1,1,0.2\n2,-1,0,0,1,1,0.4\n")
    with pytest.raises(
        DetectionFileError,
        match=r"min_confidence=0.5 \(track run: --min-confidence\) drops "
        r"every one of the 2 rows; their confidences \(column index 6\) range from 0.2 to 0.4",
    ):
        read_mot_detections(path, min_confidence=0.5)


def test_ground_truth_keeps_the_considered_rows(tmp_path: Path) -> None:
    # MOT16+ gt: column index 6 is 1 (considered) or 0 (ignored); MOT15 writes 1; -1: not given
    gt = write(tmp_path / "gt.txt", "1,1,0,0,2,2,1,1,1\n1,2,5,5,2,2,0,1,1\n1,3,9,9,2,2,-1,1,1\n")
    truth = read_tracks(gt, min_confidence=CONSIDERED)
    assert truth.ids.tolist() == [1, 3]
    assert truth.boxes is not None and truth.boxes[1].tolist() == [9, 9, 2, 2]


# ------------------------------------------------------------------------------ tracks' boxes


def test_carried_boxes_take_the_update_and_keep_the_last_while_coasting() -> None:
    boxes = np.arange(4 * 4, dtype=float).reshape(4, 4)  # frame 0: rows 0, 1; frame 1: row 2; frame 2: row 3
    offsets = np.array([0, 2, 3, 4, 4])
    #               frame  id  detection
    rows = np.array(
        [[0, 7, 1], [0, 8, -1], [1, 7, -1], [1, 8, 0], [2, 7, 0], [2, 8, -1], [3, 7, -1], [3, 8, -1]]
    )
    tracks = Tracks(rows[:, 0], rows[:, 1], np.zeros((8, 2)), 4, detection=rows[:, 2])
    got = carried_boxes(tracks, boxes, offsets)
    expected = [boxes[1], [np.nan] * 4, boxes[1], boxes[2], boxes[3], boxes[2], boxes[3], boxes[2]]
    np.testing.assert_array_equal(got, expected)


def test_carried_boxes_equal_a_loop_over_rows() -> None:
    rng = np.random.default_rng(3)
    n_frames, per = 40, rng.integers(0, 5, 40)
    offsets = np.concatenate([[0], np.cumsum(per)])
    boxes = rng.random((offsets[-1], 4))
    frame, ids, det = [], [], []
    for t in range(n_frames):
        live = rng.choice(6, rng.integers(0, 6), replace=False)
        for i in sorted(live):
            frame.append(t), ids.append(i), det.append(rng.integers(-1, per[t]) if per[t] else -1)
    tracks = Tracks(frame, ids, np.zeros((len(frame), 2)), n_frames, detection=det)
    last: dict[int, np.ndarray] = {}
    expected = np.full((len(frame), 4), np.nan)
    for k, (t, i, j) in enumerate(zip(frame, ids, det, strict=True)):
        if j >= 0:
            last[i] = boxes[offsets[t] + j]
        expected[k] = last.get(i, np.nan)
    np.testing.assert_array_equal(carried_boxes(tracks, boxes, offsets), expected)


def test_run_agent_writes_each_rows_detection_box(tmp_path: Path) -> None:
    # two boxes drifting slowly; the second is missed in frame 3
    lines = []
    for t in range(1, 7):
        lines.append(f"{t},-1,{10.0 + 0.1 * t},0,8,16,1")
        if t != 3:
            lines.append(f"{t},-1,{10.0 + 0.1 * t},100,6,12,1")
    d = read_mot_detections(write(tmp_path / "det.txt", "\n".join(lines) + "\n"))
    assert d.boxes is not None
    spec = detection_sensor_spec(d, dt=0.04, measurement_noise_std=1.0)
    tracks = run_agent("gnn", d, spec)
    assert tracks.boxes is not None and tracks.detection is not None
    assert len(set(tracks.ids.tolist())) == 2
    updated = tracks.detection >= 0
    expected = d.boxes[d.offsets[tracks.frame[updated]] + tracks.detection[updated]]
    np.testing.assert_array_equal(tracks.boxes[updated], expected)
    coasting = np.flatnonzero(~updated)
    assert tracks.frame[coasting].tolist() == [2]  # the missed frame (from 0)
    np.testing.assert_array_equal(tracks.boxes[coasting], [[10.2, 100.0, 6.0, 12.0]])  # frame 1's box

    for fmt, name in (("mot", "t.txt"), ("long", "t.csv")):
        write_tracks(tmp_path / name, tracks, fmt)
        back = read_tracks(tmp_path / name)
        assert back.boxes is not None
        np.testing.assert_array_equal(back.boxes, tracks.boxes)
    assert "bb_left,bb_top,bb_width,bb_height" in (tmp_path / "t.csv").read_text().splitlines()[0]


def test_tracks_of_points_still_write_a_box_size_box(tmp_path: Path) -> None:
    tracks = Tracks([0], [1], [[5.0, 7.0]], 1)
    write_tracks(tmp_path / "t.txt", tracks, "mot", box_size=2.0)
    assert (tmp_path / "t.txt").read_text().startswith("1,1,4.0,6.0,2.0,2.0,")
    assert read_tracks(tmp_path / "t.txt").boxes is not None
    write_tracks(tmp_path / "p.txt", tracks, "mot")
    assert read_tracks(tmp_path / "p.txt").boxes is None  # 0 x 0 boxes: points


# -------------------------------------------------------------------------------------- scoring


def test_box_iou_by_hand() -> None:
    a = [[0, 0, 2, 2]]
    b = [[1, 1, 2, 2], [0, 0, 2, 2], [5, 5, 1, 1], [0, 0, 0, 0]]
    np.testing.assert_allclose(box_iou(a, b), [[1 / 7, 1.0, 0.0, 0.0]])
    assert np.isnan(iou_distances(a, b)).tolist() == [[True, False, True, True]]
    assert iou_distances([[0, 0, 2, 1]], [[0, 0, 1, 1]])[0, 0] == 0.5  # IoU exactly 0.5 matches


def test_match_kind_defaults_to_iou_where_both_have_boxes() -> None:
    assert match_kind(True, True) == "iou" and match_kind(True, False) == "distance"
    assert match_kind(True, True, "distance") == "distance"
    with pytest.raises(ValueError, match=r"--match iou\) needs boxes, and the ground truth have none"):
        match_kind(True, False, "iou")
    with pytest.raises(ValueError, match=r"the tracks and ground truth have none"):
        match_kind(False, False, "iou")
    with pytest.raises(ValueError, match=r"match must be one of \['auto', 'iou', 'distance'\]"):
        match_kind(True, True, "IoU")


def test_iou_and_distance_matching_differ_as_they_should() -> None:
    truth = Tracks([0, 1], [1, 1], [[1.0, 1.0], [1.0, 1.0]], 2, boxes=[[0, 0, 2, 2], [0, 0, 2, 2]])
    # same centre both frames; frame 1's box is 4x the area: IoU 0.25
    tracks = Tracks([0, 1], [5, 5], [[1.0, 1.0], [1.0, 1.0]], 2, boxes=[[0, 0, 2, 2], [-1, -1, 4, 4]])
    by_iou, _ = score_tracks(tracks, truth, threshold=0.1)
    by_distance, _ = score_tracks(tracks, truth, threshold=0.1, match="distance")
    assert by_iou["num_matches"] == 1 and by_iou["num_misses"] == 1 and by_iou["mota"] == 0.0
    assert by_distance["num_matches"] == 2 and by_distance["mota"] == 1.0


mm = pytest.importorskip("motmetrics")


def motmetrics_frames(gt: Path, hyp: Path):
    """(gt ids, hyp ids, 1 − IoU with NaN below 0.5) per frame, read and computed with motmetrics'
    own loader and ``boxiou`` (``iou_matrix`` calls np.asfarray, gone in numpy 2)."""
    g = mm.io.loadtxt(str(gt), fmt="mot15-2D", min_confidence=1)
    h = mm.io.loadtxt(str(hyp), fmt="mot15-2D")
    frames = sorted(set(g.index.get_level_values(0)) | set(h.index.get_level_values(0)))
    for f in frames:
        a = g.loc[f] if f in g.index.get_level_values(0) else g.iloc[:0]
        b = h.loc[f] if f in h.index.get_level_values(0) else h.iloc[:0]
        boxes_a = a[["X", "Y", "Width", "Height"]].to_numpy(float)
        boxes_b = b[["X", "Y", "Width", "Height"]].to_numpy(float)
        dist = 1 - mm.distances.boxiou(boxes_a[:, None], boxes_b[None, :])
        yield a.index.to_numpy(), b.index.to_numpy(), np.where(dist > 0.5, np.nan, dist)


@pytest.mark.filterwarnings("ignore:Operation with tuple is deprecated")  # motmetrics io.py on pandas 3
@pytest.mark.parametrize("name", ["TUD-Campus", "TUD-Stadtmitte"])
def test_our_iou_scores_of_our_tracks_equal_motmetrics(name: str, tmp_path: Path) -> None:
    data = Path(mm.__file__).parent / "data" / name
    d = read_mot_detections(data / "test.txt")
    spec = detection_sensor_spec(d, dt=0.04, measurement_noise_std=5.0, max_tracks=64)
    tracks = run_agent("gnn", d, spec)
    write_tracks(tmp_path / "tracks.txt", tracks, "mot")
    truth = read_tracks(data / "gt.txt", min_confidence=CONSIDERED)
    ours, _ = score_tracks(tracks, truth, threshold=50.0)
    acc = mm.MOTAccumulator(auto_id=True)
    for oids, hids, dists in motmetrics_frames(data / "gt.txt", tmp_path / "tracks.txt"):
        acc.update(oids, hids, dists)
    names = ["mota", "motp", "idf1", "num_switches", "num_misses", "num_false_positives", "num_objects"]
    theirs = mm.metrics.create().compute(acc, metrics=names, return_dataframe=False)
    for key, their in zip(
        names,
        ["mota", "motp", "idf1", "id_switches", "num_misses", "num_false_positives", "num_objects"],
        strict=True,
    ):
        assert ours[their] == pytest.approx(float(theirs[key]), rel=1e-12, abs=1e-12), key
    assert ours["mota"] > 0.4


def test_box_clear_mot_takes_padded_frames() -> None:
    metric = BoxClearMot()
    truth = {
        "ids": np.array([1, -1]),
        "visible": np.array([True, False]),
        "boxes": np.array([[0, 0, 2, 2], [np.nan] * 4]),
    }
    report = {
        "ids": np.array([3, 0]),
        "mask": np.array([1, 0], np.int8),
        "boxes": np.array([[0, 0, 2, 2], [0] * 4]),
    }
    metric.update(truth, np.full(2, -1), report)
    out = metric.compute()
    assert out["num_matches"] == 1 and out["mota"] == 1.0 and out["motp"] == 0.0
    with pytest.raises(ValueError, match=r"need 'boxes'"):
        metric.update({k: v for k, v in truth.items() if k != "boxes"}, np.full(2, -1), report)


def test_tracks_validate_keep_and_compare_their_boxes() -> None:
    with pytest.raises(ValueError, match=r"Tracks.boxes must have shape \(1, 4\)"):
        Tracks([0], [1], [[0.0, 0.0]], 1, boxes=np.zeros((1, 2)))
    a = Tracks([0], [1], [[0.0, 0.0]], 1, boxes=[[0, 0, 1, 1]])
    b = Tracks([0], [2], [[0.0, 0.0]], 1, boxes=[[np.nan] * 4])
    joined = Tracks.concatenate([a, b.with_frames(1)])
    assert joined.boxes is not None and joined.boxes.shape == (2, 4)
    assert Tracks.concatenate([a, Tracks([0], [2], [[0.0, 0.0]], 1)]).boxes is None  # not every part
    assert a.with_frames(5).boxes is not None and b.equals(b.with_boxes(np.full((1, 4), np.nan)))
    assert not a.equals(a.with_boxes(np.array([[0.0, 0.0, 2.0, 1.0]])))
    frame = a.padded_frame(0, 1, 3)
    np.testing.assert_array_equal(frame["boxes"], [[0, 0, 1, 1], [np.nan] * 4, [np.nan] * 4])
