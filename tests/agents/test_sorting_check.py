"""Sorting predictions from recordings: run_agent(sorting_line=), DetectionReplay-v0's nozzle bar,
the truth-free check on streams whose crossings are known analytically, and track run's flags."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401  (registers the envs)
from agents import make_agent
from agents.files.points import run_agent
from agents.sorting.check import check_sorting, cut_stream
from track_apps.cli.run import main
from track_envs.envs.detection_replay import sample_detections_path
from track_envs.io.crossings import read_crossings
from track_envs.io.detections import write_wide_detections
from track_envs.values.detections import Detections, detection_sensor_spec

DT = 0.01
VX = 1.0  # m/s: 1 cm per frame
WINDOW = 0.4


def lines_stream(n_frames: int = 70) -> tuple[Detections, np.ndarray, np.ndarray, np.ndarray]:
    """Particles on straight lines at constant velocity ``(VX, vy_i)``, entering at ``x = 0`` at
    staggered times, seen while ``0 <= x <= WINDOW``, 1.3 cm apart across the belt: ``(stream,
    start times, y at x = 0, vy)``."""
    y0 = 0.01 + 0.013 * np.arange(12)
    vy = 0.02 * np.sin(np.arange(12))
    start = 0.0037 * np.arange(12) + DT * (np.arange(12) % 3) * 7  # enter between frames
    frames = []
    for k in range(n_frames):
        t = k * DT - start
        x = VX * t
        seen = (x >= 0) & (x <= WINDOW)
        frames.append(np.stack([x[seen], (y0 + vy * t)[seen]], axis=1))
    return Detections.from_frames(frames), start, y0, vy


def exact_crossings(line: float, start, y0, vy) -> tuple[np.ndarray, np.ndarray]:
    """``t_c = start + line / VX``, ``y_c = y0 + vy (t_c − start)``."""
    t = start + line / VX
    return t, y0 + vy * (t - start)


@pytest.fixture(scope="module")
def lines():
    stream, start, y0, vy = lines_stream()
    spec = detection_sensor_spec(stream, dt=DT, measurement_noise_std=1e-6)
    return stream, spec, start, y0, vy


# --------------------------------------------------------------------------------- run_agent


def test_run_agent_returns_each_tracks_predicted_crossing(lines):
    stream, spec, start, y0, vy = lines
    line = spec.region_high[0] + 0.05
    tracks, made = run_agent(make_agent("gnn", predictor="kf-cv"), stream, spec, sorting_line=line)
    alone = run_agent(make_agent("gnn", predictor="kf-cv"), stream, spec)
    assert tracks.equals(alone)  # the sorting line changes no track
    assert made.line == line
    assert len(np.unique(made.ids)) == len(made)  # one prediction per track: when it is let go
    assert np.all(np.diff(made.frame) >= 0)
    # every particle leaves the window within the stream: 12 tracks, 12 predictions
    assert len(np.unique(tracks.ids)) == 12 and len(made) == 12
    order = np.argsort(made.y)  # match by lateral position
    t_c, y_c = exact_crossings(line, start, y0, vy)
    truth = np.argsort(y_c)
    np.testing.assert_allclose(made.t[order], t_c[truth], atol=1e-5)
    np.testing.assert_allclose(made.y[order], y_c[truth], atol=1e-5)
    assert np.all(made.cov[:, [0, 1], [0, 1]] > 0)


def test_run_agent_sorting_line_errors(lines):
    stream, spec, *_ = lines
    with pytest.raises(ValueError, match=r"sorting_line must be .*> region x_high = 0\.40.*got 0\.3"):
        run_agent("gnn", stream, spec, sorting_line=0.3)
    quiet = make_agent("gnn", predictor="kf-cv", predict_sorting=False)
    with pytest.raises(
        ValueError, match=r"\(GnnAgent\) reports no sorting predictions .* predict_sorting=False"
    ):
        run_agent(quiet, stream, spec, sorting_line=0.5)


# ------------------------------------------------------------------------ DetectionReplay-v0


def test_detection_replay_nozzle_offset_sets_the_sorting_line_like_belt_replay():
    plain = gym.make("DetectionReplay-v0").unwrapped
    barred = gym.make("DetectionReplay-v0", nozzle_offset=0.05).unwrapped
    assert plain.sensor_spec.sorting_line is None
    assert barred.sensor_spec.sorting_line == pytest.approx(plain.sensor_spec.region_high[0] + 0.05, abs=0)
    given = gym.make("DetectionReplay-v0", region=((0.0, 0.0), (0.3, 0.18)), nozzle_offset=0.1).unwrapped
    assert given.sensor_spec.sorting_line == pytest.approx(0.4)
    a, _ = plain.reset(seed=3)
    b, _ = barred.reset(seed=3)
    for _ in range(3):  # the same observations
        np.testing.assert_array_equal(a["detections"], b["detections"])
        report = plain.action_space.sample() | {"mask": np.zeros(plain.sensor_spec.max_tracks, np.int8)}
        a, *_ = plain.step(report)
        b, *_ = barred.step(report)


def test_detection_replay_gnn_reports_crossings_in_the_gym_loop():
    env = gym.make("DetectionReplay-v0", nozzle_offset=0.05)
    agent = make_agent("gnn", predictor="kf-ca")
    obs, _ = env.reset(seed=0)
    agent.reset(env.unwrapped.sensor_spec, seed=0)
    predicted = 0
    for _ in range(40):
        report = agent.act(obs)
        predicted += int(report["sorting_mask"].sum())
        obs, *_ = env.step(report)
    assert predicted > 10


@pytest.mark.parametrize("bad", [0, -0.01, float("nan"), "far"])
def test_detection_replay_bad_nozzle_offset_is_named(bad):
    with pytest.raises(ValueError, match=rf"nozzle_offset must be .*got {re.escape(repr(bad))}"):
        gym.make("DetectionReplay-v0", nozzle_offset=bad)


# ------------------------------------------------------------------------- the truth-free check


def test_cut_stream_keeps_every_frame_and_the_upstream_detections(lines):
    stream, *_ = lines
    cut, kept = cut_stream(stream, 0.2)
    assert cut.n_frames == stream.n_frames
    np.testing.assert_array_equal(cut.points, stream.points[stream.points[:, 0] <= 0.2])
    np.testing.assert_array_equal(stream.points[kept], cut.points)
    for k in (0, 10, 40, 69):
        np.testing.assert_array_equal(cut.frame(k), stream.frame(k)[stream.frame(k)[:, 0] <= 0.2])


def test_check_on_exact_lines_hits_every_particle(lines):
    stream, spec, start, y0, vy = lines
    result = check_sorting(make_agent("gnn", predictor="kf-cv"), stream, spec, 0.3, 0.2)
    t_c, y_c = exact_crossings(0.3, start, y0, vy)
    # the observed crossings are the analytic ones (linear interpolation of linear motion)
    order = np.argsort(result.observed.y)
    np.testing.assert_allclose(result.observed.t[order], t_c[np.argsort(y_c)], atol=1e-12)
    np.testing.assert_allclose(result.observed.y[order], np.sort(y_c), atol=1e-12)
    score = result.score
    assert (score.crossings, score.predicted, score.hits, score.hit_rate) == (12, 12, 12, 1.0)
    assert (score.never_crossed, score.late) == (0, 0)
    assert np.abs(score.time_error).max() < 1e-6
    assert np.abs(score.lateral_error).max() < 1e-6
    assert np.all((result.distance > 0.1 - 1e-12) & (result.distance < 0.1 + VX * DT))
    # the written rows carry the true crossing of each prediction
    np.testing.assert_allclose(result.predictions.extra["t_true"], result.predictions.t, atol=1e-6)


def test_tight_tolerances_turn_hits_into_misses(lines):
    stream, spec, *_ = lines
    tight = check_sorting(
        make_agent("gnn", predictor="kf-cv"),
        stream,
        spec,
        0.3,
        0.2,
        lateral_tolerance=1e-12,
        time_tolerance=1e-12,
    )
    assert tight.score.predicted == 12 and tight.score.hits < 12


@pytest.mark.parametrize(
    ("line", "cut", "message"),
    [
        (0.5, 0.2, r"line=0.5 lies outside the camera window: x must be in \(-0.008, 0.408\)"),
        (0.3, -0.1, r"cut=-0.1 lies outside the camera window"),
        (0.2, 0.3, r"cut=0.3 must lie upstream of line=0.2 \(cut < line\)"),
        (0.3, 0.3, r"cut=0.3 must lie upstream of line=0.3"),
        ("x", 0.3, r"line must be a number .* got 'x'"),
    ],
)
def test_check_bad_line_or_cut_is_named(lines, line, cut, message):
    stream, spec, *_ = lines
    with pytest.raises(ValueError, match=message):
        check_sorting("gnn", stream, spec, line, cut)


# ----------------------------------------------------------------------------------- track run


@pytest.fixture(scope="module")
def lines_file(tmp_path_factory, lines) -> Path:
    stream, *_ = lines
    path = tmp_path_factory.mktemp("lines") / "lines.csv"
    times = np.arange(stream.n_frames) * DT
    write_wide_detections(path, Detections(stream.points, stream.offsets, times=times))
    return path


def test_track_run_sorting_line_writes_the_predictions(lines_file, tmp_path, capsys):
    out = tmp_path / "tracks.csv"
    args = [str(lines_file), "--time-column", "time", "--declared-noise-std", "1e-6", "--out", str(out)]
    assert main([*args, "--sorting-line", "0.45", "--no-progress"]) == 0
    made = read_crossings(tmp_path / "tracks.sorting.csv")
    assert len(made) == 12 and np.all(made.t > 0.449)
    assert "12 predicted crossings of x = 0.45 for 12 track ids" in capsys.readouterr().err
    assert (
        main([*args, "--sorting-line", "0.45", "--sorting-out", str(tmp_path / "p.csv"), "--no-progress"])
        == 0
    )
    assert read_crossings(tmp_path / "p.csv").equals(made)


def test_track_run_sorting_check_prints_and_writes(lines_file, tmp_path, capsys):
    out = tmp_path / "tracks.txt"
    args = [str(lines_file), "--time-column", "time", "--declared-noise-std", "1e-6", "--out", str(out)]
    assert main([*args, "--sorting-check", "line=0.3,cut=0.2,time_tolerance=1e-3", "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert (
        "sorting check: line x = 0.3, predicted from x <= 0.2; hit: |dt| <= 1 ms and |dy| <= 0.0015 m"
        in printed
    )
    assert re.search(r"hit_rate\s+1\n", printed)
    scored = read_crossings(tmp_path / "tracks.sorting-check.csv")
    assert list(scored.extra) == ["track", "x_seen", "t_true", "y_true"]
    assert len(scored) == 12


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (
            ["--sorting-line", "0.3"],
            r"--sorting-line 0.3 must lie downstream of the camera window, past its x_high = 0.408",
        ),
        (["--sorting-check", "line=0.3"], r"--sorting-check needs cut \(e.g. line=0.35,cut=0.3\)"),
        (
            ["--sorting-check", "line=0.3,cut=0.2,nozzle=1"],
            r"--sorting-check: unknown name\(s\) \['nozzle'\]; valid names",
        ),
        (
            ["--sorting-check", "line=0.6,cut=0.2"],
            r"--sorting-check: line=0.6 lies outside the camera window",
        ),
        (["--sorting-check", "line=0.2,cut=0.3"], r"--sorting-check: cut=0.3 must lie upstream of line=0.2"),
        (
            ["--sorting-check", "line=0.3,cut=0.2,lateral_tolerance=-1"],
            r"--sorting-check: lateral_tolerance must be a finite number > 0, got -1",
        ),
        (
            ["--sorting-out", "x.csv"],
            r"--sorting-out needs exactly one of --sorting-line and --sorting-check",
        ),
    ],
)
def test_track_run_bad_sorting_flags_are_named(lines_file, tmp_path, capsys, flags, message):
    out = tmp_path / "tracks.txt"
    assert main([str(lines_file), "--time-column", "time", "--out", str(out), *flags]) == 2
    assert re.search(message, capsys.readouterr().err)
    assert not out.exists()  # checked before tracking


# ------------------------------------------------------------------------------- the README


def readme_sorting_command() -> str:
    """The command of docs/track_run.md's "Sorting predictions from a recording" subsection."""
    text = (Path(__file__).parents[2] / "docs" / "track_run.md").read_text()
    section = text.split("### Sorting predictions from a recording", 1)[1].split("\n### ", 1)[0]
    block = section.split("```bash\n", 1)[1].split("```", 1)[0]
    return " ".join(line.rstrip("\\").strip() for line in block.splitlines() if line.strip())


