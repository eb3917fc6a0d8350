"""CLEAR MOT / IDF1 parity with py-motmetrics: random distance matrices and the TUD sequences.

motmetrics 1.4 on numpy 2: ``motmetrics.distances.iou_matrix`` calls ``np.asfarray`` (removed in
numpy 2.0), so ``compare_to_groundtruth(..., 'iou')`` fails; the TUD test swaps in an IoU distance
computed here exactly as motmetrics' ``boxiou`` does. Its accumulator and metrics run unchanged.
motmetrics also raises ``KeyError`` when a *new* truth id appears twice in one frame, so the
random sequences repeat track ids only (truth ids are unique per frame in every environment).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linear_sum_assignment

from track_envs.metrics import ClearMot, Metric
from track_envs.metrics.clear_mot import max_weight_matching

mm = pytest.importorskip("motmetrics")

MM_NAMES = {  # ours -> motmetrics
    "mota": "mota",
    "motp": "motp",
    "id_switches": "num_switches",
    "idf1": "idf1",
    "num_misses": "num_misses",
    "num_false_positives": "num_false_positives",
    "num_matches": "num_matches",
    "num_objects": "num_objects",
    "num_predictions": "num_predictions",
    "num_fragmentations": "num_fragmentations",
    "idtp": "idtp",
    "idfp": "idfp",
    "idfn": "idfn",
    "idp": "idp",
    "idr": "idr",
}


def motmetrics_summary(acc) -> dict[str, float]:
    out = mm.metrics.create().compute(acc, metrics=list(MM_NAMES.values()), return_dataframe=False)
    return {ours: float(out[theirs]) for ours, theirs in MM_NAMES.items()}


def assert_same(ours: dict[str, float], theirs: dict[str, float]) -> None:
    for key, value in theirs.items():
        assert ours[key] == pytest.approx(value, rel=1e-12, abs=1e-12, nan_ok=True), key


def random_sequence(rng: np.random.Generator, repeat_track_ids: bool):
    frames = []
    for _ in range(rng.integers(1, 20)):
        no, nh = rng.integers(0, 6, size=2)
        oids = rng.choice(8, no, replace=False)  # ids drawn from a small pool: reuse across frames
        hids = rng.integers(0, 8, nh) if repeat_track_ids else rng.choice(8, nh, replace=False)
        if rng.random() < 0.3:  # ties
            dists = rng.choice([0.0, 0.25, 0.5, 1.0], size=(no, nh))
        else:
            dists = rng.random((no, nh))
        dists[rng.random((no, nh)) < 0.4] = np.nan
        frames.append((oids, hids, dists))
    return frames


@pytest.mark.parametrize("repeat_track_ids", [False, True])
@pytest.mark.parametrize("seed", range(12))
def test_random_sequences_match_motmetrics(seed, repeat_track_ids):
    rng = np.random.default_rng([seed, repeat_track_ids])
    acc, ours = mm.MOTAccumulator(auto_id=True), ClearMot(threshold=1.0)
    for oids, hids, dists in random_sequence(rng, repeat_track_ids):
        acc.update(oids, hids, dists)
        ours.update_distances(oids, hids, dists)
    assert_same(ours.compute(), motmetrics_summary(acc))


def test_empty_frames_and_nothing_at_all():
    acc, ours = mm.MOTAccumulator(auto_id=True), ClearMot(threshold=1.0)
    for oids, hids in [([], []), ([1, 2], []), ([], [5]), ([1], [5])]:
        dists = np.full((len(oids), len(hids)), 0.5)
        acc.update(oids, hids, dists)
        ours.update_distances(np.asarray(oids, np.int64), np.asarray(hids, np.int64), dists)
    assert_same(ours.compute(), motmetrics_summary(acc))
    empty = ClearMot(threshold=1.0).compute()
    assert np.isnan(empty["mota"]) and np.isnan(empty["idf1"]) and empty["num_objects"] == 0


def tie_heavy_sequence(rng: np.random.Generator, repeat_track_ids: bool):
    """Frames that exercise every branch: empty and all-impossible frames, exact ties (equal
    distances, so several assignments are optimal and motmetrics' tie-breaking shows), continuous
    distances, crowded frames (several candidates per truth), id switches and reused ids (small
    id pools) and, optionally, duplicate track ids within a frame."""
    frames = []
    for _ in range(rng.integers(1, 25)):
        no, nh = rng.integers(0, 9, size=2)
        oids = rng.choice(12, no, replace=False)
        hids = rng.integers(0, 12, nh) if repeat_track_ids else rng.choice(12, nh, replace=False)
        kind = rng.integers(0, 5)
        if kind == 0:
            dists = rng.choice([0.0, 0.25, 0.5, 1.0], size=(no, nh))
        elif kind == 1:
            dists = np.full((no, nh), 0.5)
        elif kind == 2:
            dists = rng.integers(0, 3, size=(no, nh)) / 2.0
        else:
            dists = rng.random((no, nh))
        dists[rng.random((no, nh)) < rng.uniform(0.0, 1.0)] = np.nan  # includes all-impossible frames
        frames.append((oids, hids, dists))
    return frames


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.booleans())
def test_tie_heavy_streams_match_motmetrics_exactly(seed, repeat_track_ids):
    """Lone pairs taken directly and the rest solved as motmetrics solves it: the same events as
    motmetrics also where several assignments are optimal."""
    rng = np.random.default_rng(seed)
    acc, ours = mm.MOTAccumulator(auto_id=True), ClearMot(threshold=1.0)
    for oids, hids, dists in tie_heavy_sequence(rng, repeat_track_ids):
        acc.update(oids, hids, dists)
        ours.update_distances(oids, hids, dists)
    assert_same(ours.compute(), motmetrics_summary(acc))


def padded_point_frame(rng: np.random.Generator, ids_pool: int, grid: bool):
    """One padded env frame (truth, report) of 2-D points; on a 0.5 grid, distances tie and pairs
    sit exactly at the threshold 1."""
    max_targets, max_tracks = 12, 10
    m, n = rng.integers(0, max_targets + 1), rng.integers(0, max_tracks + 1)
    if grid:
        truth_pos = rng.integers(0, 6, size=(max_targets, 2)) * 0.5
        report_pos = rng.integers(0, 6, size=(max_tracks, 2)) * 0.5
    else:
        truth_pos = rng.uniform(0, 4, size=(max_targets, 2))
        report_pos = truth_pos[rng.integers(0, max_targets, max_tracks)] + rng.normal(0, 0.6, (max_tracks, 2))
    ids = np.full(max_targets, -1, np.int64)
    ids[:m] = rng.choice(ids_pool, m, replace=False)
    truth = {"ids": ids, "positions": truth_pos, "visible": rng.random(max_targets) < 0.85}
    mask = np.zeros(max_tracks, np.int8)
    mask[rng.permutation(max_tracks)[:n]] = 1
    report = {
        "ids": rng.integers(0, ids_pool, max_tracks).astype(np.int64),
        "positions": report_pos.astype(np.float32),
        "detection": np.full(max_tracks, -1, np.int64),
        "mask": mask,
    }
    return truth, report


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.booleans())
def test_point_frames_match_motmetrics_on_the_dense_distance_matrix(seed, grid):
    """``update`` (sparse close pairs) = motmetrics fed scipy's full cdist matrix, NaN above 1."""
    from scipy.spatial.distance import cdist

    rng = np.random.default_rng(seed)
    acc, ours = mm.MOTAccumulator(auto_id=True), ClearMot(threshold=1.0)
    for _ in range(rng.integers(1, 20)):
        truth, report = padded_point_frame(rng, ids_pool=15, grid=grid)
        ours.update(truth, np.full(4, -1), report)
        live = (truth["ids"] >= 0) & truth["visible"]
        rows = report["mask"] == 1
        oids, hids = truth["ids"][live], report["ids"][rows]
        x, y = truth["positions"][live], report["positions"][rows].astype(np.float64)
        d = cdist(x, y) if len(x) and len(y) else np.zeros((len(x), len(y)))
        d[d > 1.0] = np.nan
        acc.update(oids, hids, d)  # report ids may repeat within a frame; truth ids never do
    assert_same(ours.compute(), motmetrics_summary(acc))


def test_a_long_stream_grows_the_state_tables():
    """Thousands of distinct ids (the tables double several times) give motmetrics' figures."""
    rng = np.random.default_rng(7)
    acc, ours = mm.MOTAccumulator(auto_id=True), ClearMot(threshold=1.0)
    for frame in range(40):
        oids = np.arange(frame * 20, frame * 20 + 40)  # each id lives two frames
        hids = oids + 1_000_000 * (rng.random(40) < 0.1)  # a few tracks change id
        dists = np.where(rng.random((40, 40)) < 0.05, rng.random((40, 40)), np.nan)
        np.fill_diagonal(dists, rng.random(40) * 0.5)
        acc.update(oids, hids, dists)
        ours.update_distances(oids, hids, dists)
    assert_same(ours.compute(), motmetrics_summary(acc))


def test_motp_of_a_long_stream_of_equal_distances_does_not_drift():
    """10⁵ matches at distance 0.1 (quantised positions repeat distances): a plain running sum
    is off by 2e-12 relative, beyond the 1e-12 of motmetrics parity; the compensated sum is not."""
    ours = ClearMot(threshold=1.0)
    ids = np.arange(500)
    dists = np.full((500, 500), np.nan)
    np.fill_diagonal(dists, 0.1)
    for _ in range(200):
        ours.update_distances(ids, ids, dists)
    out = ours.compute()
    assert out["num_detections"] == 100_000
    assert abs(out["motp"] - 0.1) <= np.spacing(0.1)


def test_update_builds_the_thresholded_point_distance_matrix():
    truth = {
        "ids": np.array([7, 8, 9, -1]),
        "positions": np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0], [0.0, 0.0]]),
        "visible": np.array([True, True, False, False]),  # truth 9 is out of view, row 3 padding
    }
    report: dict[str, np.ndarray] = {
        "ids": np.array([1, 2, 3, 4], np.int64),
        "positions": np.array([[0.0, 1.0], [13.0, 4.0], [20.0, 0.0], [50.0, 0.0]], np.float32),
        "detection": np.full(4, -1, np.int64),
        "mask": np.array([1, 1, 1, 0], np.int8),
    }
    ours = ClearMot(threshold=5.0)
    assert isinstance(ours, Metric)
    ours.update(truth, np.full(3, -1), report)
    ref = ClearMot(threshold=5.0)
    # (10,0)-(13,4) is exactly at the threshold 5: still possible, as in motmetrics
    ref.update_distances(
        np.array([7, 8]), np.array([1, 2, 3]), [[1.0, np.nan, np.nan], [np.nan, 5.0, np.nan]]
    )
    assert ours.compute() == ref.compute()
    out = ours.compute()
    assert (out["num_matches"], out["num_false_positives"], out["num_misses"]) == (2, 1, 0)
    assert out["motp"] == pytest.approx(3.0)
    with pytest.raises(ValueError, match="threshold"):
        ClearMot(threshold=0.0)


