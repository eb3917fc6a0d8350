"""Training the belt LSTMs (``lstm``, ``nll-lstm``, ``mc-lstm``) on true tracks.

Losses (per step ``t`` of track ``i`` with ``T_i`` steps; ``e = ŷ_t − f_y(x_{t−1})`` in
standardised units, see [`Features`][predictors.belt_lstm.features.Features]), averaged first over a
track's ``T_i − 1`` predictions and then over tracks, as in Pollithy et al. (2020), eq. (7):

* ``lstm``, ``mc-lstm``: ``‖e‖²`` (MSE). ``mc-lstm`` draws one variational dropout mask per track
  and mini-batch (held fixed over the track's time steps);
* ``nll-lstm``: ``½ Σ_d (exp(−s_d) e_d² + s_d)`` with ``s = log σ²`` per axis.

Measurement noise (``noise_std``, sensor units, or a range of per-track stds) is added to the true
positions afresh for every mini-batch (from the training loop's seeded generator), so the model
sees what a tracker sees and cannot memorise one noisy copy; the validation tracks get one fixed
noisy copy, so their loss is comparable between epochs.

Training recipes ([`predictors.training.recipes`][predictors.training.recipes]):
[`recipe`][predictors.belt_lstm.recipe] gives ``track train KIND`` for each of the three kinds,
`train_command` runs one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from predictors.belt_lstm.network import HEAD_OUTPUTS, BeltLSTMNet, Features
from predictors.training.data import TrackSet, TrackSplit, pad_tracks
from predictors.training.loop import History, LossFn, TrainConfig, fit, seeded_init, trained_model_file
from predictors.training.model_file import ModelFile


@dataclass(frozen=True)
class SequenceBatch:
    """Padded training tensors of a set of tracks.

    Attributes:
        inputs: ``(B, T, 2D)`` standardised features.
        targets: ``(B, T − 1, D)`` standardised next displacements.
        mask: ``(B, T − 1)`` 1 where step ``t`` has a next measurement.
        positions: ``(B, T, D)`` the (noisy) positions, sensor units.
    """

    inputs: torch.Tensor
    targets: torch.Tensor
    mask: torch.Tensor
    positions: NDArray[np.float64]

    def tensors(self) -> list[torch.Tensor]:
        """The tensors in the order the losses take them."""
        return [self.inputs, self.targets, self.mask]


#: A noise level: one std for every track, or a ``(low, high)`` range drawn uniformly per track.
NoiseStd = float | tuple[float, float]


def check_noise_std(noise_std: NoiseStd) -> tuple[float, float]:
    """``noise_std`` as a ``(low, high)`` range of per-track stds, validated."""
    if isinstance(noise_std, tuple | list):
        if len(noise_std) != 2:
            raise ValueError(f"a noise_std range must be (low, high), got {noise_std!r}")
        lo, hi = float(noise_std[0]), float(noise_std[1])
    else:
        lo = hi = float(noise_std)
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 <= lo <= hi):
        raise ValueError(
            f"noise_std must be a number >= 0 or a range (low, high) with 0 <= low <= high, got {noise_std!r}"
        )
    return lo, hi


def noisy_tracks(data: TrackSet, noise_std: NoiseStd, seed: int) -> TrackSet:
    """``data`` with Gaussian noise added to every coordinate (generator seeded by ``seed``).

    With a range ``(low, high)`` each track gets its own std drawn uniformly from it, so a model
    trained on the result sees every noise level of the range (and can learn it from the jitter).
    """
    lo, hi = check_noise_std(noise_std)
    if hi == 0:
        return data
    rng = np.random.default_rng(seed)
    stds = rng.uniform(lo, hi, len(data.tracks))
    return data.with_tracks(
        [t + rng.normal(0.0, s, t.shape) for t, s in zip(data.tracks, stds, strict=True)], noise_std=[lo, hi]
    )


def sequence_batch(data: TrackSet, features: Features) -> SequenceBatch:
    """Pad the tracks of ``data`` and compute their standardised inputs and targets."""
    z, valid = pad_tracks(data.tracks)
    inputs = features.sequence_inputs(z) * valid[..., None]
    targets = features.targets(z) * (valid[:, 1:, None])
    mask = valid[:, 1:] & valid[:, :-1]
    return SequenceBatch(
        torch.as_tensor(inputs, dtype=torch.float32),
        torch.as_tensor(targets, dtype=torch.float32),
        torch.as_tensor(mask, dtype=torch.float32),
        z,
    )


def per_track_mean(step_loss: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Mean over each track's valid steps, then over tracks (eq. (7)'s averaging)."""
    steps = mask.sum(dim=1).clamp(min=1.0)
    return ((step_loss * mask).sum(dim=1) / steps).mean()


