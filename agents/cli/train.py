"""``track train`` (alias ``track-train``): train a learned motion model on env truth, a track file
or the sine, recalibrate one, and for ``lstm`` choose its covariance by a line search on a tracker.

Model kinds (one subcommand each): the belt LSTMs (``lstm``, ``nll-lstm``, ``mc-lstm``,
:mod:`predictors.belt_lstm.training`), the displacement LSTM of the LSTM particle filter
(``displacement-lstm``, :mod:`predictors.displacement_lstm.training`) and the probabilistic pose
predictor of the SMC pose tracker (``pose-lstm``, :mod:`predictors.pose_lstm.training`);
``calibrate`` refits a model file's covariance scale on the tracks it is given (calibration data:
tracks the model was not trained on; the reliability curves it plots are of those same tracks).

The output is ``OUT.safetensors`` + ``OUT.json`` (see :mod:`predictors.training.model_file`); pass it to a
tracker as ``make_agent("gnn", predictor="nll-lstm", weights="OUT")``, or a displacement model to
the particle filter as ``make_agent("pf", model="lstm", model_weights="OUT")``.

**The lstm line search.** The plain LSTM predicts no uncertainty; Pollithy et al. (2020, Sec. IV-D)
give it a scaled identity covariance ``s·I`` and choose the scale by a line search for the best
association accuracy. Here the candidates are ``s = f · s₀`` for factors ``f`` on a log grid around
``s₀``, the mean squared one-step error per axis on the validation tracks (what training stores as
``calibration.cov_scale``); each candidate tracks validation episodes (not trained on, but the
search picks its scale on them) with ``gnn`` and the scale with
the lowest mean e_mean (ties: the one nearest ``s₀``) is written back to the model file, with the
whole search in ``training.tuning`` (:func:`line_search`, run after every ``track train lstm``).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shlex
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from agents.cli import arguments
from predictors.belt_lstm.network import HEAD_OUTPUTS
from predictors.displacement_lstm.inference import KIND as DISPLACEMENT_KIND
from predictors.pose_lstm.predictor import KIND as POSE_KIND
from predictors.pose_lstm.training import LOSSES as POSE_LOSSES
from predictors.training.model_file import ModelFile

if TYPE_CHECKING:
    from predictors.training.data import TrackSet

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
--added-noise-std is noise added to the training positions (--noise-std: its deprecated alias);
--env-kwargs are the env's own kwargs (comma-separated; the old space-separated form still works,
with a warning).
"""

