"""The sensor model estimate: the noise estimator on streams of known R and q, unit invariance, warnings,
the report that grows, the sidecar and the flags that override each estimate."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import numpy as np
import pytest

from agents import make_agent
from agents.files.points import run_agent
from agents.sensor_model import estimate_sensor_model, run_warnings
from agents.sensor_model.estimate import detection_labels, live_track_bound
from agents.sensor_model.noise import design_matrix, estimate_noise
from predictors.kalman.predictor import _kinematic_model
from track_apps.cli import main as track_main
from track_envs.io.detections import write_wide_detections
from track_envs.metrics.track_scoring import score_tracks
from track_envs.values.detections import Detections, detection_sensor_spec

#: Pixels per metre of the pixel versions (a 56 µm pixel, as on a sorter camera).
PIXELS = 1 / 5.6e-5


def labelled_tracks(rng, order, q, r, dt, n_tracks=200, length=60):
    """``n_tracks`` independent tracks of the ``order``-fold integrator (white noise of intensity
    q) measured with noise variance r: points (N, 2), frames, labels."""
    F, Q, H = _kinematic_model(order, 2, dt, q)
    L = np.linalg.cholesky(Q)
    x = np.zeros((n_tracks, 2 * order))
    x[:, :2] = rng.uniform(0, 1, (n_tracks, 2))
    if order > 1:
        x[:, 2:4] = rng.normal(0, 1, (n_tracks, 2))
    start = rng.integers(0, 100, n_tracks)
    points, frames = [], []
    for t in range(length):
        points.append(x @ H.T + rng.normal(0, np.sqrt(r), (n_tracks, 2)))
        frames.append(start + t)
        x = x @ F.T + rng.normal(size=x.shape) @ L.T
    labels = np.tile(np.arange(n_tracks), length)
    return np.concatenate(points), np.concatenate(frames), labels


def belt_stream(rng, *, frames=400, dt=0.005, sigma=5e-5, q=0.5, rate=0.6, speed=1.0):
    """A belt-like stream in metres: targets enter at x = 0 (Poisson, ``rate`` a frame) with
    velocity ≈ (speed, 0), move with white-noise acceleration ``q`` and leave at x = 0.4; each is
    detected every frame with noise ``sigma``. Returns the detections (with truth ids)."""
    F, Q, _ = _kinematic_model(2, 2, dt, q)
    L = np.linalg.cholesky(Q)
    state = np.zeros((0, 4))
    ids = np.zeros(0, np.int64)
    next_id = 0
    per_frame, per_ids = [], []
    for _ in range(frames):
        k = rng.poisson(rate)
        born = np.zeros((k, 4))
        born[:, 1] = rng.uniform(0.01, 0.19, k)
        born[:, 2] = speed * rng.normal(1.0, 0.05, k)
        born[:, 3] = rng.normal(0, 0.01, k)
        state = np.concatenate([state, born])
        ids = np.concatenate([ids, np.arange(next_id, next_id + k)])
        next_id += k
        inside = state[:, 0] <= 0.4
        state, ids = state[inside], ids[inside]
        per_frame.append(state[:, :2] + rng.normal(0, sigma, (len(state), 2)))
        per_ids.append(ids)
        state = state @ F.T + rng.normal(size=state.shape) @ L.T
    return Detections.from_frames(per_frame, per_ids)


def scaled(detections: Detections, k: float) -> Detections:
    return Detections(detections.points * k, detections.offsets, detections.ids)


# -- the estimator -------------------------------------------------------------------------------
def test_design_matrix_is_the_autocovariance_of_the_differences():
    # cv: c0 = 6 r + 2/3 q dt³, c1 = -4 r + q dt³/6, c2 = r
    np.testing.assert_allclose(design_matrix(2), [[6, 2 / 3], [-4, 1 / 6], [1, 0]])
    np.testing.assert_allclose(design_matrix(1), [[2, 1], [-1, 0]])
    np.testing.assert_allclose(design_matrix(3)[:, 1], [11 / 20, 13 / 60, 1 / 120, 0])


@pytest.mark.parametrize(
    ("order", "q", "r", "r_tol", "q_tol"),
    [
        (2, 1.0, 1e-6, 0.1, 0.2),  # noise and process alike: r ±2.4 %, q ±10 % over 10 seeds
        (2, 1.0, 1e-8, 0.15, 0.1),  # process dominates: r ±9 %, q ±2 %
        (3, 300.0, 1e-8, 0.1, 0.2),  # constant acceleration: r ±2.4 %, q ±7 %
        (1, 0.02, 1e-5, 0.35, 0.1),  # random walk, process dominates: r ±24 %, q ±3 %
    ],
)
def test_the_estimator_finds_r_and_q_of_a_known_stream_in_two_unit_systems(order, q, r, r_tol, q_tol):
    points, frames, labels = labelled_tracks(np.random.default_rng(0), order, q, r, 0.01)
    metres = estimate_noise(points, frames, labels, 0.01, order)
    assert metres is not None
    # measured: r within 2 % (cv, ca) and 12 % (random walk), q within 3 % (cv), 6 % (ca)
    assert metres.r == pytest.approx(r, rel=0.15)
    assert metres.q == pytest.approx(q, rel=q_tol)
    millimetres = estimate_noise(points * 1000, frames, labels, 0.01, order)
    assert millimetres is not None
    assert millimetres.r == pytest.approx(metres.r * 1e6, rel=1e-9)
    assert millimetres.q == pytest.approx(metres.q * 1e6, rel=1e-9)


def test_the_estimator_drops_wrong_associations():
    rng = np.random.default_rng(1)
    points, frames, labels = labelled_tracks(rng, 2, 1.0, 1e-6, 0.01)
    clean = estimate_noise(points, frames, labels, 0.01, 2)
    jumped = points.copy()
    jumped[rng.choice(len(points), 40, replace=False)] += 0.05  # 40 detections of someone else
    dirty = estimate_noise(jumped, frames, labels, 0.01, 2)
    assert clean is not None and dirty is not None and dirty.n_outliers >= 40
    assert dirty.r == pytest.approx(clean.r, rel=0.1)


# -- the estimate ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def belt():
    return belt_stream(np.random.default_rng(3))


@pytest.fixture(scope="module")
def estimated(belt):
    spec = detection_sensor_spec(belt, dt=0.005)
    cal = estimate_sensor_model(belt, spec, predictor="kf-cv")
    agent = make_agent("gnn", predictor="kf-cv", **cal.agent_kwargs())
    return cal, run_agent(agent, belt, cal.sensor_spec(spec))


def test_the_estimate_finds_the_belts_noise_and_speed(belt, estimated):
    cal, tracks = estimated
    assert cal.noise_std == pytest.approx(5e-5, rel=0.1)  # measured: 3 %
    assert cal.q == pytest.approx(0.5, rel=0.5)
    assert cal.velocity_mean[0] == pytest.approx(1.0, rel=0.05)
    assert cal.sources["noise_std"] == "estimated"
    truth_ids = len(np.unique(belt.ids))
    assert len(np.unique(tracks.ids)) <= 1.1 * truth_ids
    assert run_warnings(tracks, len(belt)) == []


@pytest.mark.parametrize("k", [PIXELS, 1000.0])
def test_pixels_and_metres_give_the_same_tracks(belt, estimated, k):
    cal, tracks = estimated
    other = scaled(belt, k)
    spec = detection_sensor_spec(other, dt=0.005)
    cal_k = estimate_sensor_model(other, spec, predictor="kf-cv")
    assert cal_k.noise_std == pytest.approx(cal.noise_std * k, rel=1e-6)
    assert cal_k.q == pytest.approx(cal.q * k * k, rel=1e-6)
    assert cal_k.max_misses == cal.max_misses
    tracks_k = run_agent(
        make_agent("gnn", predictor="kf-cv", **cal_k.agent_kwargs()), other, cal_k.sensor_spec(spec)
    )
    np.testing.assert_array_equal(detection_labels(other, tracks_k), detection_labels(belt, tracks))
    np.testing.assert_array_equal(tracks_k.ids, tracks.ids)


def test_given_settings_are_kept(belt):
    spec = detection_sensor_spec(belt, dt=0.005)
    cal = estimate_sensor_model(
        belt, spec, predictor="kf-ca", noise_std=1e-4, q=7.0, agent_kwargs={"max_misses": 4}
    )
    assert (cal.noise_std, cal.q, cal.max_misses) == (1e-4, 7.0, 4)
    assert cal.sources["noise_std"] == cal.sources["q"] == cal.sources["max_misses"] == "given"
    assert cal.sources["velocity_mean"] == "estimated"


def test_the_estimate_needs_motion():
    lone = Detections.from_frames([np.zeros((1, 2)), np.zeros((0, 2)), np.ones((1, 2))])
    with pytest.raises(ValueError, match="no two consecutive frames"):
        estimate_sensor_model(lone, detection_sensor_spec(lone, dt=1.0))


# -- warnings and the report size ---------------------------------------------------------------
def test_a_run_of_one_frame_tracks_is_warned_about_by_its_figures(belt):
    pixels = scaled(belt, PIXELS)  # the metres defaults on a file in pixels
    with pytest.warns(RuntimeWarning, match="did not fit"):  # and the report grows on the way
        tracks = run_agent(
            make_agent("gnn", predictor="kf-ca"), pixels, detection_sensor_spec(pixels, dt=0.005)
        )
    problems = run_warnings(tracks, len(pixels))
    assert len(problems) == 2
    assert "most detections start a track" in problems[0] and "ids/detections = " in problems[0]
    assert "most tracks are 1-2 frames long" in problems[1]


def test_a_report_too_small_for_the_coasting_tracks_grows():
    # one detection a frame, each far from the last: every detection starts a track that coasts
    # two frames, so three tracks live while the fullest frame holds one
    frames = [np.array([[10.0 * t, 0.0]]) for t in range(12)]
    stream = Detections.from_frames(frames)
    small = detection_sensor_spec(stream, dt=1.0, measurement_noise_std=0.1, max_tracks=1)
    large = detection_sensor_spec(stream, dt=1.0, measurement_noise_std=0.1, max_tracks=64)
    with pytest.warns(RuntimeWarning, match="did not fit a report of max_tracks=1"):
        grown = run_agent(make_agent("gnn", predictor="kf-cv"), stream, small)
    assert grown.equals(run_agent(make_agent("gnn", predictor="kf-cv"), stream, large))
    assert live_track_bound(stream, 2) == 3


# -- track run ----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def pixel_file(tmp_path_factory, belt):
    path = tmp_path_factory.mktemp("sorter") / "recording.csv"
    write_wide_detections(path, scaled(belt, PIXELS))
    return path


def run_cli(command: str, capsys) -> tuple[int, str, str]:
    argv = shlex.split(command)
    assert argv[:2] == ["track", "run"]
    code = track_main(argv[1:])
    out = capsys.readouterr()
    return code, out.out, out.err


def readme_points_command() -> str:
    """The command of docs/track_run.md's "Points" subsection."""
    text = (Path(__file__).parents[2] / "docs" / "track_run.md").read_text(encoding="utf-8")
    section = text.split("### Points", 1)[1].split("\n### ", 1)[0]
    return section.split("```bash\n", 1)[1].split("\n```", 1)[0].strip()


