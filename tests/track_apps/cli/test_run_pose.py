"""``track run`` on pose files (COCO results, PoseTrack), the round trip, and which agents run where."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from agents import make_agent
from agents.files.kinds import file_agents, why_not
from agents.files.points import run_agent
from agents.files.poses import run_pose_agent
from track_apps.cli.run import main
from track_envs.envs.pose_recording import record_keypoint_walkers
from track_envs.io.poses import posetrack_track_ids, read_pose_file, write_coco_results, write_posetrack
from track_envs.metrics.pose_scoring import score_poses
from track_envs.values.poses import pose_sensor_spec
from track_envs.values.types import SensorSpec

FRAMES = 15
README = Path(__file__).resolve().parents[3] / "docs" / "track_run.md"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A KeypointWalkers-v0 episode as COCO detections, PoseTrack detections and PoseTrack gt."""
    root = tmp_path_factory.mktemp("poses")
    det, gt = record_keypoint_walkers(FRAMES, seed=1, num_people=4, initial_people=4)
    write_coco_results(root / "det.json", det)
    write_posetrack(root / "video.json", det.with_rows(track_ids=np.arange(len(det))))
    write_posetrack(root / "gt.json", gt)
    return root, det, gt


def test_round_trip_read_track_write_read_back_and_score(files, tmp_path):
    root, det, _ = files
    stream = read_pose_file(root / "det.json", frames=det.image_ids.tolist(), file_names=det.file_names)
    tracks = run_pose_agent(make_agent("pose-baseline"), stream, pose_sensor_spec(stream), seed=0)
    write_posetrack(tmp_path / "tracks.json", tracks)
    back = read_pose_file(tmp_path / "tracks.json")
    renumbered = tracks.with_rows(track_ids=posetrack_track_ids(tracks.frame_index(), tracks.track_ids))
    assert back.equals(renumbered)
    assert back.track_ids.max() < 1000 and len(back) == len(stream)
    # tracked poses keep their detection's keypoints and confidences
    metrics, _ = score_poses(back, read_pose_file(root / "gt.json"))
    # measured: MOTA 0.6554, HOTA 0.7427 (pose-baseline on this episode)
    assert metrics["mota"] == pytest.approx(0.6554, abs=5e-4)
    assert metrics["hota"] == pytest.approx(0.7427, abs=5e-4)


def readme_commands() -> list[str]:
    text = README.read_text()
    section = text[text.index("### Poses: COCO and PoseTrack files") :]
    section = section[: section.index("\n## ")]
    return re.findall(r"^track run .*$", section, flags=re.M)


@pytest.mark.parametrize(
    "command",
    [pytest.param(c, marks=pytest.mark.slow) if "pose-smc" in c else c for c in readme_commands()],
)
def test_readme_commands_run(files, command, monkeypatch, capsys):
    root, _, _ = files
    assert len(readme_commands()) == 2
    monkeypatch.chdir(root)
    assert main([*shlex.split(command)[2:], "--no-progress"]) == 0
    back = read_pose_file(root / "tracks.json")
    assert back.n_frames == FRAMES and len(back) > 0
    values = dict(line.split() for line in capsys.readouterr().out.splitlines()[2:])
    assert {"mota", "hota", "det_a", "ass_a", "mota_nose", "id_switches"} <= set(values)
    assert 0.6 < float(values["mota"]) <= 1 and 0.7 < float(values["hota"]) <= 1


@pytest.mark.slow
def test_pose_smc_and_baseline_figures(files, tmp_path, capsys):
    root, _, _ = files
    figures = {}
    for agent in ("pose-baseline", "pose-smc"):
        argv = [str(root / "det.json"), "--agent", agent, "--gt", str(root / "gt.json"), "--metrics"]
        assert main([*argv, "--out", str(tmp_path / f"{agent}.json"), "--no-progress"]) == 0
        table = dict(line.split() for line in capsys.readouterr().out.splitlines()[2:])
        figures[agent] = (float(table["mota"]), float(table["hota"]))
    # measured on this episode: pose-baseline MOTA 0.6554 HOTA 0.7427, pose-smc MOTA 0.6681 HOTA 0.7773
    assert figures["pose-baseline"] == pytest.approx((0.6554, 0.7427), abs=5e-4)
    assert figures["pose-smc"] == pytest.approx((0.6681, 0.7773), abs=5e-3)


def test_point_options_and_input_format(files, tmp_path, capsys):
    root, _, _ = files
    out = str(tmp_path / "t.json")
    assert main([str(root / "video.json"), "--input-format", "posetrack", "--out", out]) == 0
    assert main([str(root / "video.json"), "--format", "wide", "--out", out]) == 2
    assert "--format: not for pose files" in capsys.readouterr().err
    assert main([str(root / "det.json"), "--input-format", "posetrack", "--out", out]) == 2
    assert "a PoseTrack file must be a JSON object with 'images' and 'annotations'" in capsys.readouterr().err
    assert main([str(root / "det.json"), "--metrics", "--out", out]) == 2
    assert "--metrics needs --gt" in capsys.readouterr().err


def test_only_agents_that_fit_the_file_are_offered(files, tmp_path, capsys):
    root, _, _ = files
    assert file_agents("pose") == ["pose-baseline", "pose-smc"]
    assert "one-step" not in file_agents("point") and "gnn" in file_agents("point")
    assert "pose-smc" not in file_agents("point")
    assert (
        why_not("one-step", "point") == "'one-step' needs truth (the env's info), which a file does not have"
    )
    out = str(tmp_path / "t.json")
    assert main([str(root / "det.json"), "--agent", "gnn", "--out", out]) == 2
    err = capsys.readouterr().err
    assert "--agent 'gnn' tracks points, not poses; agents for pose files: pose-baseline, pose-smc" in err
    points = tmp_path / "det.txt"
    points.write_text("1,-1,10,10,2,2,1\n2,-1,11,10,2,2,1\n")
    for agent, why in (
        ("one-step", "--agent 'one-step' needs truth (the env's info), which a file does not have"),
        ("pose-smc", "--agent 'pose-smc' tracks poses (17 keypoints), not points"),
        ("pose-baseline", "--agent 'pose-baseline' tracks poses (17 keypoints), not points"),
    ):
        assert main([str(points), "--agent", agent, "--out", str(tmp_path / "t.txt")]) == 2
        err = capsys.readouterr().err
        assert why in err and "agents for point files: detections, gnn" in err


def test_help_lists_the_agents_of_each_kind(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "pose files: pose-baseline, pose-smc" in text and "point files: detections, gnn" in text


def test_run_agent_and_run_pose_agent_refuse_the_wrong_agent(files):
    _, det, _ = files
    spec = SensorSpec(0.1, 2, 0.0, 1.0, 0.0, (0.0, 0.0), (1.0, 1.0), 4, 4)
    with pytest.raises(ValueError, match=r"'PoseBaselineAgent' tracks poses \(17 keypoints\), not points"):
        run_agent("pose-baseline", [np.zeros((1, 2))], spec)
    with pytest.raises(ValueError, match=r"'OneStepAgent' needs truth"):
        run_agent("one-step", [np.zeros((1, 2))], spec)
    with pytest.raises(ValueError, match=r"'GnnAgent' tracks points, not poses"):
        run_pose_agent(make_agent("gnn"), det, pose_sensor_spec(det))


def test_sorting_flags_are_refused_on_pose_files(files, tmp_path, capsys):
    root, _, _ = files
    out = str(tmp_path / "t.json")
    assert main([str(root / "video.json"), "--sorting-line", "0.5", "--out", out]) == 2
    assert "--sorting-line" in capsys.readouterr().err
