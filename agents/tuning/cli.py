"""The ``track-tune`` command: train PPO on GateTuning-v0, the grid baseline, the paired evaluation.

examples::

    track-tune train --timesteps 60000 --n-envs 2 --vec subproc --seed 0 --out runs/gate-tuning \\
        --policy-out agents/tuning/weights/gate-tuning-ppo
    track-tune grid-suite --seeds 0:6 --out results/gate_grid.toml
    track-bench run --suite results/gate_grid.toml --out results/gate_grid
    track-tune best-fixed results/gate_grid
    track-tune evaluate --seeds 20 --best-fixed results/gate_grid --out results/gate_eval.json
    track-tune evaluate --seeds 20 --best-fixed results/gate_grid --no-drift
    track-tune evaluate --seeds 10 --best-fixed results/gate_grid --oracle
    track-tune evaluate --seeds 10 --best-fixed results/gate_grid --oracle --oracle-resample 2
    track-tune sensor-grid --seeds 0:3 --steps 50 --workers 2 --out results/sensor_table.json
    track-tune evaluate --seeds 20 --best-fixed results/gate_grid --informed results/sensor_table.json
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path
from typing import Any

from agents.bench.cli import parse_seeds, parse_value


def _kv(text: str) -> dict[str, Any]:
    out = {}
    for item in text.split(","):
        name, sep, value = item.partition("=")
        if not sep:
            raise argparse.ArgumentTypeError(f"bad setting {item!r}: use name=value,name=value")
        out[name.strip()] = parse_value(value)
    return out


def cmd_train(args: argparse.Namespace) -> int:
    from agents.tuning.train import TrainConfig, train

    config = TrainConfig(
        timesteps=args.timesteps,
        n_envs=args.n_envs,
        vec=args.vec,
        seed=args.seed,
        checkpoint_every=args.checkpoint_every,
        env_kwargs=args.env_kwargs or {},
    )
    command = "track-tune " + " ".join(shlex.quote(a) for a in args.argv)
    _, summary = train(
        config, args.out, policy_out=args.policy_out, progress=not args.no_progress, command=command
    )
    print(
        f"trained {summary['timesteps']} steps in {summary['wall_s']:.0f} s; policy -> "
        f"{args.policy_out or Path(args.out) / 'policy'}"
    )
    return 0


def cmd_grid_suite(args: argparse.Namespace) -> int:
    from agents.tuning.evaluate import grid_suite

    text = grid_suite(args.seeds, args.steps, drift=None if args.no_drift else args.drift)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(text)
    print(f"wrote {args.out}: run it with track-bench run --suite {args.out} --out <dir>")
    return 0


def cmd_best_fixed(args: argparse.Namespace) -> int:
    from agents.tuning.evaluate import best_fixed, read_records

    result = best_fixed(read_records(args.records))
    for row in result["rows"][: args.top]:
        print(f"{row['mean']:8.1f} ± {row['std']:6.1f}  {row['setting']}")
    print(f"best fixed setting over seeds {result['seeds']}: {result['best']}")
    return 0


def cmd_sensor_grid(args: argparse.Namespace) -> int:
    import numpy as np

    from agents.tuning.informed import default_states, sensor_table

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
    print(f"wrote {args.out}: evaluate it with track-tune evaluate --informed {args.out}")
    return 0


def cmd_evaluate(args: argparse.Namespace) -> int:
    import numpy as np

    from agents.tuning import FixedPolicy, NisRule, load_policy
    from agents.tuning.evaluate import (
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
        from agents.tuning.oracle import LookaheadOracle

        policies["oracle"] = LookaheadOracle(
            horizon=args.oracle_horizon,
            resample_future=args.oracle_resample > 0,
            futures=max(args.oracle_resample, 1),
        )
    if args.informed:
        if args.no_drift:
            raise ValueError("--informed follows the drifting sensor: nothing to follow with --no-drift")
        from agents.tuning.informed import SensorInformedPolicy

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
        Path(args.out).write_text(json.dumps(result, indent=2) + "\n")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="track-tune",
        description="PPO on GateTuning-v0: train, grid baseline, paired evaluation on held-out seeds.",
        epilog=__doc__.split("examples::", 1)[1] if __doc__ else None,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("train", help="train PPO (stable-baselines3) and export the actor")
    p.add_argument("--timesteps", type=int, default=60_000)
    p.add_argument("--n-envs", type=int, default=2)
    p.add_argument("--vec", choices=("subproc", "dummy"), default="subproc")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--checkpoint-every", type=int, default=10_000, help="env steps between checkpoints (0: none)"
    )
    p.add_argument(
        "--env-kwargs", type=_kv, default=None, help="GateTuning-v0 kwargs, e.g. frames_per_step=5"
    )
    p.add_argument("--out", default="runs/gate-tuning")
    p.add_argument("--policy-out", default=None, help="model-file name of the exported actor")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(func=cmd_train)
    p = sub.add_parser("grid-suite", help="write the track-bench suite of the fixed-setting grid")
    p.add_argument("--seeds", type=parse_seeds, default=tuple(range(6)))
    p.add_argument("--steps", type=int, default=1000)
    p.add_argument("--drift", default="belt")
    p.add_argument("--no-drift", action="store_true")
    p.add_argument("--out", required=True)
    p.set_defaults(func=cmd_grid_suite)
    p = sub.add_parser("best-fixed", help="the best fixed setting of a track-bench grid run")
    p.add_argument("records")
    p.add_argument("--top", type=int, default=10)
    p.set_defaults(func=cmd_best_fixed)
    p = sub.add_parser(
        "sensor-grid",
        help="errors of a knob grid at constant sensor states (the sensor-informed reference's table)",
    )
    p.add_argument("--seeds", type=parse_seeds, default=tuple(range(3)), help="training seeds")
    p.add_argument("--steps", type=int, default=50, help="GateTuning-v0 steps per episode")
    p.add_argument("--drift", default="belt", help="drift preset whose ranges the states span")
    p.add_argument("--noise-states", type=int, default=5, help="log-spaced noise stds")
    p.add_argument("--env-kwargs", type=_kv, default=None, help="further GateTuning-v0 kwargs")
    p.add_argument("--workers", type=int, default=1, help="processes playing the episodes")
    p.add_argument("--out", required=True)
    p.set_defaults(func=cmd_sensor_grid)
    p = sub.add_parser("evaluate", help="paired comparison on held-out seeds")
    p.add_argument("--seeds", type=int, default=20)
    p.add_argument("--policy", default=None, help="model file (default: the shipped policy)")
    p.add_argument("--best-fixed", default=None, help="track-bench out dir of the grid")
    p.add_argument(
        "--fixed", type=_kv, default=None, help="a fixed setting, e.g. p_gate=0.9999,noise_scale=4"
    )
    p.add_argument("--gain", type=float, default=0.5, help="gain of the NIS rule")
    p.add_argument("--env-kwargs", type=_kv, default=None, help="GateTuning-v0 kwargs: episode_steps=50")
    p.add_argument("--no-drift", action="store_true")
    p.add_argument(
        "--oracle",
        action="store_true",
        help="also play the clairvoyant lookahead oracle (agents.tuning.oracle; slow: ≈6 min per episode)",
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
        help="also play the sensor-informed reference of this table (track-tune sensor-grid)",
    )
    p.add_argument("--workers", type=int, default=1, help="processes playing the episodes")
    p.add_argument("--out", default=None)
    p.set_defaults(func=cmd_evaluate)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    args.argv = argv
    try:
        return int(args.func(args))
    except (ValueError, ImportError) as exc:
        print(f"track-tune {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