def test_readme_command_estimates_a_pixel_recordings_sensor_model(
    pixel_file, belt, tmp_path, capsys, monkeypatch
):
    command = readme_points_command()
    assert command == "track run recording.csv --dt 0.005 --out tracks.csv"
    monkeypatch.chdir(tmp_path)
    (tmp_path / "recording.csv").write_bytes(pixel_file.read_bytes())
    code, _, err = run_cli(command, capsys)
    assert code == 0, err
    assert "measurement noise std" in err and "(input units, estimated)" in err
    sidecar = json.loads((tmp_path / "tracks.csv.calibration.json").read_text())
    cal = sidecar["calibration"]
    # the default kf-ca model on a constant-velocity stream: its fit reads part of the process as
    # noise (measured: 1.16 px for 0.89 px; kf-cv, the stream's model, finds it within 10 %)
    assert cal["noise_std"] == pytest.approx(5e-5 * PIXELS, rel=0.4)
    assert cal["dt"] == 0.005 and cal["sources"]["q"] == "estimated"
    assert sidecar["warnings"] == []
    assert sidecar["run"]["ids"] <= 1.1 * len(np.unique(belt.ids))


def test_flags_override_their_estimates(pixel_file, tmp_path, capsys):
    out = tmp_path / "t.txt"
    code, _, err = run_cli(
        f"track run {pixel_file} --dt 0.005 --out {out} --no-progress --sensor-model on "
        "--declared-noise-std 2 --process-noise 1e9 --initial-velocity 17000,0 --initial-velocity-std 900 "
        "--agent-kwargs max_misses=3",
        capsys,
    )
    assert code == 0, err
    cal = json.loads((tmp_path / "t.txt.calibration.json").read_text())["calibration"]
    assert (cal["noise_std"], cal["q"], cal["velocity_mean"], cal["velocity_std"], cal["max_misses"]) == (
        2.0,
        1e9,
        [17000.0, 0.0],
        900.0,
        3,
    )
    assert set(cal["sources"].values()) == {"given", "estimated"}  # the acceleration prior is estimated
    assert "measurement noise std 2 (input units, given)" in err


