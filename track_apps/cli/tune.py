"""``track tune``: PPO on GateTuning-v0, the grid baseline, the paired evaluation."""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from track_apps.cli import arguments
from track_envs.infra.atomic import write_text

PROG = "track tune"

EPILOG = """\
examples:
  track tune train --timesteps 60000 --n-envs 2 --vec subproc --seed 0 --out runs/gate-tuning \\
      --policy-out track_apps/tuning/weights/gate-tuning-ppo
  track tune grid-suite --seeds 0:6 --out results/gate_grid.toml
  track bench run --suite results/gate_grid.toml --out results/gate_grid
  track tune best-fixed results/gate_grid
  track tune evaluate --seeds 20 --best-fixed results/gate_grid --out results/gate_eval.json
  track tune evaluate --seeds 20 --best-fixed results/gate_grid --no-drift
  track tune evaluate --seeds 20 --fixed p_gate=0.9999,noise_scale=4 --env-kwargs episode_steps=50
  track tune evaluate --seeds 10 --best-fixed results/gate_grid --oracle
  track tune evaluate --seeds 10 --best-fixed results/gate_grid --oracle --oracle-resample 2
  track tune sensor-grid --seeds 0:3 --steps 50 --workers 2 --out results/sensor_table.json
  track tune evaluate --seeds 20 --best-fixed results/gate_grid --informed results/sensor_table.json
"""


def cmd_train(args: argparse.Namespace) -> int:
    from track_apps.tuning.train import TrainConfig, train

    config = TrainConfig(
        timesteps=args.timesteps,
        n_envs=args.n_envs,
        vec=args.vec,
        seed=args.seed,
        checkpoint_every=args.checkpoint_every,
        env_kwargs=args.env_kwargs,
    )
    command = f"{args.prog} " + " ".join(shlex.quote(a) for a in args.argv)
    _, summary = train(
        config, args.out, policy_out=args.policy_out, progress=not args.no_progress, command=command
    )
    print(
        f"trained {summary['timesteps']} steps in {summary['wall_s']:.0f} s; policy -> "
        f"{args.policy_out or Path(args.out) / 'policy'}"
    )
    return 0


def cmd_grid_suite(args: argparse.Namespace) -> int:
    from track_apps.tuning.evaluate import grid_suite

    text = grid_suite(args.seeds, args.steps, drift=None if args.no_drift else args.drift)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    write_text(args.out, text)
    print(f"wrote {args.out}: run it with track bench run --suite {args.out} --out <dir>")
    return 0


def cmd_best_fixed(args: argparse.Namespace) -> int:
    from track_apps.tuning.evaluate import best_fixed, read_records

    result = best_fixed(read_records(args.records))
    for row in result["rows"][: args.top]:
        print(f"{row['mean']:8.1f} ± {row['std']:6.1f}  {row['setting']}")
    print(f"best fixed setting over seeds {result['seeds']}: {result['best']}")
    return 0


def cmd_sensor_grid(args: argparse.Namespace) -> int:
    import numpy as np

    from track_apps.tuning.informed import default_states, sensor_table

    states = default_states(args.drift, n_noise=args.noise_states)
    table = sensor_table(
        args.seeds, args.steps, states=states, env_kwargs=args.env_kwargs, workers=args.workers
    )
    table.save(args.out)
    errors = np.asarray(table.errors)
    flat = errors.reshape(-1, errors.shape[-1])
    overall = int(np.argmin(flat.mean(axis=0)))
    print(f"best setting over all states: {table.settings[overall]}")
    names = list(table.states)
    for index in np.ndindex(errors.shape[:-1]):
        state = {n: table.states[n][i] for n, i in zip(names, index, strict=True)}
        row = errors[index]
        best = int(np.argmin(row))
        gain = (row[overall] - row[best]) / row[overall] if row[overall] else 0.0
        print(
            f"noise_std {state['noise_std']:.3g}  p_detect {state['p_detect']:.3g}  clutter "
            f"{state['clutter_rate']:.3g}: best {table.settings[best]} {row[best]:.1f} vs "
            f"{row[overall]:.1f} ({100 * gain:.1f}% fewer)"
        )
    print(f"wrote {args.out}: evaluate it with {args.prog} evaluate --informed {args.out}")
    return 0


