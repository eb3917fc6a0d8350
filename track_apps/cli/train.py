"""``track train``: train a learned motion model on env truth, a track file
or the sine, or recalibrate one.

Model kinds (one subcommand each) are the training recipes registered beside the predictors
([`predictors.available_recipes`][predictors.available_recipes],
[`predictors.training.recipes`][predictors.training.recipes]): the belt LSTMs (``lstm``, ``nll-lstm``,
``mc-lstm``, [`predictors.belt_lstm.training`][predictors.belt_lstm.training]), the displacement LSTM of the
LSTM particle filter (``displacement-lstm``,
[`predictors.displacement_lstm.training`][predictors.displacement_lstm.training]) and the probabilistic pose
predictor of the SMC pose tracker (``pose-lstm``,
[`predictors.pose_lstm.training`][predictors.pose_lstm.training]). Each subcommand takes the shared data and
training arguments and its recipe's own options, turns them into the recipe's typed settings
([`training_settings`][track_apps.cli.train.training_settings],
[`predictors.training.settings`][predictors.training.settings]) and runs the recipe's ``train``; a newly
registered recipe is a new subcommand. ``calibrate`` refits a model file's covariance scale on the tracks it
is given (calibration data: tracks the model was not trained on; the reliability curves it plots are of those
same tracks).

The output is ``OUT.safetensors`` + ``OUT.json`` (see
[`predictors.training.model_file`][predictors.training.model_file]); pass it to a tracker as
``make_agent("gnn", predictor="nll-lstm", weights="OUT")``, or a displacement model to the particle filter as
``make_agent("pf", model="lstm", model_weights="OUT")``.

``lstm`` runs the covariance line search on ``gnn`` after training
([`track_apps.lstm_line_search`][track_apps.lstm_line_search], its post-training step:
[`POST_TRAINING`][track_apps.cli.train.POST_TRAINING]), on the model file the recipe wrote.
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from predictors.training.command import load_data, with_meta
from predictors.training.model_file import ModelFile
from predictors.training.recipes import available_recipes, training_recipe
from predictors.training.settings import DataSettings, TrainingSettings
from track_apps.cli import arguments
from track_apps.lstm_line_search import lstm_tuner

#: The steps after training that run a tracker, by model kind: ``step(model_path, settings)``
#: may rewrite the model file and returns the record the sidecar keeps as ``training.tuning``.
POST_TRAINING: dict[str, Callable[[Path, TrainingSettings], dict[str, Any]]] = {"lstm": lstm_tuner}

PROG = "track train"

EPILOG = """\
examples:
  track train nll-lstm --env BeltSorter-v0 --env-kwargs particle_kind=cylinder --episodes 4 \\
      --epochs 1000 --out models/nll-lstm-cylinder
  track train nll-lstm --env BeltSorter-v0 --env-kwargs particle_kind=sphere,noise_std=1e-4 \\
      --added-noise-std 1e-4:3e-4 --out models/nll-lstm-sphere
  track train lstm --tracks my_recording.zip --dt 0.005 --epochs 300 --out models/my-lstm
  track train mc-lstm --env BeltSorter-v0 --episodes 2 --dropout 0.002 --out models/mc
  track train mc-lstm --env BeltSorter-v0 --dropout-grid 0.001,0.002,0.005 --grid-epochs 50 --out models/mc
  track train calibrate models/nll-lstm-cylinder --env BeltSorter-v0 --data-seed 5000 \\
      --added-noise-std 1e-4 --plot reliability.png
  track train displacement-lstm --sine --window 128 --stride 8 --epochs 1000 --decay-every 250 \\
      --batch-size 16 --out models/displacement-lstm-sine
  track train displacement-lstm --env PiecewiseTarget-v0 --episodes 8 --window 128 --out models/pw
  track train pose-lstm --env KeypointWalkers-v0 --episodes 16 --window 15 --epochs 40 --lr 1e-3 \\
      --batch-size 30 --out models/pose-lstm

