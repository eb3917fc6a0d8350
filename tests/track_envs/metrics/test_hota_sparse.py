"""HOTA on the non-zero similarities (spatial index, per-component matching) against the dense path.

``DenseHota`` below is the accumulator as it was before frames were kept sparse: the dense
similarity matrix of every frame, its row and column sums, and scipy's assignment of the whole
matrix wherever a row or column has two non-zero entries. The sparse path must give the very same
arrays (``np.array_equal``), ties included.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from track_envs.metrics import BoxHota, Hota
from track_envs.metrics import hota as hota_module
from track_envs.metrics.hota import ALPHAS, HotaAccumulator
from track_envs.metrics.hota_matching import column_sums, frame_matches, row_sums, unique_inverse
from track_envs.metrics.hota_similarity import (
    box_iou,
    box_iou_entries,
    point_similarity,
    point_similarity_entries,
)

_EPS = float(np.finfo(float).eps)


class DenseHota:
    """The dense reference: TrackEval's per-frame steps on the whole matrix."""

    def __init__(self) -> None:
        self.frames: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def add_frame(self, gt: np.ndarray, tr: np.ndarray, sim: np.ndarray) -> None:
        self.frames.append((np.asarray(gt, np.int64), np.asarray(tr, np.int64), np.asarray(sim, float)))

    def compute_arrays(self) -> dict[str, np.ndarray]:
        n_alpha = ALPHAS.size
        gt_values = np.unique(np.concatenate([f[0] for f in self.frames]))
        tr_values = np.unique(np.concatenate([f[1] for f in self.frames]))
        gt_count = np.zeros(gt_values.size)
        tr_count = np.zeros(tr_values.size)
        soft: dict[tuple[int, int], float] = {}
        for gt, tr, sim in self.frames:
            g, k = np.searchsorted(gt_values, gt), np.searchsorted(tr_values, tr)
            gt_count[g] += 1
            tr_count[k] += 1
            denominator = sim.sum(0)[np.newaxis, :] + sim.sum(1)[:, np.newaxis] - sim
            match = np.zeros_like(sim)
            ok = denominator > _EPS
            match[ok] = sim[ok] / denominator[ok]
            for i, j in zip(*np.nonzero(sim), strict=True):
                soft[(g[i], k[j])] = soft.get((g[i], k[j]), 0.0) + match[i, j]
        alignment = {key: p / (gt_count[key[0]] + tr_count[key[1]] - p) for key, p in soft.items()}
        tp = np.zeros(n_alpha)
        loc = np.zeros(n_alpha)
        pair_tp: dict[tuple[int, int], np.ndarray] = {}
        for gt, tr, sim in self.frames:
            g, k = np.searchsorted(gt_values, gt), np.searchsorted(tr_values, tr)
            score = np.zeros_like(sim)
            for i, j in zip(*np.nonzero(sim), strict=True):
                score[i, j] = alignment[(g[i], k[j])] * sim[i, j]
            rows, cols = linear_sum_assignment(-score)
            for i, j in zip(rows, cols, strict=True):
                if sim[i, j] > 0:
                    passes = sim[i, j] >= ALPHAS - _EPS
                    tp += passes
                    loc += passes * sim[i, j]
                    key = (g[i], k[j])
                    pair_tp[key] = pair_tp.get(key, np.zeros(n_alpha)) + passes
        n_gt = sum(f[0].size for f in self.frames)
        n_tr = sum(f[1].size for f in self.frames)
        ass_a = np.zeros(n_alpha)
        for (gi, ki), c in sorted(pair_tp.items()):
            ass_a += c * (c / np.maximum(1.0, gt_count[gi] + tr_count[ki] - c))
        ass_a /= np.maximum(1.0, tp)
        det_a = tp / np.maximum(1.0, tp + (n_gt - tp) + (n_tr - tp))
        return {"HOTA": np.sqrt(det_a * ass_a), "DetA": det_a, "AssA": ass_a, "HOTA_TP": tp, "loc": loc}