def test_id_switch_and_fragmentation_by_hand():
    ours = ClearMot(threshold=1.0)
    frames = [([1], [10], [[0.1]]), ([1], [11], [[0.1]]), ([1], [], None), ([1], [11], [[0.3]])]
    for oids, hids, dists in frames:
        d = np.zeros((len(oids), len(hids))) if dists is None else np.asarray(dists)
        ours.update_distances(np.asarray(oids), np.asarray(hids, np.int64), d)
    out = ours.compute()
    assert (out["id_switches"], out["num_misses"], out["num_fragmentations"]) == (1, 1, 1)
    assert out["mota"] == pytest.approx(1 - 2 / 4)
    # IDF1: truth 1 <-> track 11 share 2 frames; 4 truth rows, 3 track rows
    assert out["idf1"] == pytest.approx(2 * 2 / 7)


def tud_iou_distance(objs: np.ndarray, hyps: np.ndarray, max_iou: float = 1.0) -> np.ndarray:
    """motmetrics' ``iou_matrix`` (1 − IoU of x, y, w, h boxes, NaN above ``max_iou``) without np.asfarray."""
    try:
        return mm.distances.iou_matrix(objs, hyps, max_iou=max_iou)
    except AttributeError:  # numpy >= 2: np.asfarray was removed
        pass
    if np.size(objs) == 0 or np.size(hyps) == 0:
        return np.empty((0, 0))
    a = np.asarray(objs, dtype=np.float64)[:, None]
    b = np.asarray(hyps, dtype=np.float64)[None, :]
    lo, hi = np.maximum(a[..., :2], b[..., :2]), np.minimum(a[..., :2] + a[..., 2:], b[..., :2] + b[..., 2:])
    inter = np.prod(np.maximum(hi - lo, 0), axis=-1)
    union = np.prod(np.maximum(a[..., 2:], 0), axis=-1) + np.prod(np.maximum(b[..., 2:], 0), axis=-1) - inter
    with np.errstate(divide="ignore", invalid="ignore"):
        iou = np.where(inter == 0, 0.0, inter / union)
    dist = 1 - iou
    return np.where(dist > max_iou, np.nan, dist)


