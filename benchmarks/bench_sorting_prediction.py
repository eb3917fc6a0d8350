"""Cost of the gnn agent's predicted nozzle-bar crossings, against the same agent without them.

    python benchmarks/bench_sorting_prediction.py [--frames 300]

One BeltSorter-v0 stream (default env, nozzle bar 0.05 m past the window) is recorded, then the
gnn agent runs over the same observations twice per predictor: told the bar
(``sensor_spec.sorting_line``, every deleted track gets a predicted crossing) and not told it
(``sorting_line=None``). Prints frames/s of both and their ratio (best of three repetitions).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import track_envs  # noqa: F401
from agents import make_agent


def record(frames: int, seed: int) -> tuple[list, object]:
    env = gym.make("BeltSorter-v0", max_episode_steps=frames)
    agent = make_agent("gnn", predictor="kf-cv")
    obs, _ = env.reset(seed=seed)
    spec = env.unwrapped.sensor_spec
    agent.reset(spec, seed=seed)
    out = []
    while True:
        out.append(obs)
        obs, _, terminated, truncated, _ = env.step(agent.act(obs))
        if terminated or truncated:
            return out, spec


def fps(predictor: str, spec, frames: list, **kwargs) -> float:
    agent = make_agent("gnn", predictor=predictor, **kwargs)
    best = np.inf
    for _ in range(3):
        agent.reset(spec, seed=0)
        start = time.perf_counter()
        for obs in frames:
            agent.act(obs)
        best = min(best, time.perf_counter() - start)
    return len(frames) / best


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--predictors", default="kf-cv,kf-ca,lstm,nll-lstm")
    args = parser.parse_args()
    frames, spec = record(args.frames, 0)
    plain = dataclasses.replace(spec, sorting_line=None)
    print("| predictor | with crossings frames/s | without frames/s | ratio |")
    print("|---|---|---|---|")
    for name in args.predictors.split(","):
        with_bar, without = fps(name, spec, frames), fps(name, plain, frames)
        print(f"| {name} | {with_bar:.0f} | {without:.0f} | {with_bar / without:.3f} |")


if __name__ == "__main__":
    main()
