"""``track train displacement-lstm`` from each data source: the sine, a point env's truth, a file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from predictors.displacement_lstm.inference import DisplacementLSTM
from track_apps.cli.train import main
from track_envs.envs.single_target import sine_trajectory, to_world
from track_envs.io.wide_tracks import write_track_csv

FAST = ["--epochs", "3", "--batch-size", "8", "--no-progress"]


def test_sine_source_writes_a_model_file(tmp_path: Path, capsys) -> None:
    out = tmp_path / "sine"
    assert (
        main(["displacement-lstm", "--sine", "--periods", "3", "--window", "40", *FAST, "--out", str(out)])
        == 0
    )
    assert "wrote" in capsys.readouterr().out
    sidecar = json.loads(out.with_suffix(".json").read_text())
    assert sidecar["kind"] == "displacement-lstm"
    assert sidecar["training"]["command"].startswith("track train displacement-lstm --sine --periods 3")
    assert sidecar["data"] == {**sidecar["data"], "source": "sine", "periods": 3.0, "window": 40, "stride": 8}
    assert sidecar["normalisation"]["step"] == 0.2 and sidecar["architecture"]["dropout"] == 0.25
    assert np.isfinite(sidecar["metrics"]["test_mean_error"]) and sidecar["training"]["wall_time_s"] >= 0
    assert DisplacementLSTM.load(out).hidden == 25


def test_env_truth_source(tmp_path: Path) -> None:
    out = tmp_path / "pw"
    argv = [
        "displacement-lstm",
        "--env",
        "PiecewiseTarget-v0",
        "--env-kwargs",
        "periods=2",
        "--episodes",
        "3",
    ]
    assert main([*argv, "--window", "30", "--hidden", "8", "--dropout", "0.1", *FAST, "--out", str(out)]) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    assert sidecar["data"]["env_id"] == "PiecewiseTarget-v0" and sidecar["normalisation"]["step"] is None
    assert sidecar["architecture"] == {**sidecar["architecture"], "hidden": 8, "dropout": 0.1}


def test_track_file_source(tmp_path: Path) -> None:
    x = sine_trajectory(200)
    tracks = np.stack([x, to_world(x, 30.0, (1.0, 2.0)), to_world(x, -60.0, (0.0, 5.0))], axis=1)
    path = tmp_path / "tracks.csv"
    write_track_csv(path, tracks)
    out = tmp_path / "file"
    argv = ["displacement-lstm", "--tracks", str(path), "--dt", "1", "--data-step", "0.2", *FAST]
    assert main([*argv, "--out", str(out)]) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    assert sidecar["data"]["source"] == "file" and sidecar["normalisation"]["step"] == 0.2


def test_dropout_for_a_model_without_it_is_an_error(tmp_path: Path, capsys) -> None:
    argv = ["nll-lstm", "--sine", "--dropout", "0.1", "--out", str(tmp_path / "m")]
    assert main(argv) == 2
    assert "--dropout is for mc-lstm and displacement-lstm, not nll-lstm" in capsys.readouterr().err
