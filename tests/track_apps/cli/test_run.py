"""run_agent and track run: a recorded BeltSorter-v0 episode tracked from its files equals the gym loop."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401  (registers the envs)
from agents import make_agent
from agents.files.points import run_agent
from track_apps.cli.run import format_metrics, main
from track_envs.contracts.observation import check_observation, pack_observation
from track_envs.io.tracks import output_format, read_tracks
from track_envs.values.detections import Detections
from track_envs.values.types import SensorSpec
from track_envs.wrappers import RecordTracking, TrackingMetrics

STEPS = 120
# no nozzle bar: the sorting score needs the crossing truth, which detection and track files do not hold
ENV_KWARGS = {
    "merge_touching": False,
    "clutter_rate": 2.0,
    "p_detect": 0.95,
    "noise_std": 2e-4,
    "nozzle_offset": None,
}


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> tuple[Path, dict, dict, SensorSpec]:
    """A BeltSorter-v0 episode tracked by gnn in the gym loop, recorded to files."""
    folder = tmp_path_factory.mktemp("belt")
    env = RecordTracking(
        TrackingMetrics(gym.make("BeltSorter-v0", max_episode_steps=STEPS, **ENV_KWARGS)), folder
    )
    obs, _ = env.reset(seed=5)
    spec = env.unwrapped.sensor_spec
    agent = make_agent("gnn", predictor="kf-cv")
    agent.reset(spec, seed=5)
    while True:
        obs, _, terminated, truncated, info = env.step(agent.act(obs))
        if terminated or truncated:
            break
    assert env.last_episode is not None
    return folder / "episode-000", env.last_episode, info["episode_metrics"], spec


def spec_flags(spec: SensorSpec) -> list[str]:
    lo, hi = spec.region_low, spec.region_high
    return [
        f"--declared-noise-std={spec.noise_std}",
        f"--p-detect={spec.p_detect}",
        f"--clutter-rate={spec.clutter_rate}",
        f"--region={lo[0]},{lo[1]},{hi[0]},{hi[1]}",
        f"--max-detections={spec.max_detections}",
        f"--max-tracks={spec.max_tracks}",
        "--seed=5",
        "--no-progress",
    ]


@pytest.mark.parametrize("fmt", ["mot", "wide"])
def test_track_run_on_the_recorded_detections_gives_the_gym_loops_tracks_and_metrics(
    recorded, tmp_path, capsys, fmt
):
    folder, episode, gym_metrics, spec = recorded
    if fmt == "mot":
        det, gt, dt_flag, out = folder / "det.txt", folder / "gt.txt", [f"--dt={spec.dt}"], tmp_path / "t.txt"
    else:
        det, gt, dt_flag, out = (
            folder / "det.csv",
            folder / "gt.csv",
            ["--time-column=time"],
            tmp_path / "t.csv",
        )
    code = main(
        [
            str(det),
            "--agent=gnn",
            "--predictor=kf-cv",
            *dt_flag,
            *spec_flags(spec),
            f"--out={out}",
            f"--format={fmt}",
            f"--gt={gt}",
            "--metrics",
            f"--threshold={0.005}",
        ]
    )
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert read_tracks(out, n_frames=STEPS).equals(episode["tracks"])
    if fmt == "mot":  # the MOT det.txt carries the truth ids: every metric, e1 / e2 included
        assert captured.out.strip() == format_metrics(gym_metrics)
        assert gym_metrics["id_switches"] > 0 and gym_metrics["e1"] > 0  # a test with errors to get right
    else:  # no truth ids in the wide file: the same figures without e1 / e2, and a note
        expected = {
            k: v for k, v in gym_metrics.items() if k not in ("e1", "e2", "e_mean", "n_tracks", "n_particles")
        }
        assert captured.out.strip() == format_metrics(expected)
        assert "e1, e2, e_mean skipped" in captured.err


def test_run_agent_equals_the_gym_loop_with_covariances(recorded):
    _, episode, _, spec = recorded
    agent = make_agent("gnn", predictor="kf-cv")
    tracks = run_agent(agent, episode["detections"], spec, seed=5, covariance=True)
    assert tracks.equals(episode["tracks"])
    assert tracks.cov is not None and tracks.cov.shape == (len(tracks), 2, 2)
    assert np.all(np.linalg.eigvalsh(tracks.cov) > 0)
    np.testing.assert_array_equal(tracks.detection, episode["tracks"].detection)


def test_run_agent_takes_plain_arrays_and_agents_without_covariances():
    frames = [np.array([[0.1, 0.1], [0.5, 0.5]]), np.zeros((0, 2)), np.array([[0.2, 0.1]])]
    spec = SensorSpec(0.01, 2, 1e-3, 1.0, 0.0, (0.0, 0.0), (1.0, 1.0), 4, 8)
    tracks = run_agent("detections", frames, spec, covariance=True)
    assert tracks.cov is None and tracks.n_frames == 3
    np.testing.assert_array_equal(tracks.frame, [0, 0, 2])
    np.testing.assert_array_equal(tracks.positions, np.concatenate(frames).astype(np.float32))
    with pytest.raises(ValueError, match="frame 0 holds 2 detections, more than max_detections=1"):
        run_agent("detections", frames, SensorSpec(0.01, 2, 1e-3, 1.0, 0.0, (0.0, 0.0), (1.0, 1.0), 1, 8))


def test_pack_observation_is_the_observation_an_agent_reads():
    spec = SensorSpec(0.01, 2, 1e-3, 1.0, 0.0, (0.0, 0.0), (1.0, 1.0), 5, 8)
    z = np.array([[0.1, 0.2], [0.3, 0.4]])
    obs = pack_observation(z, spec)
    assert obs["detections"].dtype == np.float32 and obs["mask"].tolist() == [1, 1, 0, 0, 0]
    rows, back = check_observation(obs, spec)
    np.testing.assert_array_equal(rows, [0, 1])
    np.testing.assert_array_equal(back, z.astype(np.float32))
    with pytest.raises(ValueError, match="6 detections do not fit an observation of max_detections=5"):
        pack_observation(np.zeros((6, 2)), spec)
    with pytest.raises(ValueError, match=r"rows \[1\] hold NaN"):
        pack_observation(np.array([[0.0, 0.0], [np.nan, 0.0]]), spec)


def test_track_run_long_output_holds_covariances(tmp_path, capsys):
    det = tmp_path / "d.csv"
    det.write_text("frame,count,x0,y0,x1,y1\n0,2,0.1,0.1,0.5,0.5\n1,2,0.11,0.1,0.5,0.51\n2,1,0.12,0.1,,\n")
    assert main([str(det), "--dt=0.01", "--declared-noise-std=0.001", f"--out={tmp_path / 't.csv'}",
                 "--format=long", "--covariance", "--no-progress"]) == 0  # fmt: skip
    tracks = read_tracks(tmp_path / "t.csv")
    assert tracks.cov is not None and len(tracks) >= 5 and tracks.n_frames == 3


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--out=t.txt"], "dt .* is not given"),
        (["--dt=0.01", "--out=t.txt", "--format=mot", "--covariance"], "--covariance needs --format long"),
        (["--dt=0.01", "--out=t.txt", "--metrics"], "--metrics needs --gt"),
        (["--dt=0.01", "--out=t.txt", "--agent=detections", "--predictor=kf-cv"], "takes no predictor"),
    ],
)
def test_track_run_errors_are_one_line_with_exit_code_2(tmp_path, capsys, monkeypatch, argv, message):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "d.csv").write_text("0,1,0.1,0.1\n1,1,0.2,0.1\n")
    assert main(["d.csv", "--no-progress", *argv]) == 2
    err = capsys.readouterr().err
    assert (
        err.startswith("track run: error:") and re.search(message, err) and not (tmp_path / "t.txt").exists()
    )


def test_a_bad_detection_file_is_named_by_track_run(tmp_path, capsys):
    det = tmp_path / "d.csv"
    det.write_text("0,1,0.1,0.1\n1,1,oops,0.1\n")
    assert main([str(det), "--dt=0.01", f"--out={tmp_path / 't.txt'}", "--no-progress"]) == 2
    assert f"{det}: row 2, column index 2 holds text 'oops'" in capsys.readouterr().err


def test_streams_from_frames_keep_order():
    d = Detections.from_frames([np.array([[1.0, 2.0]]), np.zeros((0, 2))])
    assert d.n_frames == 2 and d.counts.tolist() == [1, 0]


def test_the_example_records_tracks_and_scores_a_detection_file(tmp_path, capsys):
    import importlib.util

    path = Path(__file__).resolve().parents[3] / "examples" / "track_detection_file.py"
    spec = importlib.util.spec_from_file_location("track_detection_file", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    metrics = module.main(["--out", str(tmp_path), "--steps", "60"])
    assert metrics["mota"] > 0.5 and "e1" in metrics
    assert (tmp_path / "tracks.txt").stat().st_size > 1000
    # docs/track_run.md's second command: the wide detections, dt from the time column
    episode = tmp_path / "episode-000"
    argv = [
        str(episode / "det.csv"),
        "--time-column=time",
        "--declared-noise-std=1e-4",
        f"--out={tmp_path / 'w.csv'}",
    ]
    assert main([*argv, "--format=wide", "--no-progress"]) == 0
    assert read_tracks(tmp_path / "w.csv").n_frames == 60


def test_a_block_of_the_loop_holds_a_bounded_number_of_rows():
    from agents.files.loop import BLOCK_ROWS, MAX_BLOCK_FRAMES, block_frames

    def spec(max_detections: int, max_tracks: int) -> SensorSpec:
        return SensorSpec(0.01, 2, 1e-3, 1.0, 0.0, (0.0, 0.0), (1.0, 1.0), max_detections, max_tracks)

    assert block_frames(spec(4, 8)) == MAX_BLOCK_FRAMES
    assert block_frames(spec(1000, 2000)) == BLOCK_ROWS // 2000
    assert block_frames(spec(100_000, 16)) == 1  # an observation as large as a report counts
    assert block_frames(spec(100_000, 300_000)) == 1  # 10^5 detections a frame: one frame a block


def test_the_loop_gives_the_same_tracks_whatever_its_blocks(monkeypatch):
    import agents.files.loop as loop

    rng = np.random.default_rng(2)
    frames = [rng.uniform(0, 1, (rng.integers(0, 30), 2)) for _ in range(50)]
    spec = SensorSpec(0.01, 2, 1e-3, 1.0, 0.0, (0.0, 0.0), (1.0, 1.0), 40, 200)
    whole = run_agent(make_agent("gnn", predictor="kf-cv"), frames, spec, seed=0, covariance=True)
    monkeypatch.setattr(loop, "BLOCK_ROWS", 1)  # one frame a block
    split = run_agent(make_agent("gnn", predictor="kf-cv"), frames, spec, seed=0, covariance=True)
    assert split.equals(whole) and np.array_equal(split.detection, whole.detection)


def test_more_detections_than_report_rows_grow_the_report_and_drop_nothing():
    frames = [np.arange(2 * k, dtype=float).reshape(k, 2) / 100 for k in (3, 12, 5)]
    spec = SensorSpec(0.01, 2, 1e-3, 1.0, 0.0, (0.0, 0.0), (1.0, 1.0), 12, 4)
    with pytest.warns(
        RuntimeWarning, match=r"12 live tracks did not fit a report of max_tracks=4; the reports grew"
    ):
        tracks = run_agent("detections", frames, spec)
    np.testing.assert_array_equal(tracks.positions, np.concatenate(frames).astype(np.float32))
    np.testing.assert_array_equal(tracks.frame, np.repeat([0, 1, 2], [3, 12, 5]))
    assert len(np.unique(tracks.ids)) == 20


def test_track_run_writes_in_chunks_the_bytes_of_one_pass(tmp_path, monkeypatch):
    import track_envs.io.csv_parser as csv_parser
    import track_envs.io.detections as detection_io
    import track_envs.io.tracks as track_io
    from track_envs.io.detections import write_mot_detections

    rng = np.random.default_rng(7)
    frames = [np.cumsum(rng.uniform(0.05, 0.1, (8, 2)), axis=0) + 0.01 * t for t in range(25)]
    write_mot_detections(tmp_path / "det.txt", Detections.from_frames(frames), box_size=0.02)
    argv = [str(tmp_path / "det.txt"), "--dt=0.01", "--declared-noise-std=0.002", "--no-progress"]
    for fmt in ("mot", "long", "wide"):
        assert main([*argv, f"--format={fmt}", f"--out={tmp_path / ('one.' + fmt)}"]) == 0
    for module in (csv_parser, detection_io, track_io):
        monkeypatch.setattr(module, "CHUNK_ROWS", 3, raising=False)
    monkeypatch.setattr(csv_parser, "PARSE_CELLS", 20)
    for fmt in ("mot", "long", "wide"):
        assert main([*argv, f"--format={fmt}", f"--out={tmp_path / ('t.' + fmt)}"]) == 0
        assert (tmp_path / f"t.{fmt}").read_bytes() == (tmp_path / f"one.{fmt}").read_bytes(), fmt


def test_a_grown_report_gives_the_tracks_of_a_large_enough_one_in_one_run():
    from track_envs.contracts.report import ReportOverflowError, pack_report

    rng = np.random.default_rng(4)
    frames = [rng.uniform(0, 1, (rng.integers(5, 30), 2)) for _ in range(40)]
    small = SensorSpec(0.01, 2, 1e-3, 1.0, 0.0, (0.0, 0.0), (1.0, 1.0), 30, 8)
    large = SensorSpec(0.01, 2, 1e-3, 1.0, 0.0, (0.0, 0.0), (1.0, 1.0), 30, 400)
    reference = run_agent(make_agent("gnn", predictor="kf-cv"), frames, large, covariance=True)
    agent = make_agent("gnn", predictor="kf-cv")
    resets = []
    reset = agent.reset
    agent.reset = lambda spec, seed=None: (resets.append(spec.max_tracks), reset(spec, seed=seed))[1]
    with pytest.warns(RuntimeWarning, match=r"the reports grew to hold them \(as a run with max_tracks=\d+"):
        grown = run_agent(agent, frames, small, covariance=True)
    assert resets == [8]  # one run, not one per doubling of the report
    assert grown.equals(reference) and np.array_equal(grown.detection, reference.detection)
    with pytest.raises(ReportOverflowError, match="do not fit a report of max_tracks=8"):
        run_agent(make_agent("gnn", predictor="kf-cv"), frames, small, grow=False)
    with pytest.raises(ReportOverflowError):  # an environment's report never grows
        pack_report(np.arange(3), np.zeros((3, 2)), np.zeros(3, np.int64), 2)


def test_the_progress_bar_is_shown_on_a_terminal_only(monkeypatch):
    import argparse
    import sys

    from track_apps.cli.run import show_progress

    class Terminal:
        def __init__(self, tty: bool) -> None:
            self.tty = tty

        def isatty(self) -> bool:
            return self.tty

    for tty, hidden, shown in ((True, False, True), (True, True, False), (False, False, False)):
        monkeypatch.setattr(sys, "stderr", Terminal(tty))
        assert show_progress(argparse.Namespace(no_progress=hidden)) is shown


def test_ids_are_counted_by_sorting_as_numpy_unique_counts_them():
    from agents.sensor_model.diagnostics import count_distinct

    rng = np.random.default_rng(1)
    for ids in (np.zeros(0, np.int64), np.array([7]), rng.integers(0, 50, 1000), rng.permutation(10**5)):
        assert count_distinct(ids) == len(np.unique(ids))


# ------------------------------------------------------------------------- inputs you can trust


def small_det(path: Path, seed: int = 2) -> Path:
    """Five points moving right by 0.02 a frame for 30 frames, a little noise, as a MOT det.txt."""
    from track_envs.io.detections import write_mot_detections

    rng = np.random.default_rng(seed)
    start = rng.uniform(0, 1, (5, 2))
    step = np.array([0.02, 0.0])
    frames = [start + step * t + rng.normal(0, 1e-3, (5, 2)) for t in range(30)]
    write_mot_detections(path, Detections.from_frames(frames))
    return path


@pytest.mark.parametrize("out", ["t.txt", "t.csv", "t.zip"])
def test_a_run_scored_against_its_own_output_scores_perfectly(tmp_path, capsys, out):
    """The format follows --out's suffix (.txt mot, .csv long, .zip wide), so the file reads back
    as --gt in the layout it was written in: MOTA, IDF1 and HOTA 1."""
    det = small_det(tmp_path / "det.txt")
    argv = [str(det), "--dt=0.01", "--declared-noise-std=0.002", "--no-progress"]
    assert main([*argv, f"--out={tmp_path / out}"]) == 0
    assert f"({output_format(out)}, written" in capsys.readouterr().err
    assert main([*argv, f"--out={tmp_path / 'again.txt'}", f"--gt={tmp_path / out}", "--metrics"]) == 0
    table = dict(line.split() for line in capsys.readouterr().out.splitlines()[2:])
    assert float(table["mota"]) == 1.0 and float(table["idf1"]) == 1.0 and float(table["hota"]) == 1.0


def test_a_format_the_suffix_contradicts_is_an_error_before_reading(tmp_path, capsys):
    assert main(["missing.txt", "--dt=0.01", f"--out={tmp_path / 't.csv'}", "--format=mot"]) == 2
    err = capsys.readouterr().err
    assert "track run: error: " in err and "a .csv track file is read back as long or wide, not mot" in err


@pytest.mark.parametrize(
    ("out", "flags", "said"),
    [
        ("/proc/track.txt", [], "--out /proc/track.txt: cannot write"),
        (
            "{tmp}/t.txt",
            ["--sorting-line=9", "--sorting-out=/proc/s.csv"],
            "--sorting-out /proc/s.csv: cannot write",
        ),
    ],
)
def test_an_unwritable_output_fails_before_anything_is_read(tmp_path, capsys, out, flags, said):
    """The detections file does not exist: the --out error comes first, before reading it."""
    out = out.format(tmp=tmp_path)
    assert main([str(tmp_path / "missing.txt"), "--dt=0.01", f"--out={out}", *flags]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"track run: error: {said}") and "Traceback" not in err


def test_ground_truth_is_checked_before_tracking(tmp_path, capsys):
    det = small_det(tmp_path / "det.txt")
    gt = tmp_path / "gt.txt"
    gt.write_text("1,0,0.5,0.5,0,0,1,1,1\n2,0,1e300,0.5,0,0,1,1,1\n")
    out = tmp_path / "t.txt"
    assert main([str(det), "--dt=0.01", f"--out={out}", f"--gt={gt}", "--metrics", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert f"track run: error: {gt}: row 2, column index 2 (bb_left) holds 1e+300" in err
    assert "sensor model estimate" not in err and not out.exists()


def test_repeated_detections_are_warned_about_and_tracked_once(tmp_path, capsys):
    det = small_det(tmp_path / "det.txt")
    argv = ["--dt=0.01", "--declared-noise-std=0.002", "--no-progress"]
    assert main([str(det), *argv, f"--out={tmp_path / 'once.txt'}"]) == 0
    rows = det.read_text().splitlines()
    twice = tmp_path / "twice.txt"
    twice.write_text("\n".join(rows[:50] + rows[20:30] + rows[50:]) + "\n")
    assert main([str(twice), *argv, f"--out={tmp_path / 'twice-tracks.txt'}"]) == 0
    err = capsys.readouterr().err
    assert "track run: warning: " in err and "10 detections repeat an earlier one of their frame" in err
    assert (tmp_path / "twice-tracks.txt").read_bytes() == (tmp_path / "once.txt").read_bytes()


def test_a_write_that_fails_keeps_the_old_file_and_names_it(tmp_path):
    """A file-size limit (as a full disk) while --out is written: the old file stays, one error
    line names the file and the cause, exit code 2."""
    det = small_det(tmp_path / "det.txt")
    out = tmp_path / "t.txt"
    out.write_text("old\n")
    code = (
        "import resource, signal, sys\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "from track_apps.cli.run import main\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (2000, 2000))\n"
        "sys.exit(main(sys.argv[1:]))\n"
    )
    argv = [str(det), "--dt=0.01", "--declared-noise-std=0.002", f"--out={out}", "--no-progress"]
    result = subprocess.run(
        [sys.executable, "-c", code, *argv],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[3])},
        check=False,
    )
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert f"track run: error: {out}: cannot write: File too large (EFBIG)" in result.stderr
    assert out.read_text() == "old\n" and sorted(p.name for p in tmp_path.iterdir()) == ["det.txt", "t.txt"]