TUD = {  # name: (MOTA, ID switches, IDF1), motmetrics' own test_motchallenge_files figures
    "TUD-Campus": (0.526462, 7, 0.557659),
    "TUD-Stadtmitte": (0.564014, 7, 0.644619),
}


@pytest.mark.filterwarnings("ignore:Operation with tuple is deprecated")  # motmetrics io.py on pandas 3
@pytest.mark.parametrize("name", sorted(TUD))
def test_tud_sequences_match_motmetrics(name, monkeypatch):
    data = Path(mm.__file__).parent / "data" / name
    gt, dt = mm.io.loadtxt(str(data / "gt.txt")), mm.io.loadtxt(str(data / "test.txt"))
    ours = ClearMot(threshold=0.5)

    class Tee(mm.MOTAccumulator):  # type: ignore[name-defined]
        """motmetrics' accumulator that hands every frame's matrix to ours as well."""

        def update(self, oids, hids, dists, frameid=None, vf=""):
            ours.update_distances(np.asarray(oids), np.asarray(hids), dists)
            return super().update(oids, hids, dists, frameid=frameid, vf=vf)

    monkeypatch.setattr(mm.utils, "iou_matrix", tud_iou_distance)
    monkeypatch.setattr(mm.utils, "MOTAccumulator", Tee)
    acc = mm.utils.compare_to_groundtruth(gt, dt, "iou", distth=0.5)
    theirs, mine = motmetrics_summary(acc), ours.compute()
    assert_same(mine, theirs)
    mota, switches, idf1 = TUD[name]
    assert mine["mota"] == pytest.approx(mota, abs=5e-7)
    assert mine["id_switches"] == switches
    assert mine["idf1"] == pytest.approx(idf1, abs=5e-7)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_component_matching_equals_one_dense_assignment(seed):
    rng = np.random.default_rng(seed)
    dense = rng.integers(1, 9, size=rng.integers(1, 9, size=2))
    dense[rng.random(dense.shape) < rng.uniform(0.3, 0.9)] = 0
    dense[0, 0] = max(dense[0, 0], 1)  # at least one edge
    keep_r, keep_c = dense.any(axis=1), dense.any(axis=0)
    dense = dense[keep_r][:, keep_c]
    rows, cols = np.nonzero(dense)
    r, c = linear_sum_assignment(dense, maximize=True)
    assert max_weight_matching(rows, cols, dense[rows, cols]) == dense[r, c].sum()


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["continuous", "ties", "dense block"]))
def test_component_matching_of_the_rest_equals_the_dense_motmetrics_problem(seed, kind):
    """Step 2 solved component by component (unique optima) or, on a near tie or a component
    with too many matchings, densely: the same pairs as the dense problem motmetrics solves."""
    from track_envs.metrics.clear_mot_events import _assign_like_motmetrics, _match_the_rest

    rng = np.random.default_rng(seed)
    m, n = rng.integers(1, 14, size=2)
    if kind == "dense block":  # one component with more matchings than are enumerated
        m, n = 9, 9
        possible = np.ones((m, n), bool)
    else:
        possible = rng.random((m, n)) < rng.uniform(0.1, 0.5)
    dist = rng.random((m, n)) if kind != "ties" else rng.integers(0, 3, size=(m, n)) / 2.0
    ptr = np.zeros(m + 1, np.int64)
    ptr[1:] = np.cumsum(possible.sum(axis=1))
    cols = np.nonzero(possible)[1].astype(np.int64)
    d = dist[possible].astype(np.float64)
    row_taken, col_taken = rng.random(m) < 0.2, rng.random(n) < 0.2
    got = _match_the_rest(ptr, cols, d, row_taken, col_taken)
    want = _assign_like_motmetrics(ptr, cols, d, row_taken, col_taken, n)
    assert got.tolist() == want.tolist()