def tie_heavy_stream(rng: np.random.Generator, frames: int, n: int) -> list[tuple]:
    """Frames with shared ids across frames, many exact ties (values on a coarse grid, duplicated
    columns) and components of every size."""
    out = []
    for _ in range(frames):
        gt = rng.choice(2 * n, size=int(rng.integers(0, n + 1)), replace=False)
        tr = rng.choice(2 * n, size=int(rng.integers(0, n + 1)), replace=False) + 500
        sim = rng.random((gt.size, tr.size)) * (rng.random((gt.size, tr.size)) < 3.0 / max(n, 1))
        if rng.random() < 0.5:
            sim = np.round(sim, 1)
        if tr.size > 1 and rng.random() < 0.5:
            sim[:, -1] = sim[:, 0]  # a duplicated report
        out.append((gt, tr, sim))
    return out


def summary(arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return {k: arrays[k] for k in ("HOTA", "DetA", "AssA", "HOTA_TP")}


@pytest.mark.parametrize("seed", range(12))
def test_sparse_frames_equal_the_dense_reference(seed):
    rng = np.random.default_rng(seed)
    frames = tie_heavy_stream(rng, int(rng.integers(1, 40)), int(rng.integers(1, 25)))
    dense, acc, sparse = DenseHota(), HotaAccumulator(), HotaAccumulator()
    for gt, tr, sim in frames:
        dense.add_frame(gt, tr, sim)
        acc.add_frame(gt, tr, sim)
        rows, cols = np.nonzero(sim)
        sparse.add_sparse_frame(gt, tr, rows, cols, sim[rows, cols])
    if not any(f[0].size for f in frames) or not any(f[1].size for f in frames):
        return
    reference = dense.compute_arrays()
    for got in (acc.compute_arrays(), sparse.compute_arrays()):
        for key in ("HOTA", "DetA", "AssA", "HOTA_TP"):
            np.testing.assert_allclose(got[key], reference[key], rtol=0, atol=1e-12)
    # the two entry paths are bit for bit the same
    a, b = acc.compute_arrays(), sparse.compute_arrays()
    assert all(np.array_equal(a[k], b[k]) for k in a)


@pytest.mark.parametrize("m", [1, 5, 8, 9, 127, 128, 129, 300, 1000, 8192, 8193, 20000])
def test_row_and_column_sums_are_numpys(m):
    """The sparse sums are the floats numpy's dense sums return (pairwise along rows)."""
    rng = np.random.default_rng(m)
    sim = rng.random((6, m)) * 10.0 ** rng.integers(-6, 1, (6, m))
    sim[rng.random(sim.shape) < 1 - min(1.0, 40 / m)] = 0.0
    rows, cols = np.nonzero(sim)
    values = sim[rows, cols]
    assert np.array_equal(row_sums(rows.astype(np.int64), cols.astype(np.int64), values, 6, m), sim.sum(1))
    assert np.array_equal(column_sums(cols.astype(np.int64), values, m), sim.sum(0))


def test_unique_inverse_is_numpys():
    keys = np.random.default_rng(0).integers(-50, 50, 1000) * 10**12
    values, inverse = unique_inverse(keys)
    expected_values, expected_inverse = np.unique(keys, return_inverse=True)
    assert np.array_equal(values, expected_values)
    assert np.array_equal(inverse, expected_inverse)


@pytest.mark.parametrize("seed", range(4))
def test_point_entries_are_the_dense_non_zeros(seed):
    rng = np.random.default_rng(seed)
    a = np.round(rng.uniform(0, 10, (300, 2)))  # integer coordinates: many distances exactly τ
    b = np.concatenate([a[:100], np.round(rng.uniform(0, 10, (200, 2)))])
    for tau in (1.0, 2.0, 0.5):
        dense = point_similarity(a, b, tau)
        rows, cols, values = point_similarity_entries(a, b, tau)
        expected = np.nonzero(dense)
        assert np.array_equal(rows, expected[0]) and np.array_equal(cols, expected[1])
        assert np.array_equal(values, dense[expected])


def test_box_entries_are_the_dense_non_zeros():
    rng = np.random.default_rng(3)
    a = np.column_stack([rng.integers(0, 200, (400, 2)), rng.integers(0, 30, (400, 2))]).astype(float)
    b = np.concatenate(
        [a[:150], np.column_stack([rng.integers(0, 200, (300, 2)), rng.integers(1, 60, (300, 2))])]
    )
    b[5] = [np.nan, 1, 2, 3]
    a[7] = [0, 0, np.inf, 4]
    dense = np.nan_to_num(box_iou(a, b), nan=0.0)
    rows, cols, values = box_iou_entries(a, b)
    expected = np.nonzero(dense)
    assert np.array_equal(rows, expected[0]) and np.array_equal(cols, expected[1])
    assert np.array_equal(values, dense[expected])


def test_an_exact_tie_is_solved_on_the_dense_frame():
    """A duplicated report makes two optima: the frame goes to the dense solver (TrackEval's)."""
    rows = np.array([0, 0, 1, 1], np.int64)
    cols = np.array([0, 1, 0, 1], np.int64)
    score = np.array([0.5, 0.5, 0.5, 0.5])
    take, dense = frame_matches(
        np.array([0, 4]), rows, cols, score, np.array([2]), np.array([2]), 1e-9, 10**6
    )
    assert dense.tolist() == [True]
    # above the size limit the component's own solver breaks the tie: still a perfect matching
    take, dense = frame_matches(np.array([0, 4]), rows, cols, score, np.array([2]), np.array([2]), 1e-9, 1)
    assert dense.tolist() == [False] and take.sum() == 2
    assert len(set(rows[take])) == 2 and len(set(cols[take])) == 2


def test_unique_components_need_no_dense_solve():
    """Two separate components, each with a unique optimum: solved on their own."""
    rows = np.array([0, 0, 1, 2, 2, 3], np.int64)
    cols = np.array([0, 1, 1, 2, 3, 3], np.int64)
    score = np.array([0.9, 0.3, 0.8, 0.2, 0.7, 0.6])
    take, dense = frame_matches(
        np.array([0, 6]), rows, cols, score, np.array([4]), np.array([4]), 1e-9, 10**6
    )
    assert dense.tolist() == [False]
    assert take.tolist() == [True, False, True, True, False, True]


def test_large_frames_keep_an_optimal_matching(monkeypatch):
    """Above the dense limit ties are broken per component: the figures stay those of an optimum
    (here equal to the dense reference on a stream without exact ties)."""
    monkeypatch.setattr(hota_module, "DENSE_LIMIT", 0)
    rng = np.random.default_rng(11)
    frames = [(gt, tr, sim) for gt, tr, sim in tie_heavy_stream(rng, 30, 20)]
    frames = [(gt, tr, sim * rng.uniform(0.9, 1.0, sim.shape)) for gt, tr, sim in frames]  # no exact ties
    dense, sparse = DenseHota(), HotaAccumulator()
    for gt, tr, sim in frames:
        dense.add_frame(gt, tr, sim)
        sparse.add_frame(gt, tr, sim)
    reference, got = dense.compute_arrays(), sparse.compute_arrays()
    for key in ("HOTA", "DetA", "AssA", "HOTA_TP"):
        np.testing.assert_allclose(got[key], reference[key], rtol=0, atol=1e-12)


def test_streaming_hota_equals_the_dense_similarity_path():
    """Hota (spatial index) against the dense similarity fed to the dense reference, with integer
    coordinates (ties) and swapped ids."""
    rng = np.random.default_rng(2)
    metric, reference = Hota(threshold=2.0), DenseHota()
    box_metric, box_reference = BoxHota(), DenseHota()
    truth_pos = np.round(rng.uniform(0, 30, (60, 2)))
    for _ in range(25):
        truth_pos += np.round(rng.normal(0, 0.6, truth_pos.shape))
        ids = np.arange(60)
        tracks = ids + 100
        swap = rng.choice(59, 3, replace=False)  # three id swaps between neighbours
        for a in swap:
            tracks[a], tracks[a + 1] = tracks[a + 1], tracks[a]
        report_pos = truth_pos + np.round(rng.normal(0, 0.7, truth_pos.shape))
        truth = {"ids": ids, "positions": truth_pos, "visible": rng.random(60) < 0.9}
        truth["boxes"] = np.column_stack([truth_pos, np.full((60, 2), 3.0)])
        report = {
            "ids": tracks,
            "positions": report_pos,
            "detection": np.full(60, -1),
            "mask": np.ones(60, np.int8),
        }
        report["boxes"] = np.column_stack([report_pos, np.full((60, 2), 3.0)])
        metric.update(truth, np.full(1, -1), report)
        box_metric.update(truth, np.full(1, -1), report)
        live = truth["visible"]
        reference.add_frame(ids[live], tracks, point_similarity(truth_pos[live], report_pos, 2.0))
        box_reference.add_frame(ids[live], tracks, box_iou(truth["boxes"][live], report["boxes"]))
    for got, ref in ((metric._acc, reference), (box_metric._acc, box_reference)):
        arrays, expected = got.compute_arrays(), ref.compute_arrays()
        for key in ("HOTA", "DetA", "AssA", "HOTA_TP"):
            np.testing.assert_allclose(arrays[key], expected[key], rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("rows", "cols", "values", "message"),
    [
        ([0, 0], [1, 0], [0.5, 0.5], "row-major"),
        ([0, 0], [0, 0], [0.5, 0.5], "row-major"),
        ([0], [3], [0.5], "must lie in"),
        ([0], [0], [1.5], r"in \[0, 1\]"),
        ([0, 1], [0], [0.5], "one length"),
    ],
)
def test_bad_sparse_frames_are_named(rows, cols, values, message):
    with pytest.raises(ValueError, match=message):
        HotaAccumulator().add_sparse_frame([1, 2], [7, 8], rows, cols, values)


def test_a_larger_tie_heavy_stream_matches_trackeval():
    """The streaming metric on integer points (ties, pairs exactly at τ) against TrackEval's HOTA
    on the dense similarity matrices."""
    trackeval = pytest.importorskip("trackeval")
    rng = np.random.default_rng(9)
    metric = Hota(threshold=2.0)
    frames = []
    truth_pos = np.round(rng.uniform(0, 40, (200, 2)))
    for _ in range(15):
        truth_pos += np.round(rng.normal(0, 0.5, truth_pos.shape))
        report_pos = np.concatenate(
            [truth_pos[:180] + np.round(rng.normal(0, 0.7, (180, 2))), truth_pos[:20]]
        )
        ids, tracks = (
            np.arange(200),
            np.concatenate([np.arange(180), 500 + rng.choice(50, 20, replace=False)]),
        )
        truth = {"ids": ids, "positions": truth_pos, "visible": np.ones(200, bool)}
        report = {
            "ids": tracks,
            "positions": report_pos,
            "detection": np.full(200, -1),
            "mask": np.ones(200, np.int8),
        }
        metric.update(truth, np.full(1, -1), report)
        frames.append((ids, tracks, point_similarity(truth_pos, report_pos, 2.0)))
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
    theirs = trackeval.metrics.HOTA({"PRINT_CONFIG": False}).eval_sequence(data)
    arrays = metric._acc.compute_arrays()
    for key in ("HOTA", "DetA", "AssA", "LocA", "DetRe", "DetPr", "AssRe", "AssPr"):
        np.testing.assert_allclose(arrays[key], theirs[key], rtol=0, atol=1e-9)
