"""Training the belt LSTMs (``lstm``, ``nll-lstm``, ``mc-lstm``) on true tracks.

Losses (per step ``t`` of track ``i`` with ``T_i`` steps; ``e = ŷ_t − f_y(x_{t−1})`` in
standardised units, see :class:`~predictors.belt_lstm.network.Features`), averaged first over a
track's ``T_i − 1`` predictions and then over tracks, as in Pollithy et al. (2020), eq. (7):

* ``lstm``, ``mc-lstm``: ``‖e‖²`` (MSE). ``mc-lstm`` draws one variational dropout mask per track
  and mini-batch (held fixed over the track's time steps);
* ``nll-lstm``: ``½ Σ_d (exp(−s_d) e_d² + s_d)`` with ``s = log σ²`` per axis.

Measurement noise (``noise_std``, sensor units, or a range of per-track stds) is added to the true
positions afresh for every mini-batch (from the training loop's seeded generator), so the model
sees what a tracker sees and cannot memorise one noisy copy; the validation tracks get one fixed
noisy copy, so their loss is comparable between epochs.

Training recipes (:mod:`predictors.training.recipes`): :func:`recipe` gives ``track train KIND``
for each of the three kinds, :func:`train_command` runs one.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from predictors.belt_lstm.network import HEAD_OUTPUTS, BeltLSTMNet, Features
from predictors.training.data import TrackSet, TrackSplit, pad_tracks
from predictors.training.loop import History, LossFn, TrainConfig, fit, seeded_init, trained_model_file
from predictors.training.model_file import ModelFile
from predictors.training.recipes import TrainingRecipe, tuner_of


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
    """A :class:`~predictors.training.model_file.ModelFile` of a trained belt network."""
    return trained_model_file(net, kind=net.kind, dim=net.dim, normalisation=features.to_dict(), **meta)


# ------------------------------------------------------------------ the training recipes

#: ``track train KIND``'s one-line help of each belt LSTM kind.
HELP = {
    "lstm": "belt LSTM with a scaled identity covariance chosen by a line search on gnn's e_mean",
    "mc-lstm": "belt LSTM with Monte Carlo (variational) dropout: the epistemic uncertainty",
    "nll-lstm": "belt LSTM trained on the Gaussian negative log-likelihood: the aleatoric uncertainty",
}


def recipe(kind: str) -> TrainingRecipe:
    """The training recipe of belt LSTM ``kind`` (``lstm``, ``mc-lstm``, ``nll-lstm``)."""
    if kind not in HEAD_OUTPUTS:
        raise ValueError(f"unknown belt LSTM kind {kind!r}; valid names are {sorted(HEAD_OUTPUTS)}")
    return TrainingRecipe(kind, HELP[kind], train=train_command)


def train_command(args: argparse.Namespace) -> Path:
    """``track train lstm | nll-lstm | mc-lstm``: train ``args.model`` on the data ``args`` names,
    compute its calibration, MC statistics and test metrics, run the kind's post-training step
    (:func:`~predictors.training.recipes.tuner_of`: ``lstm``'s covariance line search) and write
    ``args.out``; returns the sidecar's path.

    Raises:
        ValueError: ``--dropout`` or ``--dropout-grid`` for a kind other than ``mc-lstm``, bad
            ``--dropout-grid`` rates, too little data.
    """
    from predictors.belt_lstm.model_stats import model_statistics
    from predictors.training.command import load_data, print_split, train_config, training_record, with_meta
    from predictors.training.data import split_tracks
    from predictors.training.model_file import load_model, save_model

    start = time.perf_counter()
    data = load_data(args)
    split = split_tracks(data, seed=args.seed, min_length=args.min_length)
    s = print_split(len(data), split, args.min_length)
    config = train_config(args)
    if args.dropout is not None and args.model != "mc-lstm":
        raise ValueError(f"--dropout is for mc-lstm and displacement-lstm, not {args.model}")
    dropout = (0.002 if args.dropout is None else args.dropout) if args.model == "mc-lstm" else 0.0
    grid = None
    if args.dropout_grid is not None:
        if args.model != "mc-lstm":
            raise ValueError(f"--dropout-grid is for mc-lstm, not {args.model}")
        dropout, grid = _grid_search(args, split, config)
    net, features, history = train_belt_model(
        args.model,
        split,
        config,
        dropout=dropout,
        noise_std=args.added_noise_std,
        progress=not args.no_progress,
    )
    stats = model_statistics(net, features, split, noise_std=args.added_noise_std, seed=args.seed)
    training = training_record(args, config, history, noise_std=args.added_noise_std)
    if grid is not None:
        training["dropout_grid"] = grid
    model = to_model_file(
        net,
        features,
        calibration=stats["calibration"],
        mc=stats["mc"],
        training=training,
        data={**dict(data.description), **s},
        metrics=stats["metrics"],
    )
    tensor_path, sidecar_path = save_model(args.out, model)
    tune = tuner_of(args.model)
    if tune is not None:
        training["tuning"] = tune(sidecar_path, args)
        model = load_model(sidecar_path)
    training["wall_time_s"] = round(time.perf_counter() - start, 1)
    save_model(args.out, with_meta(model, training=training))
    m = stats["metrics"]
    print(
        f"wrote {tensor_path} and {sidecar_path} in {training['wall_time_s']:.0f} s; test: mean per-track "
        f"error {m['test_mean_error']:.3g}, coverage at 0.999 {m['test_coverage_999']:.4f}"
    )
    return sidecar_path


def _grid_search(
    args: argparse.Namespace, split: TrackSplit, config: TrainConfig
) -> tuple[float, list[dict[str, float]]]:
    """``--dropout-grid``: short runs per rate, printed; the rate of the best validation
    predictive log-likelihood and the grid."""
    from predictors.belt_lstm.model_stats import dropout_grid

    try:
        rates = [float(r) for r in args.dropout_grid.split(",") if r.strip()]
    except ValueError:
        raise ValueError(f"--dropout-grid must be comma-separated rates, got {args.dropout_grid!r}") from None
    if not rates or not all(0 < r < 1 for r in rates):
        raise ValueError(f"--dropout-grid rates must be in (0, 1), got {args.dropout_grid!r}")
    short = dataclasses.replace(config, epochs=args.grid_epochs, decay_every=max(1, args.grid_epochs // 5))
    grid = dropout_grid(split, rates, short, noise_std=args.added_noise_std, seed=args.seed)
    print("dropout grid (validation predictive log-likelihood, mean error):")
    for row in grid:
        ll, err = row["validation_log_likelihood"], row["validation_mean_error"]
        print(f"  {row['dropout']:<8g} {ll:10.4f}  {err:.4g}")
    best = max(grid, key=lambda r: r["validation_log_likelihood"])
    print(f"chose dropout {best['dropout']:g}")
    return float(best["dropout"]), grid
