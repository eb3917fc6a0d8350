"""The pose predictor's training losses: eq. (8) and the squared error of μ alone (``--loss``)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from predictors.pose_lstm.network import PosePredictorNet
from predictors.pose_lstm.training import (
    PoseWindows,
    gaussian_nll,
    mean_squared_error,
    pose_loss,
    pose_tensors,
    train_pose_model,
)
from predictors.training.loop import TrainConfig
from track_apps.cli.train import main as train_main


def test_mean_squared_error_is_the_weighted_mean_over_sequences_of_half_the_summed_squares():
    mu = torch.tensor([[1.0, 2.0], [0.0, 0.0], [3.0, 1.0]])
    r = torch.tensor([[0.0, 0.0], [1.0, 1.0], [3.0, 3.0]])
    weight = torch.tensor([1.0, 1.0, 0.0])  # the third sequence has no visible target
    # per sequence: (1 + 4) / 2 = 2.5, (1 + 1) / 2 = 1, (0 + 4) / 2 = 2 (weight 0)
    assert float(mean_squared_error(mu, r, weight)) == pytest.approx((2.5 + 1.0) / 2)
    # eq. (8) with σ = 1 (log σ = 0) is the same number
    nll = gaussian_nll(mu, torch.zeros_like(mu), r, weight)
    assert float(nll) == pytest.approx(float(mean_squared_error(mu, r, weight)))


def _windows(n: int, L: int = 5) -> PoseWindows:
    rng = np.random.default_rng(0)
    path = 300.0 + np.cumsum(rng.normal(0, 5.0, (n, 17, L + 1, 2)), axis=2)
    windows = np.concatenate([path[:, :, :L], np.ones((n, 17, L, 1))], axis=-1).astype(np.float32)
    return PoseWindows(windows, path[:, :, L], np.ones((n, 17), bool), np.arange(n), 10.0)


def test_the_mse_loss_gives_no_gradient_to_the_log_sigma_outputs():
    net = PosePredictorNet(dropout=0.0)
    net.eval()
    batch = pose_tensors(_windows(2))
    generator = torch.Generator().manual_seed(0)
    grads = {}
    for name in ("mse", "nll"):
        net.zero_grad()
        pose_loss(10.0, 5, 3, name)(net, batch, generator).backward()
        assert net.out.weight.grad is not None
        grads[name] = net.out.weight.grad.clone()
    assert grads["mse"][2:].abs().max() == 0.0  # rows of log σ_x, log σ_y
    assert grads["mse"][:2].abs().min() > 0.0 and grads["nll"][2:].abs().min() > 0.0


def test_a_bad_loss_name_is_refused_with_the_valid_ones():
    with pytest.raises(ValueError, match=r"loss must be one of nll, mse, got 'l1'"):
        pose_loss(10.0, 5, 3, "l1")
    config = TrainConfig(epochs=1, batch_size=2, seed=0)
    with pytest.raises(ValueError, match=r"nll, mse"):
        train_pose_model(_windows(2), None, config, loss="l1", progress=False)


ARGV = ["pose-lstm", "--env", "KeypointWalkers-v0", "--episodes", "1", "--steps", "20", "--window", "4",
        "--min-window", "2", "--epochs", "1", "--batch-size", "30", "--no-progress"]  # fmt: skip


def test_the_loss_flag_is_recorded_in_the_model_file(tmp_path):
    out = tmp_path / "pose"
    assert train_main([*ARGV, "--loss", "mse", "--dropout", "0", "--out", str(out)]) == 0
    sidecar = json.loads((tmp_path / "pose.json").read_text())
    assert sidecar["training"]["loss"] == "mse"
    assert sidecar["training"]["command"].endswith("--loss mse --dropout 0 --out " + str(out))
    assert sidecar["architecture"]["dropout"] == 0.0
    assert len(sidecar["metrics"]["fixed_sigma"]) == 2


def test_a_bad_loss_flag_is_named_with_the_valid_names(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        train_main([*ARGV, "--loss", "l1", "--out", str(tmp_path / "pose")])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "--loss" in err and "'l1'" in err and "'nll'" in err and "'mse'" in err