Model kinds: lstm, nll-lstm, mc-lstm (belt LSTMs; lstm also runs the covariance line search on
gnn after training), displacement-lstm (the particle filter's displacement model), pose-lstm (the
SMC pose tracker's predictor); 'calibrate' refits a model file's covariance scale. The output is
OUT.safetensors + OUT.json: pass it to a tracker as make_agent("gnn", predictor="nll-lstm",
weights="OUT") or make_agent("pf", model="lstm", model_weights="OUT").
Time on a 2-core CPU machine, the shipped models' recorded commands (their JSON's
training.wall_time_s): lstm 4.3 min, nll-lstm 2.7-9.1 min, mc-lstm 6.7 min (400 epochs on one
BeltSorter-v0 episode), calibrate 6-43 s, displacement-lstm 31 s (the sine), pose-lstm 11-20 min
(10 KeypointWalkers-v0 episodes, 40 epochs); more data or epochs take longer.
--added-noise-std is noise added to the training positions; --env-kwargs are the env's own kwargs
(comma-separated).
"""


def _data_parser() -> argparse.ArgumentParser:
    """The data arguments shared by every model kind and ``calibrate``."""
    p = argparse.ArgumentParser(add_help=False)
    src = p.add_mutually_exclusive_group(required=True)
    arguments.add_env(src, help="a point env whose truth gives the tracks, e.g. BeltSorter-v0")
    src.add_argument("--tracks", help="a recorded track file (BeltReplay CSV/zip layout)")
    src.add_argument(
        "--sine",
        action="store_true",
        help="the noiseless sine x_t = (t*step, sin(t*step)) of Jung et al. (2019), eq. (5), as one track",
    )
    p.add_argument("--periods", type=float, default=25.0, help="--sine: sine periods (default 25)")
    p.add_argument(
        "--sine-step", type=float, default=0.2, help="--sine: the step Δ (recorded as the data's step)"
    )
    p.add_argument(
        "--data-step",
        type=float,
        default=None,
        help="the step Δ of --env / --tracks data where it has one (a displacement model records it, so a "
        "filter with another Δ rescales speeds)",
    )
    p.add_argument(
        "--window",
        type=int,
        default=None,
        help="cut tracks into windows of this many frames (default: whole tracks; 128 for --sine)",
    )
    p.add_argument("--stride", type=int, default=8, help="frames between --window starts (default 8)")
    arguments.add_env_kwargs(p, help="keyword arguments of --env")
    p.add_argument("--episodes", type=int, default=4, help="env episodes (seeds --data-seed, +1, ...)")
    p.add_argument("--steps", type=int, default=None, help="frames per env episode (default: whole)")
    p.add_argument("--data-seed", type=int, default=1000, help="seed of the first env episode (default 1000)")
    p.add_argument("--dt", type=float, default=None, help="frame period of --tracks, seconds")
    arguments.add_added_noise(p)
    p.add_argument("--min-length", type=int, default=5, help="drop tracks with fewer frames (default 5)")
    return p


def _training_parser() -> argparse.ArgumentParser:
    """The training arguments shared by every model kind."""
    p = argparse.ArgumentParser(add_help=False)
    p.add_argument("--epochs", type=int, default=1000, help="training epochs (default 1000)")
    p.add_argument("--lr", type=float, default=0.01, help="Adam learning rate (default 0.01)")
    p.add_argument(
        "--decay-every", type=int, default=200, help="epochs between learning-rate halvings (default 200)"
    )
    p.add_argument("--batch-size", type=int, default=None, help="tracks per step (default: all)")
    p.add_argument(
        "--dropout",
        type=float,
        default=None,
        help="mc-lstm: variational dropout rate (default 0.002); displacement-lstm: input dropout rate "
        "(default 0.25); pose-lstm: dropout of the FC block (default 0.3)",
    )
    p.add_argument("--hidden", type=int, default=25, help="displacement-lstm hidden units (default 25)")
    p.add_argument(
        "--dropout-grid",
        type=arguments.parse_rates,
        default=None,
        metavar="R1,R2,...",
        help="mc-lstm: train once per rate for --grid-epochs, keep the rate of the best validation "
        "predictive log-likelihood, then train it fully (overrides --dropout)",
    )
    p.add_argument(
        "--min-window",
        type=int,
        default=3,
        help="pose-lstm: shortest window length a training batch is cut to (the longest is --window)",
    )
    p.add_argument("--grid-epochs", type=int, default=100, help="epochs of each --dropout-grid run")
    arguments.add_seed(p, help="split, initialisation, shuffling, masks")
    p.add_argument("--device", choices=("cpu", "cuda"), default="cpu", help="torch device (default cpu)")
    arguments.add_out(p, kind="stem", help="the model file", required=True)
    arguments.add_no_progress(p)
    return p


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The argument parser of ``track train`` (``prog``: the name it answers to)."""
    parser = argparse.ArgumentParser(
        prog=prog,
        description="Train a learned motion model (belt LSTMs lstm, nll-lstm, mc-lstm; the particle "
        "filter's displacement-lstm; the pose tracker's pose-lstm) and write a model file, or "
        "recalibrate one (calibrate).",
        epilog=EPILOG.replace(PROG + " ", prog + " "),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    kinds = available_recipes()
    sub = parser.add_subparsers(
        dest="model", required=True, metavar="{" + ",".join([*kinds, "calibrate"]) + "}"
    )
    data, training = _data_parser(), _training_parser()
    for kind in kinds:
        recipe = training_recipe(kind)
        k = sub.add_parser(kind, parents=[data, training], help=recipe.help, description=recipe.help)
        for option in recipe.options:
            k.add_argument(
                f"--{option.name}",
                type=option.type,
                choices=option.choices,
                default=option.default,
                help=option.help,
            )
    p = sub.add_parser(
        "calibrate",
        parents=[data],
        help="refit a model file's covariance scale factor r on calibration tracks (not trained on)",
        description="Refit a model file's covariance scale factor r on calibration tracks, data the model "
        "was not trained on (p_des = 0.999), and plot the reliability curves on those tracks before "
        "(r = 1) and after (the fitted r).",
    )
    p.add_argument("model_file", help="the model file to recalibrate (rewritten in place unless --out)")
    arguments.add_seed(p, help="noise and mc-lstm masks")
    p.add_argument(
        "--plot", default=None, help="PNG of the reliability curves (default: MODEL.reliability.png)"
    )
    arguments.add_out(p, kind="stem", help="write the recalibrated model here instead of in place")
    return parser


def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    """Entry point of ``track train`` (``prog``: the name it answers to); returns
    the exit code (2 on bad input)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser(prog).parse_args(argv)
    args.prog = prog
    args.command = f"{prog} " + shlex.join(argv)
    try:
        if args.model == "calibrate":
            return _calibrate(args)
        train(training_settings(args))
        return 0
    except ValueError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2


def data_settings(args: argparse.Namespace) -> DataSettings:
    """The data settings of ``track train``'s data arguments."""
    return DataSettings(
        env=args.env,
        env_kwargs=dict(args.env_kwargs),
        episodes=args.episodes,
        steps=args.steps,
        data_seed=args.data_seed,
        tracks=args.tracks,
        dt=args.dt,
        sine=args.sine,
        periods=args.periods,
        sine_step=args.sine_step,
        data_step=args.data_step,
        window=args.window,
        stride=args.stride,
        added_noise_std=args.added_noise_std,
        min_length=args.min_length,
    )


def training_settings(args: argparse.Namespace) -> TrainingSettings:
    """The settings of ``track train KIND``'s arguments (the recipe's own options by name)."""
    options = training_recipe(args.model).options
    return TrainingSettings(
        kind=args.model,
        out=args.out,
        data=data_settings(args),
        command=args.command,
        epochs=args.epochs,
        lr=args.lr,
        decay_every=args.decay_every,
        batch_size=args.batch_size,
        dropout=args.dropout,
        hidden=args.hidden,
        dropout_grid=args.dropout_grid,
        grid_epochs=args.grid_epochs,
        min_window=args.min_window,
        seed=args.seed,
        device=args.device,
        progress=not args.no_progress,
        options={o.name: vars(args)[o.name.replace("-", "_")] for o in options},
    )


def train(settings: TrainingSettings) -> Path:
    """Train with the recipe of ``settings.kind``, then run the kind's step after training
    ([`POST_TRAINING`][track_apps.cli.train.POST_TRAINING]) on the model file written, recording it in
    ``training.tuning`` (with the wall time grown by the step's); returns the sidecar's path."""
    from predictors.training.model_file import load_model, save_model

    sidecar = Path(training_recipe(settings.kind).train(settings))
    step = POST_TRAINING.get(settings.kind)
    if step is None:
        return sidecar
    training = dict(load_model(sidecar).meta.get("training", {}))
    wall = float(training.pop("wall_time_s", 0.0))
    search = time.perf_counter()
    training["tuning"] = step(sidecar, settings)
    training["wall_time_s"] = round(wall + time.perf_counter() - search, 1)
    save_model(settings.out, with_meta(load_model(sidecar), training=training))
    return sidecar


def _calibrate(args: argparse.Namespace) -> int:
    from predictors.belt_lstm.model_stats import predictions_of
    from predictors.training.calibration import (
        P_DES,
        coverage,
        fit_recalibration,
        plot_reliability,
        reliability,
    )
    from predictors.training.data import split_tracks
    from predictors.training.model_file import save_model

    model = _reload(args.model_file)
    data = load_data(data_settings(args))
    tracks = split_tracks(data, fractions=(1.0, 0.0, 0.0), seed=args.seed, min_length=args.min_length).train
    uncalibrated = with_meta(model, calibration={**model.meta.get("calibration", {}), "scale": 1.0})
    before = predictions_of(uncalibrated, tracks, args.added_noise_std, args.seed)
    cal = fit_recalibration(*before.flat(), p_des=P_DES)
    calibration = {
        **model.meta.get("calibration", {}),
        "scale": cal.scale,
        "p_des": P_DES,
        "command": args.command,
        "data": {**dict(data.description), "tracks": len(tracks)},
        "predictions": len(before.valid_d2()),
    }
    scaled = with_meta(model, calibration=calibration)
    after = predictions_of(scaled, tracks, args.added_noise_std, args.seed)
    plot = Path(args.plot) if args.plot else Path(str(model.path).removesuffix(".json") + ".reliability.png")
    cover_before = coverage(before.valid_d2(), P_DES, model.dim)
    cover_after = coverage(after.valid_d2(), P_DES, model.dim)
    labels = calibrate_labels(cal.scale, cover_before, cover_after)
    curves = {labels[0]: reliability(*before.flat()), labels[1]: reliability(*after.flat())}
    plot_reliability(curves, plot, title=f"{model.kind}: reliability on {len(tracks)} calibration tracks")
    out = args.out or str(model.path)
    save_model(out, scaled)
    old = model.meta.get("calibration", {}).get("scale", 1.0)
    print(f"r = {cal.scale:.4g} (was {old:.4g}); curves: {labels[0]}; {labels[1]}; wrote {out} and {plot}")
    return 0


def calibrate_labels(scale: float, cover_before: float, cover_after: float) -> tuple[str, str]:
    """The labels of ``calibrate``'s two reliability curves, with the factors it prints
    (``r`` to 4 significant digits, as the summary line; coverage at p_des = 0.999 on the same
    calibration tracks)."""
    return (
        f"before (r = 1, coverage@0.999 {cover_before:.4f})",
        f"after (r = {scale:.4g}, coverage@0.999 {cover_after:.4f})",
    )


def _reload(path: str | os.PathLike[str]) -> ModelFile:
    from predictors.training.model_file import load_model

    return load_model(path)
