"""The displacement LSTM: training with the shared loop, numpy inference equal to torch, the model
file, and the shipped sine-trained weights (bounds measured once and pinned)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from predictors.belt_lstm.predictor import shipped_weights
from predictors.displacement.geometry import displacements_of
from predictors.displacement_lstm.inference import DisplacementLSTM, shipped_displacement_weights
from predictors.displacement_lstm.network import DisplacementLSTMNet
from predictors.displacement_lstm.training import (
    displacement_metrics,
    displacement_tensors,
    fit_features,
    one_step_errors,
    to_model_file,
    train_displacement_model,
)
from predictors.training.data import TrackSplit, sine_tracks, split_tracks, window_tracks
from predictors.training.loop import TrainConfig, seeded_init
from predictors.training.model_file import ModelFileError, load_model, save_model

TINY = TrainConfig(epochs=30, decay_every=10, batch_size=8)


@pytest.fixture(scope="module")
def sine_split() -> TrackSplit:
    """Windows of 48 frames every 6 of a 4-period sine (Δ = 0.2)."""
    return split_tracks(window_tracks(sine_tracks(4.0), 48, 6), seed=0)


def test_sine_windows_start_at_every_phase() -> None:
    data = sine_tracks(25.0)
    assert len(data) == 1 and data.tracks[0].shape == (786, 2)
    np.testing.assert_allclose(data.tracks[0][:, 1], np.sin(data.tracks[0][:, 0]))
    windows = window_tracks(data, 128, 8)
    assert len(windows) == (786 - 128) // 8 + 1 and all(len(t) == 128 for t in windows.tracks)
    np.testing.assert_array_equal(windows.tracks[3][0], data.tracks[0][24])
    with pytest.raises(ValueError, match="window length must be an integer >= 2, got 1"):
        window_tracks(data, 1, 8)


def test_tensors_pair_each_step_with_the_next() -> None:
    x = sine_tracks(1.0).tracks[0][:10]
    features = fit_features(sine_tracks(1.0))
    inputs, targets, mask = displacement_tensors([x, x[:6]], features)
    d = displacements_of(x)
    scaled = np.stack([d.rotation / features.rotation_scale, d.speed / features.speed_scale], axis=-1)
    np.testing.assert_allclose(inputs[0].numpy(), scaled[:-1], rtol=1e-6)
    np.testing.assert_allclose(targets[0].numpy(), scaled[1:], rtol=1e-6)
    assert mask[1].tolist() == [1.0] * 5 + [0.0] * 4


def test_tiny_training_lowers_the_loss(sine_split: TrackSplit) -> None:
    _, _, history = train_displacement_model(sine_split, TINY, progress=False)
    assert history.train_loss[-1] < 0.2 * history.train_loss[0]
    assert history.validation_loss[history.best_epoch] < 0.2 * history.validation_loss[0]


def test_training_is_deterministic_for_a_seed(sine_split: TrackSplit) -> None:
    config = TrainConfig(epochs=3, batch_size=8, seed=4)
    a, _, _ = train_displacement_model(sine_split, config, progress=False)
    b, _, _ = train_displacement_model(sine_split, config, progress=False)
    for (name, x), (_, y) in zip(a.state_dict().items(), b.state_dict().items(), strict=True):
        assert torch.equal(x, y), name
    c, _, _ = train_displacement_model(
        sine_split, TrainConfig(epochs=3, batch_size=8, seed=5), progress=False
    )
    assert not torch.equal(a.head.weight, c.head.weight)


def test_numpy_step_equals_torch() -> None:
    net = seeded_init(lambda: DisplacementLSTMNet(), 3)
    assert isinstance(net, DisplacementLSTMNet)
    with torch.no_grad():
        for p in net.parameters():
            p.mul_(3.0)  # saturate some gates
    features = fit_features(sine_tracks(2.0))
    model = DisplacementLSTM.from_model_file(to_model_file(net.eval(), features))
    rng = np.random.default_rng(0)
    x = rng.normal(size=(7, 40, 2))  # T = 7 targets, 40 steps, network units
    with torch.no_grad():
        whole = net(torch.as_tensor(x, dtype=torch.float32)).numpy()
        h, c = model.zero_state(7)
        state = None
        for t in range(40):
            out_np, h, c = model.step_scaled(x[:, t], h, c)
            out_torch, state = net.step(torch.as_tensor(x[:, t], dtype=torch.float32), state)
            np.testing.assert_allclose(out_np, out_torch.numpy(), rtol=0, atol=1e-6)
            np.testing.assert_allclose(out_np, whole[:, t], rtol=0, atol=1e-6)
            np.testing.assert_allclose(h, state[0].numpy(), rtol=0, atol=1e-6)
    assert h.shape == c.shape == (7, 25)


def test_model_file_round_trip_and_wrong_files(tmp_path, sine_split: TrackSplit) -> None:
    net, features, _ = train_displacement_model(sine_split, TrainConfig(epochs=1), progress=False)
    save_model(tmp_path / "d", to_model_file(net, features))
    model = DisplacementLSTM.load(tmp_path / "d.json")
    assert model.features == features and model.hidden == 25
    with pytest.raises(ModelFileError, match=r"holds a 'nll-lstm' model; expected 'displacement-lstm'"):
        DisplacementLSTM.load(shipped_weights("nll-lstm", "cylinder"))
    with pytest.raises(ModelFileError, match=r"nowhere\.json does not exist"):
        DisplacementLSTM.load(tmp_path / "nowhere")
    with pytest.raises(ValueError, match=r"weights must be a model file path, a ModelFile or None.*got 3"):
        DisplacementLSTM.load(3)  # type: ignore[arg-type]
    stored = load_model(tmp_path / "d")
    wide = to_model_file(net, features)
    arch = {**wide.architecture, "hidden": 30}
    with pytest.raises(ModelFileError, match=r"'lstm.weight_ih_l0' has shape \(100, 2\), the architecture"):
        DisplacementLSTM.from_model_file(type(stored)(**{**stored.__dict__, "architecture": arch}))
    no_scale = type(stored)(**{**stored.__dict__, "meta": {"normalisation": {"speed_scale": 0.2}}})
    with pytest.raises(ModelFileError, match="normalisation must hold rotation_scale and speed_scale"):
        DisplacementLSTM.from_model_file(no_scale)


# Measured with the shipped weights on the noiseless 25-period sine: one-step position error
# 0.0027 (Δ = 0.2), rotation RMSE 0.0053 rad, speed RMSE 0.0046.
SINE_BOUNDS = {"test_mean_error": 0.004, "test_rotation_rmse": 0.008, "test_speed_rmse": 0.007}


def test_shipped_model_predicts_the_noiseless_sine() -> None:
    model = DisplacementLSTM.load()
    metrics = displacement_metrics(model, sine_tracks(25.0).tracks)
    for key, bound in SINE_BOUNDS.items():
        assert metrics[key] < bound, (key, metrics[key])
    assert metrics["test_predictions"] == 784
    # and it is a model, not a lookup: the error stays small from frame 10 to the last one
    errors = one_step_errors(model, sine_tracks(25.0).tracks)["position"][0]
    assert np.nanmax(errors[10:]) < 0.02


def test_shipped_sidecar_records_how_it_was_made() -> None:
    model = load_model(shipped_displacement_weights(), kind="displacement-lstm", dim=2)
    training = model.meta["training"]
    assert training["command"].startswith("track-train displacement-lstm --sine ")
    assert 0 < training["wall_time_s"] < 300
    assert model.meta["data"]["source"] == "sine" and model.meta["data"]["periods"] == 25.0
    assert model.meta["normalisation"]["step"] == 0.2
    assert model.architecture["hidden"] == 25 and model.architecture["dropout"] == 0.25
    assert {"torch", "numpy", "python"} <= set(model.meta["versions"])