def cmd_evaluate(args: argparse.Namespace) -> int:
    import numpy as np

    from track_apps.tuning import FixedPolicy, NisRule, load_policy
    from track_apps.tuning.evaluate import (
        best_fixed,
        evaluate,
        format_comparison,
        held_out_seeds,
        paired,
        read_records,
    )

    fixed = args.fixed
    if args.best_fixed:
        fixed = best_fixed(read_records(args.best_fixed))["best"]
    policies: dict[str, Any] = {
        "ppo": load_policy(args.policy),
        "nis-rule": NisRule(gain=args.gain),
        "gnn-defaults": FixedPolicy(),
    }
    if fixed:
        policies["best-fixed"] = FixedPolicy(fixed)
    if args.oracle:
        from track_apps.tuning.oracle import LookaheadOracle

        policies["oracle"] = LookaheadOracle(
            horizon=args.oracle_horizon,
            resample_future=args.oracle_resample > 0,
            futures=max(args.oracle_resample, 1),
        )
    if args.informed:
        if args.no_drift:
            raise ValueError("--informed follows the drifting sensor: nothing to follow with --no-drift")
        from track_apps.tuning.informed import SensorInformedPolicy

        policies["informed"] = SensorInformedPolicy(args.informed)
    seeds = held_out_seeds(args.seeds)
    env_kwargs: dict[str, Any] = dict(args.env_kwargs or {})
    if args.no_drift:
        env_kwargs["drift"] = None
    errors = evaluate(policies, seeds, env_kwargs, workers=args.workers)
    result: dict[str, Any] = {
        "seeds": seeds,
        "env_kwargs": env_kwargs,
        "fixed": fixed,
        "errors": errors,
        "paired": {},
    }
    for name, e in errors.items():
        std = np.std(e, ddof=1) if len(e) > 1 else 0.0
        print(f"{name:>13}: {np.mean(e):8.1f} ± {std:6.1f} association errors per episode")
    pairs = [
        ("ppo", "best-fixed"),
        ("ppo", "nis-rule"),
        ("nis-rule", "best-fixed"),
        ("ppo", "gnn-defaults"),
        ("oracle", "best-fixed"),
        ("ppo", "oracle"),
        ("informed", "best-fixed"),
        ("ppo", "informed"),
    ]
    for a, b in pairs:
        if a in errors and b in errors:
            r = paired(errors[a], errors[b])
            result["paired"][f"{a} vs {b}"] = r
            print(format_comparison(a, b, r))
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        write_text(args.out, json.dumps(result, indent=2) + "\n")
    return 0


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The argparse parser of ``track tune`` (``prog``: the name it answers to)."""
    # long: one argparse declaration per option and subcommand, in the order --help lists them
    parser = argparse.ArgumentParser(
        prog=prog,
        description="PPO on GateTuning-v0: train, grid baseline, paired evaluation on held-out seeds.",
        epilog=EPILOG.replace(PROG + " ", prog + " "),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("train", help="train PPO (stable-baselines3) and export the actor")
    p.add_argument("--timesteps", type=int, default=60_000, help="env steps to train (default 60000)")
    p.add_argument("--n-envs", type=int, default=2, help="parallel training envs (default 2)")
    p.add_argument(
        "--vec",
        choices=("subproc", "dummy"),
        default="subproc",
        help="vector env: one process per env (subproc, default) or all in-process (dummy)",
    )
    arguments.add_seed(p, help="PPO and env seed")
    p.add_argument(
        "--checkpoint-every", type=int, default=10_000, help="env steps between checkpoints (0: none)"
    )
    arguments.add_env_kwargs(p, help="GateTuning-v0 kwargs, e.g. frames_per_step=5")
    arguments.add_out(
        p,
        kind="directory",
        help="the run: checkpoints, logs, the exported policy",
        default="runs/gate-tuning",
    )
    p.add_argument(
        "--policy-out",
        default=None,
        help="model-file path without suffix of the exported actor (default: OUT/policy)",
    )
    arguments.add_no_progress(p)
    p.set_defaults(func=cmd_train)
    p = sub.add_parser("grid-suite", help="write the track bench suite of the fixed-setting grid")
    arguments.add_seeds(p, default=tuple(range(6)), help="seeds of the grid cells (default 0:6)")
    p.add_argument("--steps", type=int, default=1000, help="GateTuning-v0 frames per cell (default 1000)")
    p.add_argument("--drift", default="belt", help="drift preset of the sensor (default belt)")
    p.add_argument("--no-drift", action="store_true", help="a constant sensor (no drift)")
    arguments.add_out(p, kind="file", help="the suite's TOML file", required=True)
    p.set_defaults(func=cmd_grid_suite)
    p = sub.add_parser("best-fixed", help="the best fixed setting of a track bench grid run")
    p.add_argument("records", help="the --out directory of 'track bench run --suite GRID.toml'")
    p.add_argument("--top", type=int, default=10, help="settings to print, best first (default 10)")
    p.set_defaults(func=cmd_best_fixed)
    p = sub.add_parser(
        "sensor-grid",
        help="errors of a knob grid at constant sensor states (the sensor-informed reference's table)",
    )
    arguments.add_seeds(p, default=tuple(range(3)), help="training seeds (default 0:3)")
    p.add_argument("--steps", type=int, default=50, help="GateTuning-v0 steps per episode")
    p.add_argument("--drift", default="belt", help="drift preset whose ranges the states span")
    p.add_argument("--noise-states", type=int, default=5, help="log-spaced noise stds")
    arguments.add_env_kwargs(p, help="further GateTuning-v0 kwargs")
    arguments.add_workers(p, default=1, help="processes playing the episodes")
    arguments.add_out(p, kind="file", help="the sensor table (JSON)", required=True)
    p.set_defaults(func=cmd_sensor_grid)
    p = sub.add_parser("evaluate", help="paired comparison on held-out seeds")
    p.add_argument(
        "--seeds",
        type=int,
        default=20,
        metavar="N",
        help="N held-out seeds, never drawn by training (default 20)",
    )
    p.add_argument("--policy", default=None, help="model file (default: the shipped policy)")
    p.add_argument("--best-fixed", default=None, help="track bench out dir of the grid")
    p.add_argument(
        "--fixed",
        type=arguments.kwargs_type("--fixed"),
        default=None,
        metavar="NAME=V,...",
        help="a fixed setting, e.g. p_gate=0.9999,noise_scale=4",
    )
    p.add_argument("--gain", type=float, default=0.5, help="gain of the NIS rule")
    arguments.add_env_kwargs(p, help="GateTuning-v0 kwargs, e.g. episode_steps=50")
    p.add_argument("--no-drift", action="store_true", help="a constant sensor (no drift)")
    p.add_argument(
        "--oracle",
        action="store_true",
        help=(
            "also play the clairvoyant lookahead oracle (track_apps.tuning.oracle; slow: ≈6 min per episode)"
        ),
    )
    p.add_argument("--oracle-horizon", type=int, default=2, help="the oracle's lookahead in steps")
    p.add_argument(
        "--oracle-resample",
        type=int,
        nargs="?",
        const=1,
        default=0,
        metavar="FUTURES",
        help="the oracle looks ahead on FUTURES fresh random futures (default 1), averaged: it knows "
        "the present, not the noise to come",
    )
    p.add_argument(
        "--informed",
        default=None,
        metavar="TABLE",
        help=f"also play the sensor-informed reference of this table ({prog} sensor-grid)",
    )
    arguments.add_workers(p, default=1, help="processes playing the episodes")
    arguments.add_out(p, kind="file", help="the comparison as JSON (default: none, printed only)")
    p.set_defaults(func=cmd_evaluate)
    return parser


def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    """Entry point of ``track tune`` (``prog``: the name it answers to)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser(prog).parse_args(argv)
    args.argv, args.prog = argv, prog
    try:
        return int(args.func(args))
    except (ValueError, ImportError) as exc:
        print(f"{prog} {args.command}: error: {exc}", file=sys.stderr)
        return 2
