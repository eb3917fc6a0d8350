"""BeltSorter-v0 frames per second against a naive pymunk implementation, in the same run.

    python benchmarks/bench_belt_sorter.py [--frames 2000]

Both run the same scene (cylinders, steady feed so that ≈150 or ≈500 particles are in the
window) on one core; the library env is stepped through ``gym.make`` with an empty report, the
naive reference (``benchmarks/naive_belt.py``: per-body joints for belt friction, per-body Python
read-out) through its own loop. The env is timed with ``merge_touching=False`` (one detection per
particle, as the reference senses) and with the default merged blobs. Prints frames/s and the
ratios; timings are the best of three repetitions; "visible" counts particles in the window.

The cost of the nozzle bar (particles simulated until they pass it 0.05 m past the window, and
the crossing truth) is the default env against ``nozzle_offset=None`` in the same run
(``--nozzle-only`` times just that).

``--industrial`` times the step cost per particle in view of ``BeltParams.industrial()`` (2 m
wide, 4 m window, ≈12,000 particles in view) against the default belt in the same run: the
median over ``--frames`` steps after the warm-up, each step divided by the particles in the
window at that frame, sizes derived from the scene (run it with ``OMP_NUM_THREADS=1``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from naive_belt import NaiveBelt

import track_envs  # noqa: F401
from track_envs.contracts.report import empty_report
from track_envs.envs.belt_physics import BeltParams

# feed rates (particles/s) that keep ≈150 and ≈500 cylinders in the window with a steady feed
LOADS = {150: 470.0, 500: 1560.0}


def time_env(
    feed_rate: float, frames: int, seed: int, merge_touching: bool = False, nozzle_offset: float | None = 0.05
) -> tuple[float, float]:
    params = BeltParams(feed_rate=feed_rate, feed_burstiness=0.0)
    env = gym.make(
        "BeltSorter-v0",
        physics=params,
        max_detections=1024,
        max_tracks=1024,
        max_targets=1024,
        merge_touching=merge_touching,
        nozzle_offset=nozzle_offset,
    )
    report = empty_report(1024, (2,))
    best = np.inf
    visible = []
    for rep in range(3):
        env.reset(seed=seed + rep)
        start = time.perf_counter()
        for _ in range(frames):
            _, _, _, _, info = env.step(report)
            if rep == 0:
                visible.append(int(np.count_nonzero(info["truth"]["ids"] >= 0)))
        best = min(best, time.perf_counter() - start)
    return frames / best, float(np.mean(visible))


def time_naive(feed_rate: float, frames: int, seed: int) -> tuple[float, float]:
    params = BeltParams(feed_rate=feed_rate, feed_burstiness=0.0)
    best = np.inf
    visible = []
    for rep in range(3):
        belt = NaiveBelt(params, "cylinder", seed + rep)
        start = time.perf_counter()
        for _ in range(frames):
            detections, _, _ = belt.step()
            if rep == 0:
                visible.append(len(detections))
        best = min(best, time.perf_counter() - start)
    return frames / best, float(np.mean(visible))


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--frames", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--nozzle-only", action="store_true", help="time only the nozzle bar's cost")
    parser.add_argument(
        "--industrial",
        action="store_true",
        help="industrial belt vs default: cost per particle",
    )
    args = parser.parse_args()
    if args.industrial:
        industrial_cost(args.frames, args.seed)
        return
    nozzle_cost(args.frames, args.seed)
    if args.nozzle_only:
        return
    rows = []
    for target, feed in LOADS.items():
        frames = args.frames if target == 150 else max(args.frames // 3, 200)
        env_fps, env_visible = time_env(feed, frames, args.seed)
        merged_fps, _ = time_env(feed, frames, args.seed, merge_touching=True)
        naive_fps, naive_visible = time_naive(feed, frames, args.seed)
        rows.append((target, env_visible, env_fps, merged_fps, naive_fps))
        print(
            f"≈{target} in window: BeltSorter-v0 {env_fps:8.0f} frames/s ({env_visible:.0f} visible), "
            f"with merged blobs {merged_fps:8.0f} frames/s, "
            f"naive pymunk {naive_fps:7.0f} frames/s ({naive_visible:.0f} visible), "
            f"ratio {env_fps / naive_fps:.1f}x, merged {merged_fps / naive_fps:.1f}x"
        )
    print(
        "\n| particles in window | BeltSorter-v0 frames/s | with merged blobs | naive pymunk frames/s "
        "| ratio | ratio, merged |"
    )
    print("|---|---|---|---|---|---|")
    for target, vis, env_fps, merged_fps, naive_fps in rows:
        print(
            f"| ≈{target} (measured {vis:.0f}) | {env_fps:.0f} | {merged_fps:.0f} | {naive_fps:.0f} "
            f"| {env_fps / naive_fps:.1f}x | {merged_fps / naive_fps:.1f}x |"
        )


def step_cost(physics: BeltParams, frames: int, seed: int) -> tuple[float, float, float]:
    """Median seconds per step and per particle in view over ``frames`` steps after the warm-up,
    and the mean particles in view (sizes derived from the scene, empty reports)."""
    env = gym.make("BeltSorter-v0", physics=physics)
    report = empty_report(env.unwrapped.sensor_spec.max_tracks, (2,))  # type: ignore[attr-defined]
    env.reset(seed=seed)
    per_step, per_particle, visible = [], [], []
    for _ in range(frames):
        start = time.perf_counter()
        _, _, _, _, info = env.step(report)
        elapsed = time.perf_counter() - start
        n = int(np.count_nonzero(info["truth"]["ids"] >= 0))
        per_step.append(elapsed)
        per_particle.append(elapsed / max(n, 1))
        visible.append(n)
    env.close()
    return float(np.median(per_step)), float(np.median(per_particle)), float(np.mean(visible))


def industrial_cost(frames: int, seed: int) -> None:
    """The step cost per particle of the industrial belt against the default belt's, same run."""
    default = step_cost(BeltParams(), max(frames, 500), seed)
    industrial = step_cost(BeltParams.industrial(), min(frames, 200), seed)
    print("| belt | particles in view | step (ms) | µs per particle and step |")
    print("|---|---|---|---|")
    for name, (step, particle, visible) in (("default", default), ("industrial", industrial)):
        print(f"| {name} | {visible:,.0f} | {step * 1e3:.2f} | {particle * 1e6:.2f} |")
    print(f"ratio industrial / default per particle: {industrial[1] / default[1]:.2f}")


def nozzle_cost(frames: int, seed: int) -> None:
    """Frames/s of the default env (nozzle bar 0.05 m downstream) and without a bar, merged blobs on."""
    print("| particles in window | with nozzle bar frames/s | without frames/s | ratio |")
    print("|---|---|---|---|")
    for target, feed in LOADS.items():
        n = frames if target == 150 else max(frames // 3, 200)
        with_bar, visible = time_env(feed, n, seed, merge_touching=True)
        without, _ = time_env(feed, n, seed, merge_touching=True, nozzle_offset=None)
        ratio = with_bar / without
        print(f"| ≈{target} (measured {visible:.0f}) | {with_bar:.0f} | {without:.0f} | {ratio:.3f} |")


if __name__ == "__main__":
    main()
