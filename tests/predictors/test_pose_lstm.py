"""The probabilistic pose predictor: features, shapes, heteroscedastic σ, the training command."""

from __future__ import annotations

import json

import numpy as np
import pytest

from predictors.pose_lstm.predictor import PosePredictor, window_features
from predictors.pose_lstm.training import PoseWindows, to_model_file, train_pose_model
from predictors.training.loop import TrainConfig
from predictors.training.model_file import load_model
from track_apps.cli.train import main as train_main


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
    assert sidecar["training"]["command"].startswith("track train pose-lstm --env KeypointWalkers-v0")
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


def _window_features_numpy(windows, scale):
    """The batched-numpy window features the compiled pass replaced (the oracle)."""
    w = np.asarray(windows, dtype=np.float64)
    pos, vis = w[..., :2], w[..., 2] > 0
    both = vis[..., 1:] & vis[..., :-1]
    d = np.zeros_like(pos)
    d[..., 1:, :] = np.where(both[..., None], (pos[..., 1:, :] - pos[..., :-1, :]) / scale, 0.0)
    inputs = np.concatenate([d, vis[..., None]], axis=-1).astype(np.float32)
    last = w.shape[-2] - 1 - np.argmax(vis[..., ::-1], axis=-1)
    anchor = np.take_along_axis(pos, last[..., None, None], axis=-2)[..., 0, :]
    has = vis.any(axis=-1)
    return inputs, np.where(has[..., None], anchor, 0.0), has


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_the_compiled_window_features_are_the_numpy_ones_bit_for_bit(dtype):
    rng = np.random.default_rng(4)
    q = (rng.normal(300, 100, (40, 17, 10, 3))).astype(dtype)
    q[..., 2] = rng.random((40, 17, 10)) < 0.7
    q[rng.random((40, 17, 10)) < 0.3] = 0.0  # invisible steps hold zeros
    q[3, 5] = 0.0  # a window without a visible step
    for got, want in zip(window_features(q, 7.3), _window_features_numpy(q, 7.3), strict=True):
        assert got.dtype == want.dtype and got.shape == want.shape
        np.testing.assert_array_equal(got, want)


def test_the_dropout_decisions_are_16_bit_fields_of_one_uint64_draw():
    from predictors.pose_lstm.predictor import dropout_fields, dropout_masks, keep_threshold

    assert keep_threshold(0.3) == 45875 and keep_threshold(0.0) == 65536 and keep_threshold(0.5) == 32768
    fields = dropout_fields(np.random.default_rng(7), 5, 3)  # 15 fields: four 64-bit words
    words = np.random.default_rng(7).integers(0, 1 << 64, size=4, dtype=np.uint64)
    np.testing.assert_array_equal(fields.ravel(), words.view(np.uint16)[:15])
    masks = dropout_masks(np.random.default_rng(1), 20000, 40, 0.3)
    keep = np.float32(0.7)
    assert set(np.unique(masks).tolist()) == {0.0, float(np.float32(1.0) / keep)}
    assert abs(np.mean(masks > 0) - 45875 / 65536) < 0.002


def test_the_dropout_product_is_the_masked_product_with_the_fields_mask():
    from predictors.ordered_product import dropout_rows_product, masked_rows_product

    rng = np.random.default_rng(2)
    a = rng.normal(0, 1, (30, 40)).astype(np.float32)
    w = rng.normal(0, 1, (40, 4)).astype(np.float32)
    rows = rng.integers(0, 30, 500)
    fields = rng.integers(0, 1 << 16, (500, 40)).astype(np.uint16)
    mask = (fields < 45875).astype(np.float32)
    for threads in (1, 2):
        got, want = np.empty((500, 4), np.float32), np.empty((500, 4), np.float32)
        dropout_rows_product(a, rows, fields, 45875, w, got, threads)
        masked_rows_product(a, rows, mask, w, want, threads)
        np.testing.assert_array_equal(got, want)
    with pytest.raises(ValueError, match="threshold must be in 0 … 65536, got 70000"):
        dropout_rows_product(a, rows, fields, 70000, w, got)
