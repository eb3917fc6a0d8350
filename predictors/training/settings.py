"""The settings a training recipe takes: what to train on and how (typed, no command line).

[`DataSettings`][predictors.training.DataSettings] names the tracks (an env's truth, a recorded track file or
the sine) and how they are cut and split; [`TrainingSettings`][predictors.training.TrainingSettings] adds the
training loop's settings, the model file to write and the recipe's own options
([`RecipeOption`][predictors.training.RecipeOption], declared by the recipe). ``track train``
([`track_apps.cli.train`][track_apps.cli.train]) builds them from its arguments; a script builds them
directly::

    from predictors.training.recipes import training_recipe
    from predictors.training.settings import DataSettings, TrainingSettings

    data = DataSettings(sine=True, periods=5.0)
    training_recipe("displacement-lstm").train(
        TrainingSettings("displacement-lstm", out="models/d", data=data, epochs=100)
    )
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class DataSettings:
    """The training data: one of ``env``, ``tracks`` or ``sine``, and how it is cut.

    Attributes:
        env: A point env (or, for ``pose-lstm``, a keypoint env) whose truth gives the tracks.
        env_kwargs: Keyword arguments of ``env``.
        episodes: Env episodes (seeds ``data_seed``, ``data_seed + 1``, ...).
        steps: Frames per env episode (``None``: whole episodes).
        data_seed: Seed of the first env episode.
        tracks: A recorded track file (BeltReplay CSV/zip layout), with ``dt``.
        dt: Frame period of ``tracks``, seconds.
        sine: The noiseless sine of Jung et al. (2019), eq. (5), as one track.
        periods: Sine periods.
        sine_step: The sine's step Δ (recorded as the data's step).
        data_step: The step Δ of env or file data where it has one (``None``: none).
        window: Cut tracks into windows of this many frames (``None``: whole tracks; 128 for the
            sine).
        stride: Frames between window starts.
        added_noise_std: Noise std added to the training positions, or a ``(low, high)`` range
            a per-track std is drawn from.
        min_length: Tracks with fewer frames are dropped.
    """

    env: str | None = None
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    episodes: int = 4
    steps: int | None = None
    data_seed: int = 1000
    tracks: str | None = None
    dt: float | None = None
    sine: bool = False
    periods: float = 25.0
    sine_step: float = 0.2
    data_step: float | None = None
    window: int | None = None
    stride: int = 8
    added_noise_std: float | tuple[float, float] = 0.0
    min_length: int = 5


@dataclass(frozen=True)
class RecipeOption:
    """A setting of one recipe beyond the shared ones (``track train KIND --NAME``).

    Attributes:
        name: The option's name (``"loss"``: ``--loss``; the key in ``TrainingSettings.options``).
        default: Its value when not given.
        help: One line for ``track train KIND --help``.
        choices: Its valid values (``None``: any value of ``type``).
        type: The type a value is read as.
    """

    name: str
    default: Any
    help: str
    choices: tuple[Any, ...] | None = None
    type: type = str


@dataclass(frozen=True)
class TrainingSettings:
    """What a recipe trains, on what, and where it writes the model file.

    Attributes:
        kind: The model kind (the recipe's).
        out: The model file to write (a path without suffix: ``OUT.safetensors`` + ``OUT.json``).
        data: The training data.
        command: The command that trains it, recorded in the sidecar (``training.command``).
        epochs: Training epochs.
        lr: Adam learning rate.
        decay_every: Epochs between learning-rate halvings.
        batch_size: Tracks per step (``None``: all).
        dropout: The kind's dropout rate (``None``: the kind's default; see each recipe).
        hidden: Hidden units of the displacement LSTM.
        dropout_grid: ``mc-lstm``: the dropout rates to search (``None``: no search).
        grid_epochs: Epochs of each run of the dropout grid.
        min_window: ``pose-lstm``: shortest window length a training batch is cut to.
        seed: Seed of the split, the initialisation, the shuffling and the masks.
        device: The torch device (``"cpu"`` or ``"cuda"``).
        progress: Show a progress bar.
        options: The recipe's own options by name ([`RecipeOption`][predictors.training.RecipeOption]; missing
            ones take their defaults).
    """

    kind: str
    out: str
    data: DataSettings = field(default_factory=DataSettings)
    command: str = ""
    epochs: int = 1000
    lr: float = 0.01
    decay_every: int = 200
    batch_size: int | None = None
    dropout: float | None = None
    hidden: int = 25
    dropout_grid: tuple[float, ...] | None = None
    grid_epochs: int = 100
    min_window: int = 3
    seed: int = 0
    device: str = "cpu"
    progress: bool = True
    options: Mapping[str, Any] = field(default_factory=dict)
