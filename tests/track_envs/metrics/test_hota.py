"""HotaAccumulator against TrackEval 1.3.0's HOTA class on the same per-frame similarity matrices.

TrackEval 1.3.0 imports under numpy 2 as it is (its HOTA code uses no removed numpy alias), so no
monkeypatching is needed.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from track_envs.metrics.hota import ALPHAS, HOTA_FIELDS, HotaAccumulator
from track_envs.metrics.hota_similarity import box_iou, point_similarity

trackeval = pytest.importorskip("trackeval")
motmetrics = pytest.importorskip("motmetrics")

Frame = tuple[np.ndarray, np.ndarray, np.ndarray]
ARRAY_FIELDS = (*HOTA_FIELDS, "HOTA_TP", "HOTA_FN", "HOTA_FP")


def trackeval_hota(frames: list[Frame]) -> dict[str, np.ndarray]:
    """TrackEval's HOTA.eval_sequence on the frames (ids relabelled 0.. as its datasets do)."""
    gt_all = np.concatenate([f[0] for f in frames]) if frames else np.empty(0, int)
    tr_all = np.concatenate([f[1] for f in frames]) if frames else np.empty(0, int)
    gt_values, tr_values = np.unique(gt_all), np.unique(tr_all)
    data = {
        "num_gt_dets": int(gt_all.size),
        "num_tracker_dets": int(tr_all.size),
        "num_gt_ids": int(gt_values.size),
        "num_tracker_ids": int(tr_values.size),
        "gt_ids": [np.searchsorted(gt_values, f[0]) for f in frames],
        "tracker_ids": [np.searchsorted(tr_values, f[1]) for f in frames],
        "similarity_scores": [f[2] for f in frames],
    }
    return trackeval.metrics.HOTA({"PRINT_CONFIG": False}).eval_sequence(data)


def ours(frames: list[Frame]) -> HotaAccumulator:
    acc = HotaAccumulator()
    for frame in frames:
        acc.add_frame(*frame)
    return acc


def max_difference(acc: HotaAccumulator, reference: dict[str, np.ndarray]) -> float:
    arrays = acc.compute_arrays()
    summary = acc.compute()
    worst = max(float(np.max(np.abs(arrays[k] - reference[k]))) for k in ARRAY_FIELDS)
    return max(worst, *(abs(summary[k] - float(np.mean(reference[k]))) for k in HOTA_FIELDS))


def random_stream(rng: np.random.Generator) -> list[Frame]:
    """Ids appearing and disappearing, empty frames, sparse similarities, some exactly tied."""
    n_frames = int(rng.integers(1, 60))
    n_gt, n_tr = int(rng.integers(1, 14)), int(rng.integers(1, 18))
    sparsity = rng.uniform(0.2, 0.95)
    frames = []
    for _ in range(n_frames):
        gt = rng.choice(3 * n_gt, size=rng.integers(0, n_gt + 1), replace=False) * 7 - 5
        tr = rng.choice(3 * n_tr, size=rng.integers(0, n_tr + 1), replace=False) + 10_000
        sim = rng.random((gt.size, tr.size))
        sim[rng.random(sim.shape) < sparsity] = 0.0
        if rng.random() < 0.3:
            sim = np.round(sim, 1)  # ties, and values exactly on the α grid
        frames.append((gt, tr, sim))
    return frames


def test_alphas_are_the_nineteen_thresholds():
    assert ALPHAS.size == 19
    np.testing.assert_allclose(ALPHAS, np.arange(1, 20) / 20, atol=1e-15)
    np.testing.assert_array_equal(ALPHAS, trackeval.metrics.HOTA({"PRINT_CONFIG": False}).array_labels)


@pytest.mark.parametrize("seed", range(40))
def test_random_streams_match_trackeval(seed):
    frames = random_stream(np.random.default_rng(seed))
    assert max_difference(ours(frames), trackeval_hota(frames)) < 1e-9


def test_one_to_one_frames_match_trackeval():
    """Frames where every row and column has at most one non-zero similarity take the no-assignment path."""
    rng = np.random.default_rng(7)
    frames = []
    for _ in range(50):
        n = int(rng.integers(0, 8))
        gt, tr = rng.permutation(10)[:n], rng.permutation(10)[:n] + 100
        sim = np.diag(rng.uniform(0.0, 1.0, n)) if n else np.zeros((0, 0))
        frames.append((gt, tr, sim))
    assert max_difference(ours(frames), trackeval_hota(frames)) < 1e-9


def test_perfect_tracking_scores_one():
    frames = [(np.arange(4), np.arange(4) + 50, np.eye(4)) for _ in range(10)]
    assert ours(frames).compute() == pytest.approx(dict.fromkeys(HOTA_FIELDS, 1.0), abs=1e-15)


