"""The probabilistic pose predictor: features, shapes, heteroscedastic σ, the training command."""

from __future__ import annotations

import json

import numpy as np
import pytest

from agents.cli import train_alias as train_main
from predictors.pose_lstm.predictor import PosePredictor, window_features
from predictors.pose_lstm.training import PoseWindows, to_model_file, train_pose_model
from predictors.training.loop import TrainConfig
from predictors.training.model_file import load_model


def test_window_features_difference_visible_steps_and_attend_to_the_last_visible_one():
    w = np.zeros((2, 4, 3))
    w[0] = [[10, 20, 1], [12, 21, 1], [0, 0, 0], [15, 25, 1]]  # a gap before the last step
    inputs, anchor, has = window_features(w, scale=2.0)
    np.testing.assert_allclose(inputs[0, :, :2], [[0, 0], [1, 0.5], [0, 0], [0, 0]])
    np.testing.assert_array_equal(inputs[0, :, 2], [1, 1, 0, 1])
    np.testing.assert_allclose(anchor[0], [15, 25])
    w[0, 3] = 0  # now the last visible step is the second
    _, anchor, _ = window_features(w, scale=2.0)
    np.testing.assert_allclose(anchor[0], [12, 21])
    assert has.tolist() == [True, False]


def speed_windows(n: int, seed: int, L: int = 6) -> PoseWindows:
    """Keypoints in straight lines, half slow and half fast, noise proportional to the speed."""
    rng = np.random.default_rng(seed)
    speed = np.where(np.arange(n) % 2 == 0, 1.0, 30.0)[:, None, None, None]  # px / frame
    heading = rng.uniform(0, 2 * np.pi, (n, 17, 1, 1))
    step = speed * np.concatenate([np.cos(heading), np.sin(heading)], axis=-1)
    t = np.arange(L + 1)[None, None, :, None]
    path = 400.0 + step * t + 0.3 * speed * rng.standard_normal((n, 17, L + 1, 2))
    windows = np.concatenate([path[:, :, :L], np.ones((n, 17, L, 1))], axis=-1).astype(np.float32)
    return PoseWindows(windows, path[:, :, L], np.ones((n, 17), bool), np.arange(n), 10.0)


@pytest.fixture(scope="module")
def speed_model():
    train, validation = speed_windows(240, 0), speed_windows(60, 1)
    config = TrainConfig(epochs=40, lr=3e-3, batch_size=30, decay_every=1000, seed=0)
    net, _ = train_pose_model(train, validation, config, min_window=6, progress=False)
    return PosePredictor(to_model_file(net, 1 / 72, metrics={"fixed_sigma": [1.0, 1.0]})), validation


def test_sigma_grows_with_the_motion_speed_of_the_training_data(speed_model):
    predictor, data = speed_model
    inputs, _, _ = window_features(data.windows, 10.0)
    _, sigma = predictor.distribution(inputs.reshape(-1, 6, 3), None, epistemic=False)
    sigma = sigma.reshape(len(data), 17, 2).mean(axis=(1, 2))
    slow, fast = sigma[0::2].mean(), sigma[1::2].mean()
    # measured: slow 0.085, fast 1.24 network units (the residual noise std is 0.04 and 1.27)
    assert fast > 4 * slow


def test_sample_shapes_and_the_uncertainty_switches(speed_model):
    predictor, data = speed_model
    windows = data.windows[:3].reshape(1, 3, 17, 6, 3)  # (filters, particles, K, L, 3)
    rng = np.random.default_rng(0)
    z, has = predictor.sample(windows, 10.0, rng)
    assert z.shape == (1, 3, 17, 2) and has.shape == (1, 3, 17) and has.all()
    inputs, _, _ = window_features(data.windows[:4], 10.0)
    flat = inputs.reshape(-1, 6, 3)
    a = predictor.distribution(flat, np.random.default_rng(1))
    b = predictor.distribution(flat, np.random.default_rng(2))
    assert not np.allclose(a[0], b[0])  # dropout at test time: another model per draw
    c = predictor.distribution(flat, np.random.default_rng(1), epistemic=False)
    d = predictor.distribution(flat, np.random.default_rng(2), epistemic=False)
    np.testing.assert_array_equal(c[0], d[0])
    mu, sigma = c
    anchor = np.zeros_like(mu)
    fixed = predictor.draw(mu, sigma, anchor, 1.0, np.random.default_rng(0), aleatoric=False, fixed_sigma=0.0)
    np.testing.assert_allclose(fixed, mu)