def test_max_tracks_never_fails_a_valid_file(pixel_file, tmp_path, capsys):
    code, _, err = run_cli(
        f"track run {pixel_file} --dt 0.005 --out {tmp_path / 't.txt'} --max-tracks 2 --no-progress", capsys
    )
    assert code == 0, err
    assert "note: " in err and "the reports grew to hold them" in err


def test_metric_threshold_defaults_from_the_data(tmp_path, capsys):
    frames = [np.array([[3.0 * t, 0.0], [100.0 + 3.0 * t, 0.0]]) for t in range(30)]
    stream = Detections.from_frames(frames)
    det = tmp_path / "det.csv"
    write_wide_detections(det, stream)
    truth = tmp_path / "gt.csv"
    truth.write_text(
        "frame,id,x,y\n"
        + "".join(
            f"{t},{i},{float(p[0])!r},{float(p[1])!r}\n"
            for t, f in enumerate(frames)
            for i, p in enumerate(f)
        )
    )
    code, out, err = run_cli(
        f"track run {det} --dt 0.04 --out {tmp_path / 't.txt'} --gt {truth} --metrics --sensor-model off "
        "--no-progress --declared-noise-std 1",
        capsys,
    )
    assert code == 0, err
    assert "metric threshold 50 (input units" in err
    assert "mota" in out