def test_box_clear_mot_on_overlapping_pairs_equals_the_dense_matrix():
    """BoxClearMot's spatial candidates give the events of the dense 1 − IoU matrix, ties included
    (integer boxes, duplicated reports, a non-finite box)."""
    from track_envs.metrics.boxes import BoxClearMot, iou_distances

    rng = np.random.default_rng(4)
    sparse, dense = BoxClearMot(0.5), BoxClearMot(0.5)
    boxes = np.column_stack([rng.integers(0, 300, (80, 2)), rng.integers(5, 30, (80, 2))]).astype(float)
    for _ in range(20):
        boxes[:, :2] += rng.integers(-3, 4, (80, 2))
        reported = np.concatenate([boxes[:60] + rng.integers(-2, 3, (60, 4)), boxes[:10]])
        reported[3] = [np.nan, 0, 1, 1]
        visible = rng.random(80) < 0.9
        truth = {"ids": np.arange(80), "positions": boxes[:, :2], "visible": visible, "boxes": boxes}
        report = {
            "ids": rng.permutation(200)[:70],
            "positions": reported[:, :2],
            "detection": np.full(70, -1),
            "mask": (rng.random(70) < 0.95).astype(np.int8),
            "boxes": reported,
        }
        sparse.update(truth, np.full(1, -1), report)
        live = report["mask"] == 1
        dense.update_distances(
            np.arange(80)[visible], report["ids"][live], iou_distances(boxes[visible], reported[live], 0.5)
        )
    assert sparse.compute() == dense.compute() or all(
        (a == b) or (np.isnan(a) and np.isnan(b))
        for a, b in zip(sparse.compute().values(), dense.compute().values(), strict=True)
    )
    assert sparse.compute()["num_detections"] > 500