def test_the_training_command_writes_a_model_file_the_predictor_loads(tmp_path):
    out = tmp_path / "pose"
    argv = ["pose-lstm", "--env", "KeypointWalkers-v0", "--episodes", "1", "--steps", "40",
            "--window", "8", "--epochs", "1", "--lr", "1e-3", "--batch-size", "30", "--out", str(out),
            "--no-progress"]  # fmt: skip
    assert train_main(argv) == 0
    model = load_model(out, kind="pose-lstm")
    sidecar = json.loads((tmp_path / "pose.json").read_text())
    assert sidecar["training"]["command"].startswith("track-train pose-lstm --env KeypointWalkers-v0")
    assert sidecar["architecture"]["hidden"] == 64 and sidecar["architecture"]["fc"] == 40
    assert sidecar["architecture"]["dropout"] == 0.3 and len(sidecar["metrics"]["fixed_sigma"]) == 2
    assert sidecar["training"]["loss"] == "nll"  # the default: eq. (8)
    predictor = PosePredictor(model)
    assert predictor.scale_for(720.0) == pytest.approx(10.0)
    assert train_main(["pose-lstm", "--sine", "--out", str(out)]) == 2  # needs a keypoint env


def _walker_windows(n: int, L: int, seed: int) -> np.ndarray:
    """Pointwise windows (n, L, 3) like the tracker's queues: walks with gaps and zero (unborn) prefixes."""
    rng = np.random.default_rng(seed)
    pos = 360.0 + np.cumsum(rng.normal(0, 8.0, (n, L, 2)), axis=1)
    vis = rng.random((n, L)) < 0.85
    vis[np.arange(n) < n // 4, : L // 2] = False  # a quarter of new filters: zeros before their first pose
    return np.concatenate([np.where(vis[..., None], pos, 0.0), vis[..., None]], axis=-1)


def test_the_shipped_predictor_encodes_as_torchs_lstm_to_1e6():
    """The pose predictor's LSTM (the shared float32 cell, torch's GEMM) equals the network's
    ``nn.LSTM`` to 1e-6 on the shipped weights: windows (several row blocks and a partial one),
    the distribution of the head, and the carried steps (``h``; ``c`` to 1e-6 of its size)."""
    import torch

    from predictors.pose_lstm.motion import DEFAULT_MODEL

    predictor = PosePredictor(DEFAULT_MODEL)
    scale = predictor.scale_for(720.0)
    inputs, _, _ = window_features(_walker_windows(1300, 10, 0), scale)
    with torch.inference_mode():
        _, (h_t, c_t) = predictor.net.lstm(torch.from_numpy(inputs))
        mu_t, log_sigma_t = predictor.net.head(h_t[0])
    h = predictor.encode(inputs)
    assert h.dtype == np.float32 and h.shape == (1300, predictor.hidden)
    np.testing.assert_allclose(h, h_t[0].numpy(), rtol=0, atol=1e-6)
    mu, sigma = predictor.distribution(inputs, None, epistemic=False)
    np.testing.assert_allclose(mu, mu_t.numpy(), rtol=0, atol=1e-6)
    np.testing.assert_allclose(np.log(sigma), log_sigma_t.numpy(), rtol=0, atol=1e-5)
    state = None  # carried: one step at a time from the zero state
    for t in range(inputs.shape[1]):
        state = predictor.step(inputs[:, t], state)
    np.testing.assert_allclose(state[0], h_t[0].numpy(), rtol=0, atol=1e-6)
    # the cell state grows to |c| ≈ 3 here: 1e-6 of its size (a few float32 ulp)
    np.testing.assert_allclose(state[1], c_t[0].numpy(), rtol=1e-6, atol=1e-6)
