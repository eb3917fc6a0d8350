"""The ``track-train`` command: train a belt LSTM on env truth or a recorded track file.

Examples::

    track-train nll-lstm --env BeltSorter-v0 --env-kwargs particle_kind=cylinder --episodes 4 \\
        --epochs 1000 --out models/nll-lstm-cylinder
    track-train lstm --tracks my_recording.zip --dt 0.005 --epochs 300 --out models/my-lstm
    track-train mc-lstm --env BeltSorter-v0 --episodes 2 --dropout 0.002 --out models/mc

The output is ``OUT.safetensors`` + ``OUT.json`` (see :mod:`predictors.model_file`); pass it to a
tracker as ``make_agent("gnn", predictor="nll-lstm", weights="OUT")``.
"""

from __future__ import annotations

import argparse
import ast
import shlex
import sys
import time
from collections.abc import Sequence
from typing import Any

from predictors.belt_lstm_net import HEAD_OUTPUTS


def parse_kwargs(items: Sequence[str]) -> dict[str, Any]:
    """``["a=1", "b=cylinder"]`` → ``{"a": 1, "b": "cylinder"}`` (Python literals, else strings)."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"expected NAME=VALUE, got {item!r}")
        try:
            out[key.strip()] = ast.literal_eval(text)
        except (ValueError, SyntaxError):
            out[key.strip()] = text
    return out


def _noise(text: str) -> float | tuple[float, float]:
    lo, sep, hi = text.partition(":")
    try:
        return (float(lo), float(hi)) if sep else float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number or LOW:HIGH, got {text!r}") from None


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``track-train``."""
    p = argparse.ArgumentParser(
        prog="track-train",
        description="Train a belt LSTM motion model (lstm, nll-lstm, mc-lstm) and write a model file.",
        epilog=__doc__.split("Examples::", 1)[1].split("The output", 1)[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("model", choices=sorted(HEAD_OUTPUTS), help="model kind")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--env", help="a point env whose truth gives the tracks, e.g. BeltSorter-v0")
    src.add_argument("--tracks", help="a recorded track file (BeltReplay CSV/zip layout)")
    p.add_argument("--env-kwargs", nargs="*", default=[], metavar="NAME=VALUE", help="env arguments")
    p.add_argument("--episodes", type=int, default=4, help="env episodes (seeds --data-seed, +1, ...)")
    p.add_argument("--steps", type=int, default=None, help="frames per env episode (default: whole)")
    p.add_argument("--data-seed", type=int, default=1000, help="seed of the first env episode")
    p.add_argument("--dt", type=float, default=None, help="frame period of --tracks, seconds")
    p.add_argument(
        "--noise-std",
        type=_noise,
        default=0.0,
        help="noise std added to positions (sensor units), or LOW:HIGH for a per-track std drawn uniformly",
    )
    p.add_argument("--min-length", type=int, default=5, help="drop tracks with fewer frames")
    p.add_argument("--epochs", type=int, default=1000)
    p.add_argument("--lr", type=float, default=0.01)
    p.add_argument("--decay-every", type=int, default=200)
    p.add_argument("--batch-size", type=int, default=None, help="tracks per step (default: all)")
    p.add_argument("--dropout", type=float, default=0.002, help="mc-lstm dropout rate")
    p.add_argument("--seed", type=int, default=0, help="split, initialisation, shuffling, masks")
    p.add_argument("--device", choices=("cpu", "cuda"), default="cpu")
    p.add_argument("--out", required=True, help="output path without suffix")
    p.add_argument("--no-progress", action="store_true", help="no tqdm bar")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``track-train``; returns the exit code."""
    args = build_parser().parse_args(argv)
    try:
        return _train(args, list(sys.argv[1:] if argv is None else argv))
    except ValueError as exc:
        print(f"track-train: error: {exc}", file=sys.stderr)
        return 2


def _train(args: argparse.Namespace, argv: list[str]) -> int:
    from predictors.model_file import save_model
    from predictors.training.belt import to_model_file, train_belt_model
    from predictors.training.data import split_tracks, tracks_from_env, tracks_from_file
    from predictors.training.loop import TrainConfig
    from predictors.training.model_stats import model_statistics

    start = time.perf_counter()
    if args.env:
        data = tracks_from_env(
            args.env,
            episodes=args.episodes,
            seed=args.data_seed,
            steps=args.steps,
            **parse_kwargs(args.env_kwargs),
        )
    else:
        if args.dt is None:
            raise ValueError("--tracks needs --dt (the recording's frame period in seconds)")
        data = tracks_from_file(args.tracks, dt=args.dt)
    split = split_tracks(data, seed=args.seed, min_length=args.min_length)
    s = split.summary()
    print(
        f"{len(data)} tracks: {s['train_tracks']} train, {s['validation_tracks']} validation, "
        f"{s['test_tracks']} test; {s['dropped_short_tracks']} shorter than {args.min_length} frames dropped"
    )
    config = TrainConfig(
        epochs=args.epochs,
        lr=args.lr,
        decay_every=args.decay_every,
        batch_size=args.batch_size,
        seed=args.seed,
        device=args.device,
    )
    dropout = args.dropout if args.model == "mc-lstm" else 0.0
    net, features, history = train_belt_model(
        args.model, split, config, dropout=dropout, noise_std=args.noise_std, progress=not args.no_progress
    )
    stats = model_statistics(net, features, split, noise_std=args.noise_std, seed=args.seed)
    wall = time.perf_counter() - start
    model = to_model_file(
        net,
        features,
        calibration=stats["calibration"],
        mc=stats["mc"],
        training={
            "command": "track-train " + shlex.join(argv),
            "wall_time_s": round(wall, 1),
            "config": {k: getattr(config, k) for k in config.__dataclass_fields__},
            "noise_std": args.noise_std,
            "history": history.to_dict(),
        },
        data={**dict(data.description), **s},
        metrics=stats["metrics"],
    )
    tensor_path, sidecar_path = save_model(args.out, model)
    m = stats["metrics"]
    print(
        f"wrote {tensor_path} and {sidecar_path} in {wall:.0f} s; test: mean per-track error "
        f"{m['test_mean_error']:.3g}, coverage at 0.999 {m['test_coverage_999']:.4f}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
