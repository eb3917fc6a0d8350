"""What every training recipe's ``train(args)`` shares: the data its arguments name, the printed
split, the :class:`~predictors.training.loop.TrainConfig` and the sidecar's ``training`` record.

``args`` is the namespace of ``track train KIND`` (:mod:`track_apps.cli.train`): the data arguments
(``--env`` / ``--tracks`` / ``--sine`` and their options), the training arguments (``--epochs``,
``--lr``, ...) and ``args.command``, the command line as typed.
"""

from __future__ import annotations

import argparse
import dataclasses
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from predictors.training.data import TrackSet
    from predictors.training.loop import History, TrainConfig
    from predictors.training.model_file import ModelFile


def load_data(args: argparse.Namespace) -> TrackSet:
    """The tracks named by the data arguments (``--env ...``, ``--sine`` or ``--tracks FILE --dt DT``),
    cut into ``--window`` frames every ``--stride`` where asked (``--sine``: 128 by default).

    Raises:
        ValueError: ``--tracks`` without ``--dt``.
    """
    from predictors.training.data import sine_tracks, tracks_from_env, tracks_from_file, window_tracks

    if args.env:
        data = tracks_from_env(
            args.env,
            episodes=args.episodes,
            seed=args.data_seed,
            steps=args.steps,
            **args.env_kwargs,
        )
    elif getattr(args, "sine", False):
        data = sine_tracks(args.periods, args.sine_step)
    else:
        if args.dt is None:
            raise ValueError("--tracks needs --dt (the recording's frame period in seconds)")
        data = tracks_from_file(args.tracks, dt=args.dt)
    window = getattr(args, "window", None)
    if window is None and getattr(args, "sine", False):
        window = 128
    return data if window is None else window_tracks(data, window, args.stride)


def print_split(n_tracks: int, split: Any, min_length: int) -> dict[str, int]:
    """Print how the tracks were split and how many were too short; returns the split's summary."""
    s: dict[str, int] = split.summary()
    print(
        f"{n_tracks} tracks: {s['train_tracks']} train, {s['validation_tracks']} validation, "
        f"{s['test_tracks']} test; {s['dropped_short_tracks']} shorter than {min_length} frames dropped"
    )
    return s


def training_record(
    args: argparse.Namespace, config: TrainConfig, history: History, **extra: Any
) -> dict[str, Any]:
    """The sidecar's ``training`` entry: the exact command, the :class:`TrainConfig`, the
    command's own settings ``extra`` and the loss history (the caller adds the wall time)."""
    return {
        "command": args.command,
        "config": {k: getattr(config, k) for k in config.__dataclass_fields__},
        **extra,
        "history": history.to_dict(),
    }


def train_config(args: argparse.Namespace) -> TrainConfig:
    """The :class:`~predictors.training.loop.TrainConfig` of the training arguments."""
    from predictors.training.loop import TrainConfig

    return TrainConfig(
        epochs=args.epochs,
        lr=args.lr,
        decay_every=args.decay_every,
        batch_size=args.batch_size,
        seed=args.seed,
        device=args.device,
    )


def with_meta(model: ModelFile, **entries: Any) -> ModelFile:
    """``model`` with its sidecar entries ``entries`` replaced."""
    return dataclasses.replace(model, meta={**model.meta, **entries})