#: One line per model kind (the subcommands' help).
KINDS = {
    "lstm": "belt LSTM with a scaled identity covariance chosen by a line search on gnn's e_mean",
    "mc-lstm": "belt LSTM with Monte Carlo (variational) dropout: the epistemic uncertainty",
    "nll-lstm": "belt LSTM trained on the Gaussian negative log-likelihood: the aleatoric uncertainty",
    DISPLACEMENT_KIND: "the LSTM particle filter's displacement model (speed and rotation per step)",
    POSE_KIND: "the SMC pose tracker's probabilistic pose predictor (KeypointWalkers-v0)",
}


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
    arguments.add_env_kwargs(p, help="keyword arguments of --env", legacy_space_separated=True)
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
    sub = parser.add_subparsers(
        dest="model", required=True, metavar="{" + ",".join([*KINDS, "calibrate"]) + "}"
    )
    data, training = _data_parser(), _training_parser()
    for kind in [*sorted(HEAD_OUTPUTS), DISPLACEMENT_KIND, POSE_KIND]:
        k = sub.add_parser(kind, parents=[data, training], help=KINDS[kind], description=KINDS[kind])
        if kind == POSE_KIND:
            k.add_argument(
                "--loss",
                choices=POSE_LOSSES,
                default="nll",
                help="nll: the Gaussian negative log-likelihood of eq. (8), mu and sigma learnt "
                "(default); mse: the squared error of mu alone (sigma is then the model file's "
                "fixed_sigma, the validation RMS residual)",
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


#: ``tune(model_file_path, args) -> dict``: a post-training step for a model kind (the ``lstm``
#: covariance line search, :func:`lstm_tuner`); it may rewrite the model file and returns entries
#: for the log.
Tuner = Callable[[Path, argparse.Namespace], dict[str, Any]]


def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    """Entry point of ``track train`` (``prog``: the name it answers to, e.g. ``track-train``);
    returns the exit code (2 on bad input)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser(prog).parse_args(argv)
    args.prog = prog
    try:
        if args.model == "calibrate":
            return _calibrate(args, argv)
        if args.model == DISPLACEMENT_KIND:
            return _train_displacement(args, argv)
        if args.model == POSE_KIND:
            return _train_pose(args, argv)
        return _train(args, argv, TUNERS.get(args.model))
    except ValueError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2


def load_data(args: argparse.Namespace) -> TrackSet:
    """The tracks named by the data arguments (``--env ...`` or ``--tracks FILE --dt DT``)."""
    from predictors.displacement_lstm.training import sine_tracks, window_tracks
    from predictors.training.data import tracks_from_env, tracks_from_file

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


def _train(args: argparse.Namespace, argv: list[str], tune: Tuner | None) -> int:
    from predictors.belt_lstm.model_stats import model_statistics
    from predictors.belt_lstm.training import to_model_file, train_belt_model
    from predictors.training.data import split_tracks
    from predictors.training.model_file import save_model

    start = time.perf_counter()
    data = load_data(args)
    split = split_tracks(data, seed=args.seed, min_length=args.min_length)
    s = _print_split(len(data), split, args.min_length)
    config = _train_config(args)
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
    training = _training_record(args, argv, config, history, noise_std=args.added_noise_std)
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
    if tune is not None:
        training["tuning"] = tune(sidecar_path, args)
        model = _reload(sidecar_path)
    training["wall_time_s"] = round(time.perf_counter() - start, 1)
    save_model(args.out, _with_meta(model, training=training))
    m = stats["metrics"]
    print(
        f"wrote {tensor_path} and {sidecar_path} in {training['wall_time_s']:.0f} s; test: mean per-track "
        f"error {m['test_mean_error']:.3g}, coverage at 0.999 {m['test_coverage_999']:.4f}"
    )
    return 0


def _train_displacement(args: argparse.Namespace, argv: list[str]) -> int:
    from predictors.belt_lstm.training import noisy_tracks
    from predictors.displacement_lstm.inference import DisplacementLSTM
    from predictors.displacement_lstm.training import (
        displacement_metrics,
        to_model_file,
        train_displacement_model,
    )
    from predictors.training.data import TrackSplit, split_tracks
    from predictors.training.model_file import save_model

    start = time.perf_counter()
    data = load_data(args)
    split = split_tracks(data, seed=args.seed, min_length=args.min_length)
    if args.added_noise_std != 0.0:  # one noisy copy per part, seeded
        split = TrackSplit(
            noisy_tracks(split.train, args.added_noise_std, args.seed),
            noisy_tracks(split.validation, args.added_noise_std, args.seed + 1),
            noisy_tracks(split.test, args.added_noise_std, args.seed + 2),
            split.dropped,
            split.min_length,
        )
    s = _print_split(len(data), split, args.min_length)
    config = _train_config(args)
    dropout = 0.25 if args.dropout is None else args.dropout
    step = args.sine_step if args.sine else args.data_step
    net, features, history = train_displacement_model(
        split, config, hidden=args.hidden, dropout=dropout, step=step, progress=not args.no_progress
    )
    test = split.test if len(split.test) else split.validation if len(split.validation) else split.train
    metrics = displacement_metrics(
        DisplacementLSTM.from_model_file(to_model_file(net, features)), test.tracks
    )
    training = _training_record(args, argv, config, history, noise_std=args.added_noise_std)
    training["wall_time_s"] = round(time.perf_counter() - start, 1)
    model = to_model_file(
        net, features, training=training, data={**dict(data.description), **s}, metrics=metrics
    )
    tensor_path, sidecar_path = save_model(args.out, model)
    print(
        f"wrote {tensor_path} and {sidecar_path} in {training['wall_time_s']:.0f} s; test: one-step position "
        f"error {metrics['test_mean_error']:.3g}, rotation RMSE {metrics['test_rotation_rmse']:.3g} rad, "
        f"speed RMSE {metrics['test_speed_rmse']:.3g}"
    )
    return 0


def _train_pose(args: argparse.Namespace, argv: list[str]) -> int:
    import numpy as np

    from predictors.pose_lstm.predictor import SCALE_PER_HEIGHT
    from predictors.pose_lstm.training import (
        pose_metrics,
        pose_windows_from_env,
        to_model_file,
        train_pose_model,
    )
    from predictors.training.model_file import save_model

    if not args.env:
        raise ValueError(
            "pose-lstm trains on a keypoint env's detections and truth; pass --env KeypointWalkers-v0"
        )
    start = time.perf_counter()
    window = 15 if args.window is None else args.window
    data = pose_windows_from_env(
        args.env,
        episodes=args.episodes,
        seed=args.data_seed,
        steps=args.steps,
        window=window,
        **args.env_kwargs,
    )
    train, validation, test = data.split(args.seed)
    s = {"train_windows": len(train), "validation_windows": len(validation), "test_windows": len(test)}
    print(f"{len(data)} pose windows of {len(np.unique(data.person))} people: {s}")
    config = _train_config(args)
    dropout = 0.3 if args.dropout is None else args.dropout
    net, history = train_pose_model(
        train,
        validation,
        config,
        dropout=dropout,
        min_window=args.min_window,
        loss=args.loss,
        progress=not args.no_progress,
    )
    metrics = pose_metrics(net, validation, test, min(10, window))
    training = _training_record(args, argv, config, history, min_window=args.min_window, loss=args.loss)
    training["wall_time_s"] = round(time.perf_counter() - start, 1)
    model = to_model_file(
        net, SCALE_PER_HEIGHT, training=training, data={**data.description, **s}, metrics=metrics
    )
    tensor_path, sidecar_path = save_model(args.out, model)
    print(
        f"wrote {tensor_path} and {sidecar_path} in {training['wall_time_s']:.0f} s; test: mean error "
        f"{metrics['test_mean_error_px']:.3g} px (last visible coordinate: "
        f"{metrics['test_last_visible_error_px']:.3g} px), NLL {metrics['test_nll']:.3g}"
    )
    return 0


def _print_split(n_tracks: int, split: Any, min_length: int) -> dict[str, int]:
    """Print how the tracks were split and how many were too short; returns the split's summary."""
    s = split.summary()
    print(
        f"{n_tracks} tracks: {s['train_tracks']} train, {s['validation_tracks']} validation, "
        f"{s['test_tracks']} test; {s['dropped_short_tracks']} shorter than {min_length} frames dropped"
    )
    return s


def _training_record(
    args: argparse.Namespace, argv: Sequence[str], config: Any, history: Any, **extra: Any
) -> dict[str, Any]:
    """The sidecar's ``training`` entry: the exact command, the :class:`TrainConfig`, the
    command's own settings ``extra`` and the loss history (the caller adds the wall time)."""
    return {
        "command": f"{args.prog} " + shlex.join(argv),
        "config": {k: getattr(config, k) for k in config.__dataclass_fields__},
        **extra,
        "history": history.to_dict(),
    }


def _train_config(args: argparse.Namespace) -> Any:
    """The :class:`~predictors.training.loop.TrainConfig` of the command-line arguments."""
    from predictors.training.loop import TrainConfig

    return TrainConfig(
        epochs=args.epochs,
        lr=args.lr,
        decay_every=args.decay_every,
        batch_size=args.batch_size,
        seed=args.seed,
        device=args.device,
    )


def _grid_search(args: argparse.Namespace, split: Any, config: Any) -> tuple[float, list[dict[str, float]]]:
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


def _calibrate(args: argparse.Namespace, argv: list[str]) -> int:
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
    data = load_data(args)
    tracks = split_tracks(data, fractions=(1.0, 0.0, 0.0), seed=args.seed, min_length=args.min_length).train
    uncalibrated = _with_meta(model, calibration={**model.meta.get("calibration", {}), "scale": 1.0})
    before = predictions_of(uncalibrated, tracks, args.added_noise_std, args.seed)
    cal = fit_recalibration(*before.flat(), p_des=P_DES)
    calibration = {
        **model.meta.get("calibration", {}),
        "scale": cal.scale,
        "p_des": P_DES,
        "command": f"{args.prog} " + shlex.join(argv),
        "data": {**dict(data.description), "tracks": len(tracks)},
        "predictions": len(before.valid_d2()),
    }
    scaled = _with_meta(model, calibration=calibration)
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


def _with_meta(model: ModelFile, **entries: Any) -> ModelFile:
    return dataclasses.replace(model, meta={**model.meta, **entries})


# ------------------------------------------------------------------ the lstm line search

#: Factors of ``s₀`` the line search tries.
FACTORS = tuple(float(f) for f in np.logspace(-1, 2, 7))


def tracker_e_mean(
    model: Any, env_id: str, env_kwargs: dict[str, Any], seeds: Sequence[int], steps: int | None
) -> float:
    """Mean over ``seeds`` of the episode e_mean of ``gnn`` with the belt model ``model``."""
    import gymnasium as gym

    import track_envs  # noqa: F401
    from agents.gnn.agent import GnnAgent
    from predictors.belt_lstm.predictor import LSTMPredictor
    from track_envs.wrappers import TrackingMetrics

    values = []
    for seed in seeds:
        env = TrackingMetrics(gym.make(env_id, **env_kwargs))
        agent = GnnAgent(predictor=LSTMPredictor(model.kind, model))
        obs, _ = env.reset(seed=seed)
        agent.reset(env.get_wrapper_attr("sensor_spec"), seed=seed)
        t = 0
        while True:
            obs, _, terminated, truncated, _ = env.step(agent.act(obs))
            t += 1
            if terminated or truncated or (steps is not None and t >= steps):
                break
        values.append(float(env.episode_metrics()["e_mean"]))
        env.close()
    return float(np.mean(values))


def line_search(
    model_path: str | os.PathLike[str],
    *,
    env_id: str,
    env_kwargs: dict[str, Any],
    seeds: Sequence[int],
    steps: int | None,
    factors: Sequence[float] = FACTORS,
) -> dict[str, Any]:
    """Pick ``calibration.cov_scale`` of the ``lstm`` model file at ``model_path`` (rewritten)."""
    from predictors.training.model_file import load_model, save_model

    model = load_model(model_path, kind="lstm")
    calibration = dict(model.meta.get("calibration", {}))
    s0 = float(calibration["cov_scale"])
    scores = []
    for f in factors:
        candidate = dataclasses.replace(
            model, meta={**model.meta, "calibration": {**calibration, "cov_scale": s0 * f, "scale": 1.0}}
        )
        scores.append(tracker_e_mean(candidate, env_id, env_kwargs, seeds, steps))
    order = np.lexsort((np.abs(np.log(np.asarray(factors))), np.asarray(scores)))
    best = int(order[0])
    calibration.update(cov_scale=s0 * factors[best], scale=1.0, cov_scale_mse=s0)
    save_model(model_path, dataclasses.replace(model, meta={**model.meta, "calibration": calibration}))
    return {
        "method": "line search of cov_scale on gnn e_mean",
        "env_id": env_id,
        "env_kwargs": env_kwargs,
        "seeds": list(seeds),
        "steps": steps,
        "factors": list(factors),
        "e_mean": scores,
        "best_cov_scale": s0 * factors[best],
    }


def lstm_tuner(model_path: Path, args: argparse.Namespace) -> dict[str, Any]:
    """``track train lstm``'s post-training step: the line search on validation episodes.

    Validation data (not trained on; the search picks the scale on them): env episodes with seeds
    after the training ones (``--data-seed + --episodes + 100 …``, 1,000 frames each) or, for
    ``--tracks``, the replayed file; the added noise is the largest of ``--added-noise-std`` (at
    least 0.1 mm: the line search needs association errors to separate the candidates).
    """
    from predictors.belt_lstm.training import check_noise_std

    noise = max(check_noise_std(args.added_noise_std)[1], 1e-4)
    if args.env:
        env_id, env_kwargs = args.env, {**args.env_kwargs, "noise_std": noise}
        first = args.data_seed + args.episodes + 100
        seeds, steps = [first, first + 1], 1000
    else:
        env_id, env_kwargs = "BeltReplay-v0", {"path": args.tracks, "dt": args.dt, "noise_std": noise}
        seeds, steps = [0], None
    print(f"lstm: line search of the covariance scale on {env_id} (noise {noise:g}) ...")
    return line_search(model_path, env_id=env_id, env_kwargs=env_kwargs, seeds=seeds, steps=steps)


#: Post-training steps by model kind.
TUNERS: dict[str, Tuner] = {"lstm": lstm_tuner}
