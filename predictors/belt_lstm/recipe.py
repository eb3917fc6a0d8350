"""``track train lstm | nll-lstm | mc-lstm``: the belt LSTMs' training recipe (registered in
[`predictors`][predictors]), on top of their training
([`predictors.belt_lstm.training`][predictors.belt_lstm.training]) and model statistics
([`predictors.belt_lstm.model_stats`][predictors.belt_lstm.model_stats])."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

from predictors.belt_lstm.network import HEAD_OUTPUTS
from predictors.belt_lstm.training import to_model_file, train_belt_model
from predictors.training.data import TrackSplit
from predictors.training.loop import TrainConfig
from predictors.training.recipes import TrainingRecipe
from predictors.training.settings import TrainingSettings

#: ``track train KIND``'s one-line help of each belt LSTM kind.
HELP = {
    "lstm": "belt LSTM with a scaled identity covariance chosen by a line search on gnn's e_mean "
    "(the shipped one: 4.3 min on 2 CPU cores)",
    "mc-lstm": "belt LSTM with Monte Carlo (variational) dropout: the epistemic uncertainty "
    "(the shipped one, with its dropout grid: 6.7 min on 2 CPU cores)",
    "nll-lstm": "belt LSTM trained on the Gaussian negative log-likelihood: the aleatoric uncertainty "
    "(the shipped ones: 2.7-9.1 min on 2 CPU cores)",
}


def recipe(kind: str) -> TrainingRecipe:
    """The training recipe of belt LSTM ``kind`` (``lstm``, ``mc-lstm``, ``nll-lstm``)."""
    if kind not in HEAD_OUTPUTS:
        raise ValueError(f"unknown belt LSTM kind {kind!r}; valid names are {sorted(HEAD_OUTPUTS)}")
    return TrainingRecipe(kind, HELP[kind], train=train_command)


def train_command(settings: TrainingSettings) -> Path:
    """``track train lstm | nll-lstm | mc-lstm``: train ``settings.kind`` on the data ``settings``
    names, compute its calibration, MC statistics and test metrics and write ``settings.out``;
    returns the sidecar's path. (``lstm``'s covariance scale is chosen afterwards, by a line search
    that runs a tracker: ``track train lstm`` runs it on the written file.)

    Raises:
        ValueError: ``dropout`` or ``dropout_grid`` for a kind other than ``mc-lstm``, bad
            ``dropout_grid`` rates, too little data.
    """
    from predictors.belt_lstm.model_stats import model_statistics
    from predictors.training.command import load_data, print_split, train_config, training_record, with_meta
    from predictors.training.data import split_tracks
    from predictors.training.model_file import save_model

    start = time.perf_counter()
    data = load_data(settings.data)
    split = split_tracks(data, seed=settings.seed, min_length=settings.data.min_length)
    s = print_split(len(data), split, settings.data.min_length)
    config = train_config(settings)
    if settings.dropout is not None and settings.kind != "mc-lstm":
        raise ValueError(f"--dropout is for mc-lstm and displacement-lstm, not {settings.kind}")
    dropout = (0.002 if settings.dropout is None else settings.dropout) if settings.kind == "mc-lstm" else 0.0
    grid = None
    if settings.dropout_grid is not None:
        if settings.kind != "mc-lstm":
            raise ValueError(f"dropout_grid is for mc-lstm, not {settings.kind}")
        dropout, grid = _grid_search(settings, split, config)
    net, features, history = train_belt_model(
        settings.kind,
        split,
        config,
        dropout=dropout,
        noise_std=settings.data.added_noise_std,
        progress=settings.progress,
    )
    noise = settings.data.added_noise_std
    stats = model_statistics(net, features, split, noise_std=noise, seed=settings.seed)
    training = training_record(settings, config, history, noise_std=settings.data.added_noise_std)
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
    training["wall_time_s"] = round(time.perf_counter() - start, 1)
    tensor_path, sidecar_path = save_model(settings.out, with_meta(model, training=training))
    m = stats["metrics"]
    print(
        f"wrote {tensor_path} and {sidecar_path} in {training['wall_time_s']:.0f} s; test: mean per-track "
        f"error {m['test_mean_error']:.3g}, coverage at 0.999 {m['test_coverage_999']:.4f}"
    )
    return sidecar_path


def _grid_search(
    settings: TrainingSettings, split: TrackSplit, config: TrainConfig
) -> tuple[float, list[dict[str, float]]]:
    """``dropout_grid``: short runs per rate, printed; the rate of the best validation
    predictive log-likelihood and the grid."""
    from predictors.belt_lstm.model_stats import dropout_grid

    rates = [float(r) for r in settings.dropout_grid or ()]
    if not rates or not all(0 < r < 1 for r in rates):
        raise ValueError(f"dropout_grid must hold rates in (0, 1), got {settings.dropout_grid!r}")
    epochs = settings.grid_epochs
    short = dataclasses.replace(config, epochs=epochs, decay_every=max(1, epochs // 5))
    grid = dropout_grid(split, rates, short, noise_std=settings.data.added_noise_std, seed=settings.seed)
    print("dropout grid (validation predictive log-likelihood, mean error):")
    for row in grid:
        ll, err = row["validation_log_likelihood"], row["validation_mean_error"]
        print(f"  {row['dropout']:<8g} {ll:10.4f}  {err:.4g}")
    best = max(grid, key=lambda r: r["validation_log_likelihood"])
    print(f"chose dropout {best['dropout']:g}")
    return float(best["dropout"]), grid
