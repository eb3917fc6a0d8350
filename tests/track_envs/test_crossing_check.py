"""Predicted-crossing files and the truth-free crossing score, against hand calculations."""

from __future__ import annotations

import numpy as np
import pytest

from track_envs.io.crossings import PredictedCrossings, read_crossings, write_crossings
from track_envs.io.csv_parser import DetectionFileError
from track_envs.metrics.crossing_check import (
    check_tolerances,
    observed_crossings,
    score_crossings,
    seen_upstream,
)
from track_envs.values.detections import Detections
from track_envs.values.tracks import Tracks

DT = 0.01


def crossings(ids, frame, mean, cov=None, **extra) -> PredictedCrossings:
    k = len(ids)
    cov = np.tile(np.diag([1e-6, 1e-6]), (k, 1, 1)) if cov is None else cov
    return PredictedCrossings(np.asarray(ids), np.asarray(frame), np.asarray(mean, float), cov, 0.3, extra)


# ----------------------------------------------------------------------------------- the file


def test_crossings_round_trip_exactly(tmp_path):
    rng = np.random.default_rng(0)
    a = rng.normal(size=(5, 2, 2))
    cov = a @ np.swapaxes(a, 1, 2)
    made = crossings(
        [3, 7, 2**40, 3, 9],
        [1, 1, 4, 6, 6],
        rng.normal(size=(5, 2)),
        cov,
        track=np.array([1.0, 2.0, 3.0, 1.0, -1.0]),
        t_true=np.array([0.1, np.nan, 0.3, 0.4, 0.5]),
    )
    path = tmp_path / "c.csv"
    write_crossings(path, made)
    assert path.read_text().splitlines()[0] == "id,frame,t_cross,y_cross,var_t,cov_ty,var_y,track,t_true"
    assert path.read_text().splitlines()[2].split(",")[7] == "2"  # track ids written as integers
    back = read_crossings(path)
    assert back.equals(made)
    assert back.ids[2] == 2**40


def test_empty_crossings_round_trip(tmp_path):
    path = tmp_path / "c.csv"
    write_crossings(path, PredictedCrossings.empty(0.3))
    assert read_crossings(path).equals(PredictedCrossings.empty())


def test_last_keeps_each_tracks_last_prediction_in_order():
    c = crossings([5, 2, 5, 9], [1, 2, 3, 3], [[0.1, 1], [0.2, 2], [0.3, 3], [0.4, 4]])
    last = c.last()
    assert last.ids.tolist() == [2, 5, 9]
    assert last.t.tolist() == [0.2, 0.3, 0.4]


def test_crossing_file_errors_name_the_column(tmp_path):
    path = tmp_path / "c.csv"
    path.write_text("id,frame,t_cross,y_cross,var_t\n1,2,0.1,0.2,0.3\n")
    with pytest.raises(DetectionFileError, match=r"lacks \['cov_ty', 'var_y'\]"):
        read_crossings(path)
    path.write_text("id,frame,t_cross,y_cross,var_t,cov_ty,var_y\n1.5,2,0.1,0.2,0.3,0,1\n")
    with pytest.raises(
        DetectionFileError, match=r"row 2, column index 0 \('id'\) holds 1.5; expected an integer"
    ):
        read_crossings(path)


def test_predicted_crossings_shapes_are_checked():
    with pytest.raises(ValueError, match=r"mean \(k, 2\)"):
        PredictedCrossings(np.array([1]), np.array([0]), np.zeros((2, 2)), np.zeros((1, 2, 2)))


# ----------------------------------------------------------------------- observed crossings


def tiny_stream() -> tuple[Tracks, Detections]:
    """Track 4: detections at frames 0, 1, 3 (coasting at 2), x 0.1, 0.2, 0.5; track 8: frames 1, 2
    at x 0.25, 0.35 and one more row at frame 3 that coasted; detections listed out of track order."""
    frames = [
        np.array([[0.1, 0.05]]),
        np.array([[0.25, 0.10], [0.2, 0.06]]),
        np.array([[0.35, 0.12]]),
        np.array([[0.5, 0.09]]),
    ]
    detections = Detections.from_frames(frames)
    tracks = Tracks(
        frame=np.array([0, 1, 1, 2, 2, 3, 3]),
        ids=np.array([4, 8, 4, 4, 8, 4, 8]),
        positions=np.zeros((7, 2)),
        n_frames=4,
        detection=np.array([0, 0, 1, -1, 0, 0, -1]),
    )
    return tracks, detections


def test_observed_crossings_by_hand():
    tracks, detections = tiny_stream()
    seen = observed_crossings(tracks, detections, 0.3, DT)
    assert seen.ids.tolist() == [4, 8]
    # track 4: between frame 1 (0.2, 0.06) and frame 3 (0.5, 0.09): φ = 1/3
    # track 8: between frame 1 (0.25, 0.10) and frame 2 (0.35, 0.12): φ = 1/2
    np.testing.assert_allclose(seen.t, [(1 + 2 / 3) * DT, 1.5 * DT], rtol=1e-12)
    np.testing.assert_allclose(seen.y, [0.07, 0.11], rtol=1e-12)
    ids, counts = seen_upstream(tracks, detections, 0.22)
    assert ids.tolist() == [4] and counts.tolist() == [2]


def test_observed_crossings_need_the_detection_rows():
    tracks, detections = tiny_stream()
    bare = Tracks(tracks.frame, tracks.ids, tracks.positions, tracks.n_frames)
    with pytest.raises(ValueError, match="detection rows"):
        observed_crossings(bare, detections, 0.3, DT)


