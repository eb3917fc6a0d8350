"""The detection model from the data: p_D, the clutter density and jpda's merge extent, their
accuracy on constant-velocity streams of known p_D and λ, unit invariance, the flags that
override them, and jpda giving the same tracks in pixels and in metres."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import numpy as np
import pytest

from agents.sensor_model import estimate_sensor_model
from agents.sensor_model.detection import (
    MIN_P_DETECT,
    covered_area,
    detection_model,
    track_gaps,
    truncated_geometric_p,
)
from agents.sensor_model.merging import box_size, closest_approaches, merge_extent
from track_apps.cli import main as track_main
from track_apps.cli.sensor_model_summary import summary_lines, write_sidecar
from track_envs.infra.atomic import FileWriteError
from track_envs.io.detections import write_wide_detections
from track_envs.streams.constant_velocity import constant_velocity_stream
from track_envs.values.detections import Detections, detection_sensor_spec

#: The second unit system: millimetres (or pixels of 1 mm) for the metres of the stream.
K = 1000.0
#: The window of the constant-velocity stream (m²).
WINDOW = 0.5 * 0.3


def cv_detections(seed: int, p_detect: float, clutter_rate: float, frames: int = 150) -> Detections:
    """A constant-velocity stream (the default belt-scale scene) as detections with truth ids."""
    stream = constant_velocity_stream(
        np.random.default_rng(seed), frames=frames, p_detect=p_detect, clutter_rate=clutter_rate
    )
    masks = [o["mask"] > 0 for o in stream.observations]
    points = [o["detections"][m].astype(np.float64) for o, m in zip(stream.observations, masks, strict=True)]
    ids = [d[m] for d, m in zip(stream.detection_ids, masks, strict=True)]
    return Detections.from_frames(points, ids)


def scaled(detections: Detections, k: float) -> Detections:
    return Detections(detections.points * k, detections.offsets, detections.ids)


def estimate(detections: Detections, **kwargs):
    return estimate_sensor_model(
        detections, detection_sensor_spec(detections, dt=0.01), predictor="kf-cv", **kwargs
    )


# -- the estimators ------------------------------------------------------------------------------
@pytest.mark.parametrize("p, k", [(0.9, 2), (0.7, 2), (0.5, 3), (0.8, 100_000)])
def test_truncated_geometric_p_inverts_the_mean_of_truncated_gaps(p, k):
    rng = np.random.default_rng(0)
    gaps = rng.geometric(p, 400_000) - 1
    gaps = gaps[gaps <= k]  # what a tracker that coasts k frames sees
    assert truncated_geometric_p(float(gaps.mean()), k) == pytest.approx(p, abs=0.005)
    # the plain geometric 1 / (1 + mean) is biased upwards by the truncation, by what the truncated
    # mean predicts (2.4e-3 at p 0.9, k 2; 0.043 at 0.7, 2; 0.077 at 0.5, 3; none at k 100,000)
    gap = np.arange(k + 1)
    law = p * (1 - p) ** gap
    expected = 1 / (1 + float(gap @ law / law.sum()))
    plain = 1 / (1 + gaps.mean())
    assert plain == pytest.approx(expected, abs=0.002)  # sampling std of plain <= 1.2e-3 here
    if k < 10:
        assert expected - p > 0.002
        assert plain - p > (expected - p) / 2
    else:
        assert expected == pytest.approx(p, abs=1e-12)


def test_truncated_geometric_p_bounds():
    assert truncated_geometric_p(0.0, 2) == 1.0
    assert truncated_geometric_p(1.0, 2) == MIN_P_DETECT  # the uniform mean k / 2: p -> 0


def test_gaps_and_area():
    frames = np.array([0, 1, 3, 4, 7, 2, 3], np.int64)
    labels = np.array([5, 5, 5, 5, 5, -1, 8], np.int64)
    np.testing.assert_array_equal(track_gaps(frames, labels), [0, 1, 0, 2])
    rng = np.random.default_rng(1)
    points = rng.uniform((0, 0), (4, 2), (20_000, 2))
    assert covered_area(points) == pytest.approx(8.0, rel=0.01)
    stray = np.concatenate([points, [[1e6, -1e6]]])  # a stray row does not move it
    assert covered_area(stray) == pytest.approx(covered_area(points), rel=1e-3)
    assert covered_area(np.zeros((5, 2))) == 0.0


def test_detection_model_counts_unclaimed_and_short_tracks_as_clutter():
    # tracks 1 (6 detections), 2 (2: short, clutter-like), unlabelled 1
    frames = np.array([0, 1, 2, 3, 5, 6, 0, 1, 4], np.int64)
    labels = np.array([1, 1, 1, 1, 1, 1, 2, 2, -1], np.int64)
    points = np.random.default_rng(0).uniform(0, 1, (9, 2))
    model = detection_model(points, frames, 7, labels, max_gap=2, min_length=6)
    assert model.n_gaps == 5 and model.mean_gap == pytest.approx(0.2)
    assert model.n_unclaimed == 3
    assert model.clutter_density == pytest.approx(3 / (7 * covered_area(points)))


def test_merge_extent_from_boxes_and_closest_approaches():
    boxes = np.array([[0, 0, 4, 9], [0, 0, 1, 1], [0, 0, 2, 8], [0, 0, 0, 5]], np.float64)
    assert box_size(boxes) == pytest.approx(4.0)  # sqrt(w h): 6, 1, 4 (the empty box left out)
    # two tracks 3 apart, then 1 apart; a third far away (whose nearest is track 1: 47, then 49)
    frames = [np.array([[0.0, 0], [3, 0], [50, 0]]), np.array([[0.0, 0], [1, 0], [50, 0]])]
    det = Detections.from_frames(frames)
    labels = np.array([0, 1, 2, 0, 1, 2])
    np.testing.assert_allclose(np.sort(closest_approaches(det, labels)), [1.0, 47.0])
    extent, rule = merge_extent(det, labels, length=10.0)
    assert rule == "closest approaches" and extent is not None and 1.0 <= extent < 47.0
    assert merge_extent(det, np.full(6, -1), length=10.0) == (None, "none")
    boxed = Detections(det.points, det.offsets, boxes=np.tile([0.0, 0, 2, 8], (6, 1)))
    assert merge_extent(boxed, labels, length=10.0) == (4.0, "boxes")


# -- accuracy on streams of known p_D and λ, and unit invariance ---------------------------------
ACCURACY_CASES = [(0.9, 5.0), (0.75, 15.0)]


@pytest.fixture(scope="module")
def accuracy():
    """Per case and seed: the estimate in metres and in units of 1/K metres."""
    out = {}
    for p, rate in ACCURACY_CASES:
        for seed in range(3):
            det = cv_detections(seed, p, rate)
            out[p, rate, seed] = (estimate(det), estimate(scaled(det, K)))
    return out


@pytest.mark.parametrize("p, rate", ACCURACY_CASES)
def test_p_detect_and_clutter_density_are_estimated(accuracy, p, rate):
    # measured (seeds 0-2): p_D within 0.006, λ 1.04-1.2 × (the excess: targets seen too briefly)
    for seed in range(3):
        cal, _ = accuracy[p, rate, seed]
        assert abs(cal.p_detect - p) < 0.05
        assert rate / WINDOW / 1.5 < cal.clutter_density < 1.5 * rate / WINDOW
        assert cal.sources["p_detect"] == cal.sources["clutter_density"] == "estimated"
        assert cal.merge_rule == "closest approaches" and 0 < cal.merge_extent < cal.length


@pytest.mark.parametrize("p, rate", ACCURACY_CASES)
def test_estimates_scale_with_the_unit(accuracy, p, rate):
    for seed in range(3):
        cal, cal_k = accuracy[p, rate, seed]
        assert cal_k.p_detect == cal.p_detect
        assert (cal_k.n_unclaimed, cal_k.n_gaps) == (cal.n_unclaimed, cal.n_gaps)
        assert cal_k.clutter_density == pytest.approx(cal.clutter_density / K**2, rel=1e-9)
        assert cal_k.merge_extent == pytest.approx(cal.merge_extent * K, rel=1e-9)


def test_given_detection_model_is_kept_and_told_to_the_tracker():
    det = cv_detections(0, 0.9, 5.0, frames=60)
    spec = detection_sensor_spec(det, dt=0.01, p_detect=0.8, clutter_rate=7.0)
    cal = estimate_sensor_model(
        det,
        spec,
        predictor="kf-cv",
        p_detect=0.8,
        clutter_density=7.0 / float(np.prod(spec.region_size)),
        merge_extent=0.002,
    )
    assert (cal.p_detect, cal.merge_extent, cal.merge_rule) == (0.8, 0.002, "given")
    assert cal.sources["p_detect"] == cal.sources["clutter_density"] == cal.sources["merge_extent"] == "given"
    told = cal.sensor_spec(spec)
    assert (told.p_detect, told.clutter_rate) == (0.8, 7.0)  # the declared rate, not rounded
    assert cal.agent_kwargs("jpda")["merge_extent"] == 0.002
    assert "merge_extent" not in cal.agent_kwargs("gnn")
    # a spec that declares misses and clutter is kept as declared (run_agent(estimate_sensor_model=True))
    from_spec = estimate_sensor_model(det, spec, predictor="kf-cv")
    assert from_spec.sources["p_detect"] == from_spec.sources["clutter_density"] == "given"
    assert (from_spec.sensor_spec(spec).p_detect, from_spec.sensor_spec(spec).clutter_rate) == (0.8, 7.0)
    with pytest.raises(ValueError, match="p_detect must be a probability in"):
        estimate_sensor_model(det, spec, p_detect=0.0)
    with pytest.raises(ValueError, match="merge_extent must be a finite number > 0"):
        estimate_sensor_model(det, spec, merge_extent=-1.0)


def test_summary_lines_and_atomic_sidecar(accuracy, tmp_path):
    cal, _ = accuracy[0.9, 5.0, 0]
    text = "\n".join(summary_lines(cal))
    assert f"detection probability p_D {cal.p_detect:.4g} (estimated; from {cal.n_gaps} gaps" in text
    assert "clutter density " in text and "per input unit² and frame (estimated" in text
    assert "merge extent (jpda) " in text and "estimated: closest approaches" in text
    out = tmp_path / "t.txt"
    path = write_sidecar(out, {"calibration": cal.as_dict()})
    written = json.loads(Path(path).read_text(encoding="utf-8"))["calibration"]
    assert written["p_detect"] == cal.p_detect and written["merge_extent"] == cal.merge_extent
    assert written["clutter_density"] == cal.clutter_density
    with pytest.raises(FileWriteError, match="nowhere"):
        write_sidecar(tmp_path / "nowhere" / "t.txt", {})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.txt.calibration.json"]  # no temporary left


# -- track run: the same tracks in metres and in 1/K metres, gnn and jpda ------------------------
def run_cli(command: str, capsys) -> tuple[int, str]:
    argv = shlex.split(command)
    code = track_main(argv[1:])
    return code, capsys.readouterr().err


@pytest.fixture(scope="module")
def unit_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("units")
    det = cv_detections(0, 0.9, 5.0, frames=200)
    write_wide_detections(folder / "metres.csv", det)
    write_wide_detections(folder / "millimetres.csv", scaled(det, K))
    return folder


def long_tracks(path):
    from track_envs.io.tracks import read_tracks

    return read_tracks(path, "long")


@pytest.mark.parametrize("agent", ["gnn", "jpda"])
def test_metres_and_millimetres_give_the_same_tracks(unit_files, agent, capsys):
    tracks = {}
    for name in ("metres", "millimetres"):
        out = unit_files / f"{agent}-{name}.csv"
        code, err = run_cli(
            f"track run {unit_files / name}.csv --dt 0.01 --agent {agent} --out {out} --format long "
            "--no-progress",
            capsys,
        )
        assert code == 0, err
        assert "merge extent (jpda)" in err
        tracks[name] = long_tracks(out)
    m, mm = tracks["metres"], tracks["millimetres"]
    np.testing.assert_array_equal(m.ids, mm.ids)
    np.testing.assert_array_equal(m.frame, mm.frame)
    np.testing.assert_array_equal(m.detection, mm.detection)
    np.testing.assert_allclose(mm.positions, m.positions * K, rtol=1e-6, atol=1e-3)


def test_a_fixed_merge_extent_is_not_unit_free(unit_files, capsys):
    """jpda's default merge extent (0.006, metres) in both files: the runs part (what the
    estimated extent fixes)."""
    tracks = []
    for name in ("metres", "millimetres"):
        out = unit_files / f"fixed-{name}.csv"
        code, err = run_cli(
            f"track run {unit_files / name}.csv --dt 0.01 --agent jpda --merge-extent 0.006 --out {out} "
            "--format long --no-progress",
            capsys,
        )
        assert code == 0, err
        assert "merge extent (jpda) 0.006 (input units, given)" in err
        tracks.append(long_tracks(out))
    assert len(tracks[0]) != len(tracks[1]) or not np.array_equal(tracks[0].ids, tracks[1].ids)


def test_flags_declare_the_detection_model(unit_files, tmp_path, capsys):
    out = tmp_path / "t.csv"
    code, err = run_cli(
        f"track run {unit_files / 'millimetres.csv'} --dt 0.01 --out {out} --no-progress --p-detect 0.85 "
        "--clutter-density 2e-5",
        capsys,
    )
    assert code == 0, err
    cal = json.loads((tmp_path / "t.csv.calibration.json").read_text())["calibration"]
    assert (cal["p_detect"], cal["clutter_density"]) == (0.85, 2e-5)
    assert cal["sources"]["p_detect"] == cal["sources"]["clutter_density"] == "given"
    assert "detection probability p_D 0.85 (given)" in err
    for flags, message in (
        ("--clutter-rate 5 --clutter-density 1", "give --clutter-rate or --clutter-density, not both"),
        ("--merge-extent 3", "--merge-extent is jpda's"),
        ("--agent jpda --merge-extent 0", "--merge-extent must be a finite number > 0"),
        ("--clutter-density -1", "--clutter-density must be a finite number >= 0"),
        ("--p-detect 0", "--p-detect must be in (0, 1]"),
    ):
        code, err = run_cli(
            f"track run {unit_files / 'metres.csv'} --dt 0.01 --out {out} --no-progress {flags}", capsys
        )
        assert code == 2 and message in err, err