def test_a_swap_halves_association():
    """Two objects followed perfectly, the tracker ids swapped halfway: DetA 1, AssA 1/2... as TrackEval."""
    frames = [
        (np.array([1, 2]), np.array([10, 20]) if t < 5 else np.array([20, 10]), np.eye(2)) for t in range(10)
    ]
    out = ours(frames).compute()
    assert out["DetA"] == 1.0
    assert out["AssA"] == pytest.approx(1 / 3)  # every TP's pair: c/(N_g + N_k − c) = 5/(10 + 10 − 5)
    assert out["HOTA"] == pytest.approx(np.sqrt(1 / 3))
    assert max_difference(ours(frames), trackeval_hota(frames)) < 1e-9


@pytest.mark.parametrize(
    "frames",
    [
        [],
        [(np.empty(0, int), np.empty(0, int), np.zeros((0, 0)))],
        [(np.arange(3), np.empty(0, int), np.zeros((3, 0)))] * 4,
        [(np.empty(0, int), np.arange(2), np.zeros((0, 2)))] * 4,
        [(np.arange(3), np.arange(3), np.zeros((3, 3)))] * 4,
    ],
    ids=["no-frame", "empty-frame", "no-tracker", "no-truth", "all-zero"],
)
def test_degenerate_streams(frames):
    acc = ours(frames)
    out = acc.compute()
    assert out["LocA"] == 1.0
    assert all(out[k] == 0.0 for k in HOTA_FIELDS if k != "LocA")
    if frames:
        assert max_difference(acc, trackeval_hota(frames)) < 1e-9


def test_reset_forgets_frames():
    rng = np.random.default_rng(3)
    acc = ours(random_stream(rng))
    acc.reset()
    assert acc.n_frames == 0
    frames = random_stream(rng)
    for frame in frames:
        acc.add_frame(*frame)
    assert acc.compute() == ours(frames).compute()


@pytest.mark.parametrize(
    ("gt", "tr", "sim", "message"),
    [
        ([1, 2], [3], np.ones((1, 2)), r"shape \(1, 2\).*\(2, 1\)"),
        ([1, 1], [3], np.ones((2, 1)), "gt_ids must be unique.*1 appears twice"),
        ([1], [3, 3], np.ones((1, 2)), "tracker_ids must be unique"),
        ([1], [3], [[1.5]], r"\[0, 1\]; got 1.5"),
        ([1], [3], [[np.nan]], r"\[0, 1\]; got nan"),
        ([1.5], [3], [[1.0]], "gt_ids must be integers"),
        ([[1]], [3], [[1.0]], "gt_ids must be 1-D"),
    ],
)
def test_bad_frames_are_named(gt, tr, sim, message):
    with pytest.raises(ValueError, match=message):
        HotaAccumulator().add_frame(np.asarray(gt), np.asarray(tr), sim)


def test_box_iou_matches_trackeval():
    rng = np.random.default_rng(11)
    a = np.concatenate([rng.uniform(0, 50, (20, 2)), rng.uniform(0, 30, (20, 2))], axis=1)
    b = np.concatenate([rng.uniform(0, 50, (15, 2)), rng.uniform(0, 30, (15, 2))], axis=1)
    a[0, 2] = 0.0  # a degenerate box
    reference = trackeval.datasets._base_dataset._BaseDataset._calculate_box_ious(a, b, box_format="xywh")
    np.testing.assert_allclose(box_iou(a, b), reference, rtol=0, atol=1e-15)
    corners = np.concatenate([a[:, :2], a[:, :2] + a[:, 2:]], axis=1)
    np.testing.assert_allclose(box_iou(corners, b[:0], box_format="xyxy"), np.zeros((20, 0)))
    with pytest.raises(ValueError, match="box_format must be 'xywh' or 'xyxy'; got 'cxcywh'"):
        box_iou(a, b, box_format="cxcywh")


def test_point_similarity_is_linear_in_distance():
    sim = point_similarity([[0.0, 0.0]], [[0.0, 0.0], [3.0, 4.0], [6.0, 8.0], [30.0, 40.0]], threshold=10.0)
    np.testing.assert_allclose(sim, [[1.0, 0.5, 0.0, 0.0]])
    with pytest.raises(ValueError, match="threshold must be > 0 and finite; got 0"):
        point_similarity([[0.0]], [[0.0]], threshold=0)


