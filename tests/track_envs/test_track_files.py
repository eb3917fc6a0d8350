"""Track files (MOT, wide, long) round-trip; BeltReplay-v0 reads the wide layout; motmetrics reads MOT."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401  (registers the envs)
from track_envs.contracts.report import empty_report
from track_envs.io.csv_parser import DetectionFileError
from track_envs.io.tracks import read_tracks, track_format, write_tracks
from track_envs.metrics.track_scoring import NO_DETECTION_IDS, score_tracks
from track_envs.values.tracks import Tracks


def random_tracks(seed: int = 0, n_frames: int = 40, n_ids: int = 9, cov: bool = False) -> Tracks:
    """Ids 0..n_ids-1, each alive over a random run of frames, full-precision positions."""
    rng = np.random.default_rng(seed)
    grid = rng.uniform(0, 1, (n_frames, n_ids, 2))
    for i in range(n_ids):
        a = rng.integers(0, n_frames - 5)
        grid[:a, i] = np.nan
        grid[a + rng.integers(3, 20) :, i] = np.nan
    tracks = Tracks.from_wide(grid)
    if not cov:
        return tracks
    a = rng.normal(size=(len(tracks), 2, 2))
    return Tracks(
        tracks.frame,
        tracks.ids,
        tracks.positions,
        n_frames,
        a @ a.transpose(0, 2, 1),
        np.arange(len(tracks)) % 4 - 1,
    )


@pytest.mark.parametrize(
    ("fmt", "name"), [("mot", "t.txt"), ("wide", "t.csv"), ("wide", "t.zip"), ("long", "t.csv")]
)
def test_every_format_round_trips_bit_for_bit(tmp_path: Path, fmt: str, name: str) -> None:
    tracks = random_tracks(cov=fmt == "long")
    write_tracks(tmp_path / name, tracks, fmt)
    assert track_format(tmp_path / name) == fmt
    back = read_tracks(tmp_path / name, n_frames=tracks.n_frames)
    assert back.equals(tracks)
    if fmt == "long":
        np.testing.assert_array_equal(back.cov, tracks.cov)
        np.testing.assert_array_equal(back.detection, tracks.detection)


def test_mot_truth_rows_carry_the_considered_flag(tmp_path: Path) -> None:
    tracks = random_tracks()
    write_tracks(tmp_path / "gt.txt", tracks, "mot", truth=True)
    first = (tmp_path / "gt.txt").read_text().splitlines()[0].split(",")
    assert first[6:] == ["1", "1", "1"] and len(first) == 9
    assert read_tracks(tmp_path / "gt.txt", min_confidence=1, n_frames=tracks.n_frames).equals(tracks)


def test_wide_tracks_are_what_belt_replay_reads_back(tmp_path: Path) -> None:
    tracks = random_tracks(n_frames=30)
    write_tracks(tmp_path / "tracks.csv", tracks, "wide")
    env = gym.make("BeltReplay-v0", path=str(tmp_path / "tracks.csv"))
    _, info = env.reset(seed=0)
    seen = []
    for _ in range(tracks.n_frames):
        live = info["truth"]["ids"] >= 0
        order = np.argsort(info["truth"]["ids"][live])
        seen.append((info["truth"]["ids"][live][order], info["truth"]["positions"][live][order]))
        _, _, terminated, _, info = env.step(empty_report(env.unwrapped.sensor_spec.max_tracks, (2,)))
        if terminated:
            break
    replayed = Tracks(
        np.repeat(np.arange(len(seen)), [len(i) for i, _ in seen]),
        np.concatenate([i for i, _ in seen]),
        np.concatenate([p for _, p in seen]),
        tracks.n_frames,
    )
    assert replayed.equals(tracks)


def test_an_id_twice_in_a_frame_is_named(tmp_path: Path) -> None:
    (tmp_path / "t.txt").write_text("1,4,0,0,0,0,1,-1,-1,-1\n1,4,1,1,0,0,1,-1,-1,-1\n")
    with pytest.raises(DetectionFileError, match=r"t\.txt: id 4 appears twice in frame 0"):
        read_tracks(tmp_path / "t.txt")


def test_long_files_name_bad_cells(tmp_path: Path) -> None:
    (tmp_path / "t.csv").write_text("frame,id,x,y\n0,1,0.5,0.5\n1,1.5,0.5,0.5\n")
    with pytest.raises(
        DetectionFileError, match=r"row 3, column index 1 \('id'\) holds 1.5; expected an integer"
    ):
        read_tracks(tmp_path / "t.csv")


@pytest.mark.filterwarnings("ignore:Operation with tuple is deprecated")  # inside motmetrics' loader
def test_motmetrics_loads_our_mot_files_and_scores_them_as_clear_mot(tmp_path: Path) -> None:
    """A noisy tracker (switches, misses, false tracks): motmetrics on our files = our ClearMot."""
    mm = pytest.importorskip("motmetrics")
    rng = np.random.default_rng(3)
    truth = random_tracks(seed=1, n_frames=60, n_ids=12)
    keep = rng.random(len(truth)) > 0.1  # misses
    ids = truth.ids.copy()
    ids[truth.frame > 30] = (ids[truth.frame > 30] + 1) % 12  # identity switches
    noisy = truth.positions + rng.normal(0, 0.02, truth.positions.shape)
    clutter_frames = np.sort(rng.integers(0, 60, 25))
    frame = np.concatenate([truth.frame[keep], clutter_frames])
    order = np.argsort(frame, kind="stable")
    tracks = Tracks(
        frame[order],
        np.concatenate([ids[keep], 100 + np.arange(25)])[order],
        np.concatenate([noisy[keep], rng.uniform(0, 1, (25, 2))])[order],
        60,
    )
    write_tracks(tmp_path / "gt.txt", truth, "mot", truth=True)
    write_tracks(tmp_path / "tracks.txt", tracks, "mot")
    gt = mm.io.loadtxt(str(tmp_path / "gt.txt"), fmt="mot15-2D", min_confidence=1)
    ts = mm.io.loadtxt(str(tmp_path / "tracks.txt"), fmt="mot15-2D")
    acc = mm.utils.compare_to_groundtruth(gt, ts, "euc", distfields=["X", "Y"], distth=0.05)
    names = {"mota": "mota", "motp": "motp", "id_switches": "num_switches", "idf1": "idf1",
             "num_misses": "num_misses", "num_false_positives": "num_false_positives",
             "num_objects": "num_objects", "num_predictions": "num_predictions"}  # fmt: skip
    theirs = mm.metrics.create().compute(acc, metrics=list(names.values()), return_dataframe=False)
    ours, notes = score_tracks(
        read_tracks(tmp_path / "tracks.txt"), read_tracks(tmp_path / "gt.txt"), threshold=0.05
    )
    assert ours["id_switches"] > 0 and ours["num_misses"] > 0 and ours["num_false_positives"] > 0
    for key, name in names.items():
        # motmetrics subtracts 1 from X and Y (the MATLAB convention): distances differ in the last bit
        assert ours[key] == pytest.approx(float(theirs[name]), rel=1e-12), key
    assert notes == [NO_DETECTION_IDS]


@pytest.mark.parametrize(("fmt", "name"), [("mot", "t.txt"), ("long", "t.csv")])
def test_ids_beyond_two_to_the_53_survive(tmp_path: Path, fmt: str, name: str) -> None:
    """Regression: ids were parsed as floats, so 2**62 - 1 came back as 2**62 (report ids reach 2**62)."""
    tracks = Tracks(np.array([0, 0, 1]), np.array([2**62 - 1, 2**53 + 1, 7]), np.zeros((3, 2)), 2)
    write_tracks(tmp_path / name, tracks, fmt)
    np.testing.assert_array_equal(read_tracks(tmp_path / name).ids, tracks.ids)


@pytest.mark.parametrize("rows", [1, 5, 1 << 16])
def test_track_writers_write_in_chunks_the_bytes_of_one_pass(tmp_path, monkeypatch, rows):
    import track_envs.io.csv_parser as csv_parser
    import track_envs.io.tracks as track_io
    import track_envs.io.wide_tracks as wide_tracks
    from track_envs.io.wide_tracks import write_track_csv

    base = random_tracks(seed=3, cov=True)
    rng = np.random.default_rng(3)
    boxes = rng.uniform(0, 1, (len(base), 4))
    boxes[rng.random(len(base)) < 0.3] = np.nan  # rows without a box: empty cells
    detection = rng.integers(-1, 4, len(base))
    tracks = Tracks(base.frame, base.ids, base.positions, base.n_frames + 3, base.cov, detection, boxes)
    for fmt in ("mot", "long", "wide"):
        write_tracks(tmp_path / f"one.{fmt}", tracks, fmt)
    write_track_csv(tmp_path / "reference.wide", tracks.to_wide()[0])
    for module in (csv_parser, track_io, wide_tracks):
        monkeypatch.setattr(module, "CHUNK_ROWS", rows, raising=False)
    for fmt in ("mot", "long", "wide"):
        write_tracks(tmp_path / f"t.{fmt}", tracks, fmt)
        assert (tmp_path / f"t.{fmt}").read_bytes() == (tmp_path / f"one.{fmt}").read_bytes(), fmt
    assert (tmp_path / "t.wide").read_bytes() == (tmp_path / "reference.wide").read_bytes()
    back = read_tracks(tmp_path / "t.long", n_frames=tracks.n_frames)
    np.testing.assert_array_equal(back.boxes, boxes)
    assert back.equals(tracks)
