"""Benchmark: frames per second of the SMC pose tracker (pose-smc) against re-running every window.

The scene: KeypointWalkers-v0 with ``--people`` people in view from the first frame, no arrivals,
no vanishing, the recorded observations of one episode (so both trackers see the same frames).
Each tracker runs the frames ``--warmup`` … ``--warmup + --frames`` (after tracking the warm-up
frames, so the filters are set up) on ``--threads`` torch threads. The reference, timed in the same
run, is the straightforward implementation of the stateless predictor: ``recurrence="window",
share_windows=False`` re-runs the 64-unit LSTM over every particle's L-window every frame. The
measured ones: the default ``share_windows=True`` (the same result: the LSTM runs once per
distinct queue of a filter, since resampled copies and particles that selected the observation
history share their queue; dropout and the Gaussian draw stay per particle), and
``recurrence="carried"`` (one LSTM step per particle and keypoint per frame; its semantics
differ, see :mod:`agents.pose.smc`). The table gives the active filters and the LSTM sequences
per frame and the LSTM arithmetic: ``4 · 64 · (64 + 3 + 1)`` multiply-adds per sequence and step.

Usage::

    python benchmarks/bench_pose_smc.py [--people 10] [--particles 300] [--window 10] [--frames 20]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import gymnasium as gym
import numpy as np
import torch

import track_envs  # noqa: F401
from agents.pose.smc import PoseSmcAgent
from track_envs.report import empty_report


def record(people: int, frames: int, seed: int) -> tuple[list[dict], object]:
    env = gym.make(
        "KeypointWalkers-v0",
        num_people=people,
        initial_people=people,
        arrival_rate=0.0,
        vanish_rate=0.0,
        clutter_rate=0.0,
    )
    obs, _ = env.reset(seed=seed)
    spec = env.unwrapped.sensor_spec
    report = empty_report(spec.max_tracks, (17, 2))
    out = [obs]
    for _ in range(frames - 1):
        obs, *_ = env.step(report)
        out.append(obs)
    return out, spec


def time_agent(agent: PoseSmcAgent, stream: list[dict], spec, warmup: int) -> tuple[float, float, float]:
    """Seconds per frame, mean active filters, mean distinct queues per frame."""
    agent.reset(spec, seed=0)
    for obs in stream[:warmup]:
        agent.act(obs)
    filters, distinct = [], []
    elapsed = 0.0
    for obs in stream[warmup:]:
        m = agent.motion
        distinct.append(int(np.sum(m.rep == np.arange(m.P))))
        t0 = time.perf_counter()
        agent.act(obs)
        elapsed += time.perf_counter() - t0
        filters.append(len(agent.ids))
    return elapsed / (len(stream) - warmup), float(np.mean(filters)), float(np.mean(distinct))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--people", type=int, default=10)
    parser.add_argument("--particles", type=int, default=300)
    parser.add_argument("--window", type=int, default=10)
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--warmup", type=int, default=5)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    torch.set_num_threads(args.threads)
    stream, spec = record(args.people, args.warmup + args.frames, args.seed)
    variants = {
        "window, every particle (reference)": {"share_windows": False},
        "window, distinct queues (default)": {},
        "carried state": {"recurrence": "carried"},
    }
    rows = []
    for label, kwargs in variants.items():
        agent = PoseSmcAgent(particles=args.particles, window=args.window, **kwargs)
        rows.append((label, *time_agent(agent, stream, spec, args.warmup)))
    macs = 4 * 64 * (64 + 3 + 1)
    print(f"people {args.people}, P = {args.particles}, L = {args.window}, torch threads {args.threads}")
    head = (
        "| variant | filters | LSTM sequences / frame | steps each | GMAC / frame | ms / frame | frames / s |"
    )
    print(head + " speed-up |")
    print("|---|---|---|---|---|---|---|---|")
    ref = rows[0][1]
    for label, dt, filters, distinct in rows:
        steps = 1 if label.startswith("carried") else args.window
        queues = filters * args.particles if "every" in label or steps == 1 else distinct
        seqs = queues * 17 + (filters * 17 if steps == 1 else 0)  # carried: + the observation states
        gmac = seqs * steps * macs / 1e9
        cells = f"{filters:.1f} | {seqs:.0f} | {steps} | {gmac:.2f} | {dt * 1e3:.0f} | {1 / dt:.1f}"
        cells += f" | {ref / dt:.1f}x"
        print(f"| {label} | {cells} |")


if __name__ == "__main__":
    main()
