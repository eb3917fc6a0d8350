"""``track train`` end to end: a user's track file in, a model file out, tracked with gnn."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from agents.gnn.agent import GnnAgent
from predictors.belt_lstm.predictor import LSTMPredictor
from track_apps.cli.train import main
from track_envs.envs.recording import record_belt_sorter


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("rec") / "tracks.csv"
    record_belt_sorter(path, n_frames=150, seed=3, particle_kind="sphere")
    return path


def test_train_from_a_track_file_then_track_with_it(
    recording: Path, tmp_path: Path, capsys, monkeypatch
) -> None:
    out = tmp_path / "nll"
    argv = ["nll-lstm", "--tracks", str(recording), "--dt", "0.01", "--epochs", "4", "--batch-size", "64"]
    assert main([*argv, "--out", str(out), "--no-progress", "--added-noise-std", "1e-4"]) == 0
    printed = capsys.readouterr().out
    assert "shorter than 5 frames dropped" in printed and "wrote" in printed
    sidecar = json.loads(out.with_suffix(".json").read_text())
    assert sidecar["training"]["command"].startswith("track train nll-lstm --tracks")
    assert sidecar["data"]["source"] == "file" and sidecar["data"]["train_tracks"] > 0
    assert sidecar["calibration"]["scale"] > 0 and np.isfinite(sidecar["metrics"]["test_mean_error"])
    assert set(sidecar["versions"]) >= {"torch", "numpy", "python"}

    env = gym.make("BeltReplay-v0", path=str(recording), dt=0.01, noise_std=1e-4)
    agent = GnnAgent(predictor=LSTMPredictor("nll-lstm", out))
    obs, _ = env.reset(seed=0)
    agent.reset(env.unwrapped.sensor_spec, seed=0)  # type: ignore[attr-defined]
    for _ in range(20):
        obs, *_ = env.step(agent.act(obs))
    assert agent.n_tracks > 0

    import predictors.training.calibration as calibration

    drawn: dict[str, object] = {}
    original = calibration.plot_reliability

    def spy(curves, path, title=""):
        drawn.update(labels=list(curves), title=title)
        original(curves, path, title)

    monkeypatch.setattr(calibration, "plot_reliability", spy)
    plot = tmp_path / "rel.png"
    assert main(["calibrate", str(out), "--tracks", str(recording), "--dt", "0.01", "--plot", str(plot)]) == 0
    assert plot.stat().st_size > 5_000
    printed = capsys.readouterr().out
    factor = printed.split("r = ", 1)[1].split(" ", 1)[0]  # the factor the summary prints
    before, after = drawn["labels"]  # type: ignore[misc]
    assert before.startswith("before (r = 1,") and after.startswith(f"after (r = {factor},")
    assert before in printed and after in printed  # each curve's label is printed as drawn
    assert "calibration tracks" in str(drawn["title"]) and "held-out" not in str(drawn["title"])


def test_lstm_line_search_writes_the_chosen_scale(recording: Path, tmp_path: Path) -> None:
    out = tmp_path / "lstm"
    argv = ["lstm", "--tracks", str(recording), "--dt", "0.01", "--epochs", "2", "--batch-size", "64"]
    assert main([*argv, "--out", str(out), "--no-progress", "--added-noise-std", "3e-4"]) == 0
    sidecar = json.loads(out.with_suffix(".json").read_text())
    tuning = sidecar["training"]["tuning"]
    assert len(tuning["e_mean"]) == len(tuning["factors"]) == 7
    chosen = sidecar["calibration"]["cov_scale"] / sidecar["calibration"]["cov_scale_mse"]
    index = int(np.argmin(np.abs(np.log(np.asarray(tuning["factors"]) / chosen))))
    assert tuning["e_mean"][index] == min(tuning["e_mean"])  # the written scale is a best candidate
    assert sidecar["calibration"]["scale"] == 1.0


def test_too_little_data_is_a_one_line_error(tmp_path: Path, capsys) -> None:
    tiny = tmp_path / "tiny.csv"
    tiny.write_text("0.1,0.1\n0.11,0.1\n")
    assert main(["nll-lstm", "--tracks", str(tiny), "--dt", "0.01", "--out", str(tmp_path / "m")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("track train: error: too few tracks to train on")


def test_tracks_need_dt(recording: Path, tmp_path: Path, capsys) -> None:
    assert main(["lstm", "--tracks", str(recording), "--out", str(tmp_path / "m")]) == 2
    assert "--tracks needs --dt" in capsys.readouterr().err