def test_frames_above_the_dense_limit_break_ties_within_components():
    """A frame larger than the dense limit never builds motmetrics' matrix: a duplicated report
    (a tie) and a seven-point pile (over 4,096 matchings) are matched within their components."""
    from track_envs.metrics.clear_mot_events import DENSE_LIMIT

    side = 47  # 2,209 truths on a grid of unit spacing
    grid = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2).astype(float)
    assert len(grid) ** 2 > DENSE_LIMIT
    truth_pos = grid.copy()
    truth_pos[:7] = [0.0, 0.0]  # a pile: seven truths on one point...
    reports = np.concatenate([truth_pos, truth_pos[100:101]])  # ...and a duplicated report
    metric = ClearMot(threshold=0.3)
    truth = {
        "ids": np.arange(len(truth_pos)),
        "positions": truth_pos,
        "visible": np.ones(len(truth_pos), bool),
    }
    report = {
        "ids": np.arange(len(reports)) + 10_000,
        "positions": reports,
        "detection": np.full(len(reports), -1),
        "mask": np.ones(len(reports), np.int8),
    }
    metric.update(truth, np.full(1, -1), report)
    out = metric.compute()
    assert out["num_matches"] == len(truth_pos)
    assert out["num_false_positives"] == 1 and out["num_misses"] == 0
    assert out["motp"] == 0.0


def test_a_larger_tie_heavy_point_stream_matches_motmetrics():
    """Hundreds of points on a 0.5 grid (ties everywhere, pairs exactly at the threshold) through
    the spatial candidates: the events of motmetrics on the full cdist matrix."""
    from scipy.spatial.distance import cdist

    rng = np.random.default_rng(8)
    acc, ours = mm.MOTAccumulator(auto_id=True), ClearMot(threshold=1.0)
    for _ in range(12):
        m, n = 300, 280
        truth = {
            "ids": rng.choice(400, m, replace=False).astype(np.int64),
            "positions": rng.integers(0, 40, (m, 2)) * 0.5,
            "visible": rng.random(m) < 0.9,
        }
        report = {
            "ids": rng.choice(400, n, replace=False).astype(np.int64) + 1000,
            "positions": rng.integers(0, 40, (n, 2)) * 0.5,
            "detection": np.full(n, -1, np.int64),
            "mask": np.ones(n, np.int8),
        }
        ours.update(truth, np.full(1, -1), report)
        live = truth["visible"]
        d = cdist(truth["positions"][live], report["positions"])
        d[d > 1.0] = np.nan
        acc.update(truth["ids"][live], report["ids"], d)
    assert_same(ours.compute(), motmetrics_summary(acc))
