"""Run one BeltSorter-v0 episode with a tracker, print what happened, save a rendered frame.

python examples/belt_sorter_episode.py --steps 500 --agent detections --png frame.png
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import track_envs  # noqa: F401  (registers the environments)
from agents import available_agents, make_agent
from track_envs.io import atomic_path
from track_envs.wrappers import TrackingMetrics


def best_available_agent() -> str:
    """The strongest registered tracker for point environments."""
    for name in ("gnn", "detections"):
        if name in available_agents():
            return name
    raise RuntimeError(f"no point tracker registered; available: {available_agents()}")


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--steps", type=int, default=500, help="frames to run (at 100 Hz)")
    parser.add_argument("--agent", default=None, help=f"tracker, one of {available_agents()}")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--noise-std", type=float, default=1e-4, help="measurement noise in metres")
    parser.add_argument("--particle-kind", default="cylinder", help="sphere, cylinder, cuboid or mixture")
    parser.add_argument("--png", default=None, help="write the last frame, rendered, to this PNG")
    args = parser.parse_args(argv)

    env = TrackingMetrics(
        gym.make(
            "BeltSorter-v0",
            noise_std=args.noise_std,
            particle_kind=args.particle_kind,
            render_mode="rgb_array",
            max_episode_steps=args.steps,
        )
    )
    agent_name = args.agent or best_available_agent()
    agent = make_agent(agent_name)
    obs, info = env.reset(seed=args.seed)
    agent.reset(env.unwrapped.sensor_spec, seed=args.seed)

    gospa, visible, detections, tracks = [], [], [], []
    for _ in tqdm(range(args.steps), desc=f"BeltSorter-v0 + {agent_name}", unit="frame"):
        visible.append(int((info["truth"]["ids"] >= 0).sum()))
        detections.append(int(obs["mask"].sum()))
        report = agent.act(obs)
        tracks.append(int(report["mask"].sum()))
        obs, reward, terminated, truncated, info = env.step(report)
        gospa.append(-reward)
        if terminated or truncated:
            break

    metrics = info["episode_metrics"]
    summary = {
        "frames": float(len(gospa)),
        "mean particles in window": float(np.mean(visible)),
        "peak particles in window": float(np.max(visible)),
        "mean detections per frame": float(np.mean(detections)),
        "mean reported tracks": float(np.mean(tracks)),
        "tracks started": metrics["n_tracks"],
        "particles seen": metrics["n_particles"],
        "e1 (tracks mixing particles)": metrics["e1"],
        "e2 (particles split or lost)": metrics["e2"],
        "e_mean": metrics["e_mean"],
        "MOTA": metrics["mota"],
        "IDF1": metrics["idf1"],
        "ID switches": metrics["id_switches"],
        "mean GOSPA (mm)": 1e3 * float(np.mean(gospa)),
    }
    print(
        f"\nBeltSorter-v0, {args.particle_kind}s, noise {args.noise_std * 1e3:.2f} mm, agent {agent_name!r}"
    )
    width = max(len(k) for k in summary)
    for key, value in summary.items():
        print(f"  {key:<{width}}  {value:10.4g}")
    if args.png:
        import matplotlib.pyplot as plt

        with atomic_path(args.png, keep_suffix=True) as tmp:  # the format follows the suffix
            plt.imsave(tmp, env.render())
        print(f"  rendered frame written to {args.png}")
    env.close()
    return summary


if __name__ == "__main__":
    main()