def test_readme_sorting_command_runs_on_the_shipped_sample(tmp_path, capsys, monkeypatch):
    words = shlex.split(readme_sorting_command())
    assert words[:3] == ["track", "run", "track_envs/data/detections_sample.zip"]
    words[2] = sample_detections_path()
    out = words.index("--out") + 1
    words[out] = str(tmp_path / Path(words[out]).name)
    assert main(words[2:]) == 0
    printed = capsys.readouterr().out
    # the figures the page quotes are the ones printed
    section = (
        (Path(__file__).parents[2] / "docs" / "track_run.md")
        .read_text()
        .split("### Sorting predictions", 1)[1]
    )
    crossings, hit_rate = re.search(r"`crossings (\d+)`, `hit_rate ([\d.]+)`", section).groups()
    assert re.search(rf"\ncrossings\s+{crossings}\n", printed)
    printed_rate = float(re.search(r"hit_rate\s+(\S+)", printed).group(1))
    assert f"{printed_rate:.3f}" == hit_rate
    assert (tmp_path / (Path(words[out]).stem + ".sorting-check.csv")).exists()


def test_the_figure_script_runs_and_writes_its_png(tmp_path, capsys):
    import importlib.util

    path = Path(__file__).parents[2] / "examples" / "sorting_check_figure.py"
    spec = importlib.util.spec_from_file_location("sorting_check_figure", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = module.main(["--predictors", "kf-cv", "--distances", "0.05", "--out", str(tmp_path)])
    assert out["rows"][0]["predictor"] == "kf-cv" and out["rows"][0]["crossings"] > 250
    assert 0.5 < out["rows"][0]["hit_rate"] <= 1.0
    assert (tmp_path / "sorting_check.png").stat().st_size > 10_000
    assert "| kf-cv |" in capsys.readouterr().out
