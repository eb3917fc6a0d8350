"""What every training recipe's ``train(settings)`` shares: the data its settings name, the printed
split, the [`TrainConfig`][predictors.training.TrainConfig] and the sidecar's ``training`` record.

The settings ([`predictors.training.settings`][predictors.training.settings]): the data (an env's truth, a
track file or the sine, and their options), the training loop's settings and the command, as typed (``track
train KIND ...``, [`track_apps.cli.train`][track_apps.cli.train], builds them from its arguments).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

from predictors.training.settings import DataSettings, TrainingSettings

if TYPE_CHECKING:
    from predictors.training.data import TrackSet
    from predictors.training.loop import History, TrainConfig
    from predictors.training.model_file import ModelFile


def load_data(data: DataSettings) -> TrackSet:
    """The tracks ``data`` names (an env's truth, the sine, or a track file with its ``dt``), cut
    into ``window`` frames every ``stride`` where asked (the sine: 128 by default).

    Raises:
        ValueError: ``--tracks`` without ``--dt``.
    """
    from predictors.training.data import sine_tracks, tracks_from_env, tracks_from_file, window_tracks

    if data.env:
        tracks = tracks_from_env(
            data.env,
            episodes=data.episodes,
            seed=data.data_seed,
            steps=data.steps,
            **data.env_kwargs,
        )
    elif data.sine:
        tracks = sine_tracks(data.periods, data.sine_step)
    else:
        if data.dt is None:
            raise ValueError("--tracks needs --dt (the recording's frame period in seconds)")
        tracks = tracks_from_file(data.tracks, dt=data.dt)  # type: ignore[arg-type]
    window = data.window
    if window is None and data.sine:
        window = 128
    return tracks if window is None else window_tracks(tracks, window, data.stride)


def print_split(n_tracks: int, split: Any, min_length: int) -> dict[str, int]:
    """Print how the tracks were split and how many were too short; returns the split's summary."""
    s: dict[str, int] = split.summary()
    print(
        f"{n_tracks} tracks: {s['train_tracks']} train, {s['validation_tracks']} validation, "
        f"{s['test_tracks']} test; {s['dropped_short_tracks']} shorter than {min_length} frames dropped"
    )
    return s


def training_record(
    settings: TrainingSettings, config: TrainConfig, history: History, **extra: Any
) -> dict[str, Any]:
    """The sidecar's ``training`` entry: the exact command, the
    [`TrainConfig`][predictors.training.TrainConfig], the command's own settings ``extra`` and the loss
    history (the caller adds the wall time)."""
    return {
        "command": settings.command,
        "config": {k: getattr(config, k) for k in config.__dataclass_fields__},
        **extra,
        "history": history.to_dict(),
    }


def train_config(settings: TrainingSettings) -> TrainConfig:
    """The [`TrainConfig`][predictors.training.TrainConfig] of the training settings."""
    from predictors.training.loop import TrainConfig

    return TrainConfig(
        epochs=settings.epochs,
        lr=settings.lr,
        decay_every=settings.decay_every,
        batch_size=settings.batch_size,
        seed=settings.seed,
        device=settings.device,
    )


def with_meta(model: ModelFile, **entries: Any) -> ModelFile:
    """``model`` with its sidecar entries ``entries`` replaced."""
    return dataclasses.replace(model, meta={**model.meta, **entries})
