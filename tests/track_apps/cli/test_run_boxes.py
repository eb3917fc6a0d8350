"""track run on box detections: MOT boxes carried to the output and scored by IoU against MOT
ground truth (docs/track_run.md's recipe on the MOT15 files py-motmetrics ships), and its input checks."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from track_apps.cli.run import main
from track_envs.io.tracks import read_tracks

mm = pytest.importorskip("motmetrics")
DATA = Path(mm.__file__).parent / "data"
README = Path(__file__).resolve().parents[3] / "docs" / "track_run.md"


def readme_boxes_command() -> list[str]:
    """The ``track run`` command of docs/track_run.md's boxes subsection, as argv after ``track run``."""
    text = README.read_text()
    section = text.split("### Boxes: MOTChallenge files", 1)[1].split("\n### ", 1)[0]
    block = section.split("```bash", 1)[1].split("```", 1)[0]
    line = next(x for x in block.replace("\\\n", " ").splitlines() if x.strip().startswith("track run"))
    argv = shlex.split(line.split("#", 1)[0].replace("$DATA", str(DATA / "TUD-Campus")))
    return argv[2:]


def metric(out: str, name: str) -> float:
    return float(re.search(rf"^{name}\s+(\S+)$", out, re.M).group(1))  # type: ignore[union-attr]


@pytest.mark.filterwarnings("ignore:Operation with tuple is deprecated")
def test_the_readme_recipe_tracks_tud_campus_keeping_boxes_and_scores_with_iou(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    argv = readme_boxes_command()
    assert main([*argv, "--no-progress"]) == 0
    captured = capsys.readouterr()
    assert "matching: boxes, IoU >= 0.5" in captured.err
    assert metric(captured.out, "mota") == pytest.approx(0.526462, abs=1e-6)
    assert metric(captured.out, "idf1") == pytest.approx(0.567986, abs=1e-6)
    assert metric(captured.out, "hota") == pytest.approx(0.405065, abs=1e-6)
    out = tmp_path / argv[argv.index("--out") + 1]
    tracks = read_tracks(out)
    assert tracks.boxes is not None and tracks.boxes[:, 2:].min() > 10  # real boxes, not points
    assert len(tracks) == 222  # box input: only the rows updated with a detection (--coasting-rows auto)


@pytest.mark.filterwarnings("ignore:Operation with tuple is deprecated")
def test_coasting_rows_all_writes_the_frames_a_track_coasts_with_its_last_box(tmp_path, capsys):
    campus = DATA / "TUD-Campus"
    argv = [str(campus / "test.txt"), "--dt=0.04", f"--gt={campus / 'gt.txt'}", "--metrics"]
    out = tmp_path / "t.txt"
    assert main([*argv, f"--out={out}", "--coasting-rows=all", "--no-progress"]) == 0
    assert metric(capsys.readouterr().out, "mota") == pytest.approx(0.415042, abs=1e-6)
    tracks = read_tracks(out)
    assert len(tracks) == 295 and tracks.boxes is not None and np.isfinite(tracks.boxes).all()


@pytest.mark.filterwarnings("ignore:Operation with tuple is deprecated")
def test_distance_matching_on_request_and_the_confidence_filter_keeps_not_given(tmp_path, capsys):
    campus = DATA / "TUD-Campus"
    argv = [str(campus / "test.txt"), "--dt=0.04", "--declared-noise-std=5", f"--out={tmp_path / 't.txt'}"]
    argv += [f"--gt={campus / 'gt.txt'}", "--metrics", "--match=distance", "--threshold=50"]
    assert main([*argv, "--min-confidence=0.5", "--no-progress"]) == 0
    captured = capsys.readouterr()
    assert "matching: centres, distance <= 50" in captured.err
    assert "222 detections" in captured.err  # every confidence is -1: none dropped


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--declared-noise-std=-1"], r"--declared-noise-std must be a finite number >= 0, got -1.0"),
        (["--max-detections=1"], r"--max-detections=1 is below the 2 detections of the fullest frame"),
        (["--p-detect=2"], r"--p-detect must be a probability"),
        (
            ["--min-confidence=0.5"],
            r"--min-confidence\) drops every one of the 3 rows; their confidences "
            r"\(column index 6\) range from 0.1 to 0.3",
        ),
        (["--min-iou=0"], r"--min-iou must be in \(0, 1\]"),
    ],
)
def test_errors_name_the_flag_the_user_typed(tmp_path, capsys, flags, message):
    det = tmp_path / "det.txt"
    det.write_text("1,-1,0,0,2,2,0.1\n1,-1,5,5,2,2,0.2\n2,-1,0,0,2,2,0.3\n")
    code = main([str(det), "--dt=0.04", f"--out={tmp_path / 't.txt'}", "--no-progress", *flags])
    err = capsys.readouterr().err
    assert code == 2 and re.search(message, err), err
    assert "measurement_noise_std" not in err


@pytest.mark.parametrize("where", ["missing folder", "a directory"])
def test_out_is_checked_before_tracking(tmp_path, capsys, where):
    det = tmp_path / "det.txt"
    det.write_text("1,-1,0,0,2,2,1\n")
    out = tmp_path / "nowhere" / "t.txt" if where == "missing folder" else tmp_path
    assert main([str(det), "--dt=0.04", f"--out={out}", "--no-progress"]) == 2
    err = capsys.readouterr().err
    said = "does not exist" if where == "missing folder" else "is a directory"
    assert err.startswith("track run: error: --out") and said in err
    assert "frames" not in err  # nothing was read or tracked


def test_iou_matching_of_points_is_refused_before_tracking(tmp_path, capsys):
    det, gt = tmp_path / "det.txt", tmp_path / "gt.txt"
    det.write_text("1,-1,0.5,0.5,0,0,1\n2,-1,0.6,0.5,0,0,1\n")  # points: 0 x 0 boxes
    gt.write_text("1,1,0,0,1,1,1,1,1\n2,1,0.1,0,1,1,1,1,1\n")
    argv = [str(det), "--dt=0.04", f"--out={tmp_path / 't.txt'}", f"--gt={gt}", "--metrics", "--match=iou"]
    assert main([*argv, "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "--match iou) needs boxes, and the tracks have none" in err and "frames" not in err
    assert not (tmp_path / "t.txt").exists()