# -- the figures of docs/sensor_model.md -----------------------------------------------------
@pytest.mark.slow
def test_estimated_mota_is_within_003_of_the_best_hand_tuned_run():
    import sys

    sys.path.insert(0, str(Path(__file__).parents[2] / "benchmarks"))
    from bench_sensor_model import belt_sample, tud_campus

    for (det, truth), dt, threshold, best in (
        (belt_sample(5e-4), 0.01, 0.005, 0.982),  # best of the hand-tuned grid (docs/sensor_model.md)
        (tud_campus(), 0.04, 50.0, 0.666),
    ):
        spec = detection_sensor_spec(det, dt=dt)
        cal = estimate_sensor_model(det, spec)
        tracks = run_agent(
            make_agent("gnn", predictor="kf-ca", **cal.agent_kwargs()), det, cal.sensor_spec(spec)
        )
        mota = score_tracks(tracks, truth, threshold=threshold, match="distance")[0]["mota"]
        assert mota >= best - 0.03


def test_run_agent_estimates_as_track_run_does(pixel_file, belt, tmp_path, capsys):
    """``run_agent("gnn", ..., estimate_sensor_model=True)`` gives the tracks of ``track run`` with
    only --dt."""
    from track_envs.io.detections import read_wide_detections
    from track_envs.io.tracks import read_tracks

    out = tmp_path / "t.csv"
    code, _, err = run_cli(
        f"track run {pixel_file} --dt 0.005 --out {out} --format long --no-progress", capsys
    )
    assert code == 0, err
    detections = read_wide_detections(pixel_file)
    tracks = run_agent(
        "gnn", detections, detection_sensor_spec(detections, dt=0.005), estimate_sensor_model=True
    )

    written = read_tracks(out, "long")
    np.testing.assert_array_equal(tracks.ids, written.ids)
    np.testing.assert_array_equal(tracks.detection, written.detection)
    with pytest.raises(ValueError, match="needs the agent by name"):
        run_agent(
            make_agent("gnn"),
            detections,
            detection_sensor_spec(detections, dt=0.005),
            estimate_sensor_model=True,
        )


def test_jpda_takes_the_estimated_settings_as_gnn_does(pixel_file):
    """A tracker built on gnn (jpda) is given the estimate's keywords too: in pixels, the
    default metre-scale process noise would start a track at nearly every detection."""
    from track_envs.io.detections import read_wide_detections

    detections = read_wide_detections(pixel_file)
    spec = detection_sensor_spec(detections, dt=0.005)
    gnn = run_agent("gnn", detections, spec, estimate_sensor_model=True)
    jpda = run_agent("jpda", detections, spec, estimate_sensor_model=True)
    n_ids = len(np.unique(jpda.ids))
    assert n_ids <= 1.1 * len(np.unique(gnn.ids))
    assert n_ids < 0.2 * len(jpda.ids)  # tracks, not one id per detection
