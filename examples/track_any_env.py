"""Track any registered environment with any agent that applies, print the episode's metrics.

python examples/track_any_env.py --env KeypointWalkers-v0 --agent pose-baseline --png poses.png
python examples/track_any_env.py --env SineTarget-v0 --agent pf --kwargs occlusion_length=60
python examples/track_any_env.py --env BeltReplay-v0 --agent gnn --predictor kf-cv
"""

from __future__ import annotations

import argparse
import ast

import gymnasium as gym

import track_envs
from agents import agent_applies_to, available_agents, make_agent, run_episode
from track_envs.io import atomic_path
from track_envs.wrappers import TrackingMetrics


def parse_kwargs(items: list[str]) -> dict[str, object]:
    """``["name=value", ...]`` with Python-literal values (strings may be bare)."""
    out: dict[str, object] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"--kwargs expects name=value, got {item!r}")
        try:
            out[name] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            out[name] = value
    return out


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--env", default="BeltSorter-v0", choices=track_envs.ENV_IDS)
    parser.add_argument(
        "--agent", default=None, help=f"one of {available_agents()} (default: the first that applies)"
    )
    parser.add_argument("--predictor", default=None, help="for agents that take one (gnn)")
    parser.add_argument("--steps", type=int, default=300, help="frames at most")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--kwargs", nargs="*", default=[], help="env keyword arguments, name=value")
    parser.add_argument("--png", default=None, help="write the last frame, rendered, to this PNG")
    args = parser.parse_args(argv)

    env = TrackingMetrics(
        gym.make(args.env, render_mode="rgb_array", max_episode_steps=args.steps, **parse_kwargs(args.kwargs))
    )
    shape, targets = env.unwrapped.position_shape, env.unwrapped.max_targets
    fits = [a for a in ("gnn", "pf", "pose-baseline", "detections") if agent_applies_to(a, shape, targets)]
    name = args.agent or fits[0]
    if not agent_applies_to(name, shape, targets):
        raise SystemExit(f"agent {name!r} does not apply to {args.env}; agents that do: {fits}")
    agent = make_agent(name, **({"predictor": args.predictor} if args.predictor else {}))
    metrics = run_episode(env, agent, seed=args.seed).metrics
    print(f"{args.env} + {name}{'/' + args.predictor if args.predictor else ''}, {args.steps} frames at most")
    for key, value in metrics.items():
        print(f"  {key:<24} {value:.6g}")
    if args.png:
        import matplotlib.pyplot as plt

        with atomic_path(args.png, keep_suffix=True) as tmp:  # the format follows the suffix
            plt.imsave(tmp, env.render())
        print(f"  rendered frame written to {args.png}")
    env.close()
    return metrics


if __name__ == "__main__":
    main()