# ----------------------------------------------------------------------------------- score


def test_score_by_hand():
    tracks, detections = tiny_stream()
    seen = observed_crossings(tracks, detections, 0.3, DT)  # 4: (0.016667, 0.07); 8: (0.015, 0.11)
    made = crossings(
        [4, 8, 8, 30, 31],
        [1, 1, 2, 2, 3],
        [
            [seen.t[0] + 0.001, 0.07 - 0.0005],  # 4: a hit (1 ms, 0.5 mm)
            [0.5, 0.5],  # 8's first prediction: replaced by its last
            [seen.t[1] - 0.003, 0.11 + 0.001],  # 8: 3 ms early: a miss; reported at 0.02 > t_c: late
            [0.02, 0.1],  # 30 never crossed
            [0.05, 0.1],  # 31 never crossed, predicted after the end (0.03)
        ],
    )
    score = score_crossings(made, seen, np.array([4, 8]), DT, end_time=3 * DT)
    assert (score.crossings, score.predicted, score.hits, score.predictions) == (2, 2, 1, 4)
    assert (score.never_crossed, score.beyond_end, score.late) == (2, 1, 1)
    assert score.hit_rate == 0.5
    np.testing.assert_allclose(score.time_error, [0.001, -0.003], atol=1e-15)
    np.testing.assert_allclose(score.lateral_error, [-0.0005, 0.001], atol=1e-15)
    np.testing.assert_allclose(score.nees, [(1e-6 + 0.25e-6) / 1e-6, (9e-6 + 1e-6) / 1e-6])
    summary = score.summary("m")
    assert summary["time_p50_ms"] == pytest.approx(2.0)  # |Δt| 1 and 3 ms
    assert summary["time_p90_ms"] == pytest.approx(1 + 0.9 * 2)
    assert summary["time_bias_ms"] == pytest.approx(-1.0)
    assert summary["lateral_p99_m"] == pytest.approx(0.0005 + 0.99 * 0.0005)
    assert summary["nees"] == pytest.approx((1.25 + 10) / 2)
    # only track 4 scored: 8 is not among the tracks seen before the cut-off
    only4 = score_crossings(made, seen, np.array([4]), DT)
    assert (only4.crossings, only4.hits, only4.hit_rate, only4.beyond_end) == (1, 1, 1.0, 0)


def test_score_in_other_units_is_the_same():
    """Positions, line and lateral tolerance in mm instead of m: the same hits, errors × 1000."""
    tracks, detections = tiny_stream()
    mm = Detections(detections.points * 1000.0, detections.offsets)
    made = crossings([4, 8], [1, 2], [[0.017, 0.0702], [0.014, 0.1118]])
    made_mm = crossings([4, 8], [1, 2], made.mean * [1.0, 1000.0])
    seen = observed_crossings(tracks, detections, 0.3, DT)
    seen_mm = observed_crossings(tracks, mm, 300.0, DT)
    np.testing.assert_allclose(seen_mm.t, seen.t, rtol=1e-12)
    np.testing.assert_allclose(seen_mm.y, 1000.0 * seen.y, rtol=1e-12)
    m = score_crossings(made, seen, seen.ids, DT, lateral_tolerance=1e-3)
    k = score_crossings(made_mm, seen_mm, seen.ids, DT, lateral_tolerance=1.0)
    assert m.hit.tolist() == k.hit.tolist() == [True, False]
    np.testing.assert_allclose(k.lateral_error, 1000.0 * m.lateral_error, rtol=1e-9)
    np.testing.assert_allclose(k.time_error, m.time_error, rtol=1e-12)


def test_a_crossing_without_prediction_is_a_miss():
    tracks, detections = tiny_stream()
    seen = observed_crossings(tracks, detections, 0.3, DT)
    score = score_crossings(crossings([4], [1], [[seen.t[0], seen.y[0]]]), seen, seen.ids, DT)
    assert (score.crossings, score.predicted, score.hits, score.hit_rate) == (2, 1, 1, 0.5)
    empty = score_crossings(PredictedCrossings.empty(), seen, seen.ids, DT)
    assert empty.hit_rate == 0.0 and np.isnan(empty.summary()["time_p50_ms"])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"lateral_tolerance": 0.0}, "lateral_tolerance must be a finite number > 0, got 0.0"),
        ({"time_tolerance": float("nan")}, "time_tolerance must be a finite number > 0, got nan"),
        ({"min_seen": 0}, "min_seen must be an integer >= 1, got 0"),
    ],
)
def test_bad_tolerances_are_named(kwargs, message):
    args = {"lateral_tolerance": 1e-3, "time_tolerance": 1e-3, "min_seen": 1} | kwargs
    with pytest.raises(ValueError, match=message):
        check_tolerances(**args)


def test_files_without_the_required_columns_are_named(tmp_path):
    from track_envs.io.crossings import read_crossings
    from track_envs.io.csv_parser import DetectionFileError
    from track_envs.io.tracks import read_tracks

    path = tmp_path / "c.csv"
    path.write_text("id,frame,t_cross\n1,2,0.5\n")
    with pytest.raises(
        DetectionFileError, match=r"the header lacks \['y_cross', 'var_t'.*a crossing file starts"
    ):
        read_crossings(path)
    path.write_text("frame,id,x\n0,1,0.5\n")
    with pytest.raises(DetectionFileError, match=r"the header lacks \['y'.*a long track file starts"):
        read_tracks(path, "long")
