"""Training the displacement LSTM of the LSTM particle filter (Jung et al. 2019) on trajectories.

Data: any [`TrackSet`][predictors.training.TrackSet] — the noiseless sine of eq. (5)
([`predictors.training.data.sine_tracks`][predictors.training.data.sine_tracks]), a point env's truth or a
user's track file — optionally cut into overlapping windows
([`predictors.training.data.window_tracks`][predictors.training.data.window_tracks]), so one long curve gives
many training sequences that start at every phase (a filter may (re)start anywhere on it). Each track
``x_0 … x_n`` becomes ``(r_t, s_t)``
([`predictors.displacement.geometry.displacements_of`][predictors.displacement.geometry.displacements_of],
``r_0 = s_0 = 0``); the network reads ``(r_{t−1}, s_{t−1})`` and predicts ``(r_t, s_t)``, ``t = 1 … n``, from
the zero state at the track's first frame, as a filter does from its first estimate.

Loss: the squared error of the scaled outputs, ``(Δr / r̄)² + (Δs / s̄)²``, averaged over a track's
steps and then over tracks; the inputs are dropped with probability ``dropout`` (0.25) during
training, masks drawn from the training loop's seeded generator (Jung et al. 2019, Sec. IV-A).
Metrics (test tracks, numpy inference): RMS rotation and speed errors and the mean one-step
position error ``‖x̂_t − x_t‖`` with ``x̂_t`` the predicted step applied to the true ``x_{t−1}`` and
its heading.

Training recipe ([`predictors.training.recipes`][predictors.training.recipes]):
[`recipe`][predictors.displacement_lstm.training.recipe] gives ``track train displacement-lstm``,
[`train_command`][predictors.displacement_lstm.training.train_command] runs it.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from predictors.belt_lstm.training import per_track_mean
from predictors.displacement.geometry import apply_displacement, displacements_of
from predictors.displacement_lstm.inference import KIND, DisplacementFeatures, DisplacementLSTM
from predictors.displacement_lstm.network import DROPOUT, HIDDEN, DisplacementLSTMNet
from predictors.training.data import TrackSet, TrackSplit, pad_tracks
from predictors.training.loop import History, LossFn, TrainConfig, fit, seeded_init, trained_model_file
from predictors.training.model_file import ModelFile
from predictors.training.recipes import TrainingRecipe
from predictors.training.settings import TrainingSettings

FloatArray = NDArray[np.float64]


def fit_features(data: TrackSet, step: float | None = None) -> DisplacementFeatures:
    """Scales ``r̄, s̄`` of the steps ``t >= 1`` of every track of ``data``."""
    parts = [displacements_of(t) for t in data.tracks if len(t) >= 2]
    if not parts:
        raise ValueError("no track has two frames; nothing to learn")
    r = np.concatenate([p.rotation[1:] for p in parts])
    s = np.concatenate([p.speed[1:] for p in parts])
    return DisplacementFeatures.fit(r, s, step)


def displacement_tensors(tracks: list[FloatArray], features: DisplacementFeatures) -> list[torch.Tensor]:
    """``[inputs (B, L−1, 2), targets (B, L−1, 2), mask (B, L−1)]``: scaled ``(r, s)`` of frames
    ``0 … n−1`` as inputs and of frames ``1 … n`` as targets (zero-padded, masked)."""
    scale = np.array([features.rotation_scale, features.speed_scale])
    rs = [np.stack(displacements_of(t)[:2], axis=-1) / scale for t in tracks]
    z, valid = pad_tracks(rs)
    mask = valid[:, 1:] & valid[:, :-1]
    inputs = z[:, :-1] * valid[:, :-1, None]
    targets = z[:, 1:] * mask[..., None]
    return [torch.as_tensor(a, dtype=torch.float32) for a in (inputs, targets, mask)]


def displacement_loss() -> LossFn:
    """Masked mean squared error of the scaled ``(r̂, ŝ)``, with input dropout in training."""

    def loss(model: torch.nn.Module, batch: Any, generator: torch.Generator) -> torch.Tensor:
        inputs, targets, mask = batch
        masks = model.draw_masks(inputs.shape, generator) if model.training else None  # type: ignore[operator]
        err = (model(inputs, masks) - targets).pow(2).sum(dim=-1)
        return per_track_mean(err, mask)

    return loss


def train_displacement_model(
    split: TrackSplit,
    config: TrainConfig,
    *,
    hidden: int = HIDDEN,
    dropout: float = DROPOUT,
    step: float | None = None,
    progress: bool = True,
) -> tuple[DisplacementLSTMNet, DisplacementFeatures, History]:
    """Train a displacement LSTM on ``split`` (train / validation tracks) with
    [`fit`][predictors.training.fit].

    Args:
        step: The data's step ``Δ`` where it has one (recorded in the normalisation).

    Returns:
        The trained network (CPU, eval mode), its scales and the loss history.
    """
    features = fit_features(split.train, step)
    net = seeded_init(lambda: DisplacementLSTMNet(hidden, dropout), config.seed)
    assert isinstance(net, DisplacementLSTMNet)
    validation = displacement_tensors(split.validation.tracks, features) if len(split.validation) else None
    history = fit(
        net,
        displacement_loss(),
        displacement_tensors(split.train.tracks, features),
        validation,
        config,
        progress=progress,
        description=KIND,
    )
    return net, features, history


def to_model_file(net: DisplacementLSTMNet, features: DisplacementFeatures, **meta: Any) -> ModelFile:
    """A [`ModelFile`][predictors.training.ModelFile] of a trained displacement network."""
    return trained_model_file(net, kind=KIND, dim=2, normalisation=features.to_dict(), **meta)


def one_step_errors(model: DisplacementLSTM, tracks: list[FloatArray]) -> dict[str, FloatArray]:
    """One-step predictions of ``model`` along true tracks, batched over tracks.

    Returns ``{"rotation", "speed", "position"}``, each (B, L−1): the errors ``r̂_t − r_t``,
    ``ŝ_t − s_t`` and ``‖x̂_t − x_t‖`` of steps ``t = 1 … n`` (NaN past a track's end; the position
    error also NaN until the track has a heading, i.e. before its second moving step).
    """
    from predictors.displacement.geometry import observe_step

    x, valid = pad_tracks(tracks)
    B, L, _ = x.shape
    d = [displacements_of(t) for t in tracks]
    r = np.zeros((B, L))
    s = np.zeros((B, L))
    for i, di in enumerate(d):
        r[i, : len(di.rotation)], s[i, : len(di.speed)] = di.rotation, di.speed
    out = {k: np.full((B, L - 1), np.nan) for k in ("rotation", "speed", "position")}
    h, c = model.zero_state(B)
    heading, has = np.zeros(B), np.zeros(B, dtype=bool)
    for t in range(1, L):
        r_hat, s_hat, h, c = model.step(r[:, t - 1], s[:, t - 1], h, c)
        if t >= 2:
            _, _, heading, has = observe_step(x[:, t - 1] - x[:, t - 2], heading, has)
        _, x_hat = apply_displacement(heading, x[:, t - 1], r_hat, s_hat)
        ok = valid[:, t]
        out["rotation"][ok, t - 1] = (r_hat - r[:, t])[ok]
        out["speed"][ok, t - 1] = (s_hat - s[:, t])[ok]
        pos = np.linalg.norm(x_hat - x[:, t], axis=1)
        out["position"][ok & has, t - 1] = pos[ok & has]
    return out


def displacement_metrics(model: DisplacementLSTM, tracks: list[FloatArray]) -> dict[str, float]:
    """RMS rotation and speed errors and the mean one-step position error over ``tracks``."""
    e = one_step_errors(model, tracks)
    return {
        "test_rotation_rmse": float(np.sqrt(np.nanmean(e["rotation"] ** 2))),
        "test_speed_rmse": float(np.sqrt(np.nanmean(e["speed"] ** 2))),
        "test_mean_error": float(np.nanmean(e["position"])),
        "test_predictions": int(np.isfinite(e["position"]).sum()),
    }


# ------------------------------------------------------------------ the training recipe

#: ``track train displacement-lstm``'s one-line help.
HELP = (
    "the LSTM particle filter's displacement model (speed and rotation per step; the shipped one: "
    "31 s on 2 CPU cores)"
)


def recipe(kind: str = KIND) -> TrainingRecipe:
    """The training recipe of the displacement LSTM (``track train displacement-lstm``)."""
    if kind != KIND:
        raise ValueError(f"unknown displacement model kind {kind!r}; valid names are {[KIND]}")
    return TrainingRecipe(KIND, HELP, train=train_command)


def train_command(settings: TrainingSettings) -> Path:
    """``track train displacement-lstm``: train on the data ``settings`` names (with an added noise
    std: one seeded noisy copy of each part of the split), compute the test metrics and write
    ``settings.out``; returns the sidecar's path."""
    from predictors.belt_lstm.training import noisy_tracks
    from predictors.training.command import load_data, print_split, train_config, training_record
    from predictors.training.data import split_tracks
    from predictors.training.model_file import save_model

    start = time.perf_counter()
    data = load_data(settings.data)
    split = split_tracks(data, seed=settings.seed, min_length=settings.data.min_length)
    if settings.data.added_noise_std != 0.0:  # one noisy copy per part, seeded
        split = TrackSplit(
            noisy_tracks(split.train, settings.data.added_noise_std, settings.seed),
            noisy_tracks(split.validation, settings.data.added_noise_std, settings.seed + 1),
            noisy_tracks(split.test, settings.data.added_noise_std, settings.seed + 2),
            split.dropped,
            split.min_length,
        )
    s = print_split(len(data), split, settings.data.min_length)
    config = train_config(settings)
    dropout = 0.25 if settings.dropout is None else settings.dropout
    step = settings.data.sine_step if settings.data.sine else settings.data.data_step
    net, features, history = train_displacement_model(
        split, config, hidden=settings.hidden, dropout=dropout, step=step, progress=settings.progress
    )
    test = split.test if len(split.test) else split.validation if len(split.validation) else split.train
    metrics = displacement_metrics(
        DisplacementLSTM.from_model_file(to_model_file(net, features)), test.tracks
    )
    training = training_record(settings, config, history, noise_std=settings.data.added_noise_std)
    training["wall_time_s"] = round(time.perf_counter() - start, 1)
    model = to_model_file(
        net, features, training=training, data={**dict(data.description), **s}, metrics=metrics
    )
    tensor_path, sidecar_path = save_model(settings.out, model)
    print(
        f"wrote {tensor_path} and {sidecar_path} in {training['wall_time_s']:.0f} s; test: one-step position "
        f"error {metrics['test_mean_error']:.3g}, rotation RMSE {metrics['test_rotation_rmse']:.3g} rad, "
        f"speed RMSE {metrics['test_speed_rmse']:.3g}"
    )
    return sidecar_path
