"""KeypointWalkers-v0 frames/s and pose-baseline tracker frames/s, against per-pair references.

    python benchmarks/bench_keypoints.py [--frames 300]

* Env: frames/s of ``env.step`` with an empty report, 10 and 50 people in the scene (occlusion
  between all pairs of people batched in numpy).
* Tracker: frames/s of ``PoseBaselineAgent.act`` over recorded observations of scenes with 10 and
  100 people, with the batched OKS similarity over all (track, detection) pairs, and with a
  reference per-pair Python OKS loop swapped in (same tracker otherwise), timed in the same run.

Timings are the best of three repetitions; prints a markdown table. No assertions.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import predictors.pose.constant_velocity as pose_module
import track_envs  # noqa: F401
from agents.pose.tracker import PoseBaselineAgent
from track_envs.contracts.report import empty_report
from track_envs.metrics.keypoints import COCO_SIGMAS, pairwise_oks


def scene(people: int) -> dict:
    rows = 2 * people + 16
    return {"num_people": people, "initial_people": people, "arrival_rate": people / 5.0,
            "max_detections": rows, "max_tracks": rows, "max_targets": rows}  # fmt: skip


def time_env(people: int, frames: int) -> tuple[float, float]:
    env = gym.make("KeypointWalkers-v0", max_episode_steps=None, **scene(people))
    report = empty_report(env.unwrapped.sensor_spec.max_tracks, (17, 2))
    best, shown = np.inf, []
    for rep in range(3):
        env.reset(seed=rep)
        start = time.perf_counter()
        for _ in range(frames):
            obs, *_ = env.step(report)
            shown.append(int(obs["mask"].sum()))
        best = min(best, time.perf_counter() - start)
    return frames / best, float(np.mean(shown))


def loop_oks(a, b, b_valid, area, a_valid=None, sigmas=COCO_SIGMAS):
    """Reference: one Python iteration per (track, detection) pair."""
    var = (2 * np.asarray(sigmas)) ** 2
    out = np.zeros((len(a), len(b)))
    for i in range(len(a)):
        for j in range(len(b)):
            v = b_valid[j] if a_valid is None else b_valid[j] & a_valid[i]
            e = np.sum((a[i] - b[j]) ** 2, axis=1) / (var * 2 * (area[j] + np.spacing(1)))
            out[i, j] = np.exp(-e)[v].sum() / max(int(v.sum()), 1)
    return out


def time_tracker(people: int, frames: int) -> tuple[float, float, float]:
    env = gym.make("KeypointWalkers-v0", max_episode_steps=None, **scene(people))
    spec = env.unwrapped.sensor_spec
    report = empty_report(spec.max_tracks, (17, 2))
    obs, _ = env.reset(seed=0)
    recorded = [obs]
    for _ in range(frames - 1):
        obs, *_ = env.step(report)
        recorded.append(obs)
    rates = []
    for similarity in (pairwise_oks, loop_oks):
        pose_module.pairwise_oks = similarity  # type: ignore[assignment]
        best = np.inf
        for _ in range(3):
            agent = PoseBaselineAgent()
            agent.reset(spec)
            start = time.perf_counter()
            for o in recorded:
                agent.act(o)
            best = min(best, time.perf_counter() - start)
        rates.append(frames / best)
    pose_module.pairwise_oks = pairwise_oks  # type: ignore[assignment]
    return rates[0], rates[1], float(np.mean([o["mask"].sum() for o in recorded]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=300)
    args = parser.parse_args()
    print("| what | people | detections / frame | frames/s | reference frames/s | speed-up |")
    print("|---|---|---|---|---|---|")
    for people in (10, 50):
        fps, shown = time_env(people, args.frames)
        print(f"| KeypointWalkers-v0 env.step | {people} | {shown:.1f} | {fps:,.0f} | – | – |")
    for people in (10, 100):
        fast, slow, shown = time_tracker(people, args.frames)
        print(
            f"| pose-baseline act (batched OKS vs per-pair loop) | {people} | {shown:.1f} | {fast:,.0f} "
            f"| {slow:,.0f} | {fast / slow:.1f}× |"
        )


if __name__ == "__main__":
    main()