TUD_DATA = Path(motmetrics.__file__).parent / "data"
#: HOTA, DetA, AssA, LocA of the test.txt files py-motmetrics ships against their gt.txt (IoU).
TUD_HOTA = {
    "TUD-Campus": (0.391397, 0.418047, 0.369121, 0.770052),
    "TUD-Stadtmitte": (0.397849, 0.392268, 0.408841, 0.737521),
}


def tud_frames(name: str) -> list[Frame]:
    """Per-frame (gt ids, tracker ids, IoU) of a shipped MOT15 sequence. Every gt row there is
    marked 1 (considered), and MOT15 has no classes, so MOTChallenge's preprocessing removes nothing."""
    gt = np.loadtxt(TUD_DATA / name / "gt.txt", delimiter=",")
    dt = np.loadtxt(TUD_DATA / name / "test.txt", delimiter=",")
    assert np.all(gt[:, 6] == 1)
    n_frames = int(max(gt[:, 0].max(), dt[:, 0].max()))
    frames = []
    for t in range(1, n_frames + 1):
        g, d = gt[gt[:, 0] == t], dt[dt[:, 0] == t]
        frames.append((g[:, 1].astype(np.int64), d[:, 1].astype(np.int64), box_iou(g[:, 2:6], d[:, 2:6])))
    return frames


@pytest.mark.parametrize("name", sorted(TUD_HOTA))
def test_tud_sequences_match_trackeval(name):
    frames = tud_frames(name)
    acc = ours(frames)
    assert max_difference(acc, trackeval_hota(frames)) < 1e-9
    out = acc.compute()
    hota, det_a, ass_a, loc_a = TUD_HOTA[name]
    assert (out["HOTA"], out["DetA"], out["AssA"], out["LocA"]) == pytest.approx(
        (hota, det_a, ass_a, loc_a), abs=5e-7
    )


def test_tud_sequences_match_trackeval_motchallenge_evaluation(tmp_path):
    """TrackEval's whole MOTChallenge pipeline (its file reader, preprocessing and IoU) on the raw files."""
    info = {}
    for name in TUD_HOTA:
        (tmp_path / "gt" / name / "gt").mkdir(parents=True)
        (tmp_path / "tr" / "t" / "data").mkdir(parents=True, exist_ok=True)
        shutil.copy(TUD_DATA / name / "gt.txt", tmp_path / "gt" / name / "gt" / "gt.txt")
        shutil.copy(TUD_DATA / name / "test.txt", tmp_path / "tr" / "t" / "data" / f"{name}.txt")
        info[name] = len(tud_frames(name))
    quiet = {"PRINT_CONFIG": False}
    evaluator = trackeval.Evaluator(
        {
            **quiet,
            "USE_PARALLEL": False,
            "PRINT_RESULTS": False,
            "OUTPUT_SUMMARY": False,
            "OUTPUT_DETAILED": False,
            "PLOT_CURVES": False,
            "TIME_PROGRESS": False,
        }
    )
    dataset = trackeval.datasets.MotChallenge2DBox(
        {
            **quiet,
            "GT_FOLDER": str(tmp_path / "gt"),
            "TRACKERS_FOLDER": str(tmp_path / "tr"),
            "BENCHMARK": "MOT15",
            "SEQ_INFO": info,
            "SKIP_SPLIT_FOL": True,
        }
    )
    results, _ = evaluator.evaluate([dataset], [trackeval.metrics.HOTA(quiet)])
    for name in TUD_HOTA:
        reference = results["MotChallenge2DBox"]["t"][name]["pedestrian"]["HOTA"]
        assert max_difference(ours(tud_frames(name)), reference) < 1e-9


@pytest.mark.parametrize("name", sorted(TUD_HOTA))
def test_score_tracks_scores_boxes_with_iou_hota(name):
    """``score_tracks`` (track run --metrics) on boxed MOT files uses IoU as HOTA's similarity, so
    the shipped test.txt scores TrackEval's MOTChallenge HOTA against its gt."""
    from track_envs.io.detections import CONSIDERED
    from track_envs.io.tracks import read_tracks
    from track_envs.metrics.track_scoring import score_tracks

    tracks = read_tracks(TUD_DATA / name / "test.txt", "mot")
    truth = read_tracks(TUD_DATA / name / "gt.txt", "mot", min_confidence=CONSIDERED)
    metrics, _ = score_tracks(tracks, truth, threshold=50.0)
    hota, det_a, ass_a, loc_a = TUD_HOTA[name]
    assert metrics["hota"] == pytest.approx(hota, abs=1e-6)
    assert metrics["det_a"] == pytest.approx(det_a, abs=1e-6)
    assert metrics["ass_a"] == pytest.approx(ass_a, abs=1e-6)
    assert metrics["loc_a"] == pytest.approx(loc_a, abs=1e-6)