def _step_loss(kind: str, out: torch.Tensor, targets: torch.Tensor) -> torch.Tensor:
    """Per-step loss (B, T − 1): ``‖e‖²``, or the Gaussian NLL of eq. (7) for ``nll-lstm``."""
    d = targets.shape[-1]
    err = targets - out[..., :d]
    if kind == "nll-lstm":
        s = out[..., d:]
        return 0.5 * (torch.exp(-s) * err.pow(2) + s).sum(dim=-1)
    return err.pow(2).sum(dim=-1)


def belt_loss(kind: str) -> LossFn:
    """The loss of model ``kind`` over a batch ``(inputs, targets, mask)`` of fixed sequences."""

    def loss(model: torch.nn.Module, batch: Any, generator: torch.Generator) -> torch.Tensor:
        inputs, targets, mask = batch
        masks = model.draw_masks(inputs.shape[0], generator) if model.training else None  # type: ignore[operator]
        return per_track_mean(_step_loss(kind, model(inputs[:, :-1], masks), targets), mask)

    return loss


def augmented_belt_loss(kind: str, features: Features, noise_std: NoiseStd) -> LossFn:
    """The loss of ``kind`` on clean region-relative tracks ``(u (B, T, D), valid (B, T))`` with
    fresh measurement noise drawn for every mini-batch (a per-track std uniform in ``noise_std``).

    Drawing new noise each time keeps the network from memorising one noisy copy of the tracks.
    """
    lo, hi = check_noise_std(noise_std)
    size = torch.as_tensor(features.size, dtype=torch.float32)
    in_mean, in_std = (torch.as_tensor(a, dtype=torch.float32) for a in (features.in_mean, features.in_std))
    out_mean, out_std = (
        torch.as_tensor(a, dtype=torch.float32) for a in (features.out_mean, features.out_std)
    )

    def loss(model: torch.nn.Module, batch: Any, generator: torch.Generator) -> torch.Tensor:
        u, valid = batch
        b = u.shape[0]
        std = lo + (hi - lo) * torch.rand(b, 1, 1, generator=generator)
        noisy = u + torch.randn(u.shape, generator=generator) * (std / size)
        du = torch.diff(noisy, dim=1)
        first = torch.zeros_like(noisy[:, :1])
        inputs = (torch.cat([noisy, torch.cat([first, du], dim=1)], dim=-1) - in_mean) / in_std
        inputs = inputs * valid[..., None]
        targets = (du - out_mean) / out_std * valid[:, 1:, None]
        mask = valid[:, 1:] * valid[:, :-1]
        masks = model.draw_masks(b, generator) if model.training else None  # type: ignore[operator]
        return per_track_mean(_step_loss(kind, model(inputs[:, :-1], masks), targets), mask)

    return loss


def region_tracks(data: TrackSet, features: Features) -> list[torch.Tensor]:
    """Clean tracks of ``data`` as region-relative ``u = (z − low)/size`` and their validity mask."""
    z, valid = pad_tracks(data.tracks)
    u = (z - features.low) / features.size * valid[..., None]
    return [torch.as_tensor(u, dtype=torch.float32), torch.as_tensor(valid, dtype=torch.float32)]


def train_belt_model(
    kind: str,
    split: TrackSplit,
    config: TrainConfig,
    *,
    dropout: float = 0.0,
    noise_std: NoiseStd = 0.0,
    progress: bool = True,
) -> tuple[BeltLSTMNet, Features, History]:
    """Train a belt model of ``kind`` on ``split`` (train / validation tracks).

    Returns:
        The trained network (CPU, eval mode), its feature normalisation and the loss history.
    """
    if kind not in HEAD_OUTPUTS:
        raise ValueError(f"kind must be one of {sorted(HEAD_OUTPUTS)}, got {kind!r}")
    # normalisation statistics from one noisy copy; training draws fresh noise every mini-batch
    once = noisy_tracks(split.train, noise_std, config.seed)
    validation = noisy_tracks(split.validation, noise_std, config.seed + 1)
    features = Features.fit(once.tracks, once.region_low, once.region_high)
    dim = once.dim
    net = seeded_init(lambda: BeltLSTMNet(kind, dim, dropout=dropout), config.seed)
    assert isinstance(net, BeltLSTMNet)
    val_batch = sequence_batch(validation, features).tensors() if len(validation) else None
    history = fit(
        net,
        augmented_belt_loss(kind, features, noise_std),
        region_tracks(split.train, features),
        val_batch,
        config,
        progress=progress,
        description=kind,
        validation_loss=belt_loss(kind),
    )
    return net, features, history


def to_model_file(net: BeltLSTMNet, features: Features, **meta: Any) -> ModelFile:
    """A [`ModelFile`][predictors.training.ModelFile] of a trained belt network."""
    return trained_model_file(net, kind=net.kind, dim=net.dim, normalisation=features.to_dict(), **meta)
