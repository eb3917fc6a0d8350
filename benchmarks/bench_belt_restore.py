"""Benchmark: what restoring a pickled or deep-copied BeltSorter-v0 costs mid-episode.

A restored env rebuilds its pymunk world by replaying the episode from its start (the warm-up
and every frame stepped so far; see ``BeltSorterEnv``'s docstring). This times, at several frames
of an episode, ``pickle.loads`` of the env's pickle and ``copy.deepcopy`` of the env (best of 3),
against the reference timed in the same run: ``reset`` plus stepping to that frame with empty
reports, i.e. playing the episode again. It also prints the pickle's size.

Usage::

    python benchmarks/bench_belt_restore.py [--frames 20 500 1500] [--seed 0]
"""

from __future__ import annotations

import argparse
import copy
import pickle
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import gymnasium as gym

import track_envs  # noqa: F401
from track_envs.contracts.report import empty_report


def best_of_3(fn) -> float:
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, nargs="+", default=[20, 500, 1500])
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    env = gym.make("BeltSorter-v0").unwrapped
    report = empty_report(env.sensor_spec.max_tracks, env.position_shape)

    def play(frames: int) -> None:
        env.reset(seed=args.seed)
        for _ in range(frames):
            env.step(report)

    play(5)  # compile / load the kernels
    print("| frame | reset + steps to it ms | pickle.loads ms | ratio | deepcopy ms | ratio | pickle KB |")
    print("|---|---|---|---|---|---|---|")
    for frames in args.frames:
        reference = best_of_3(lambda frames=frames: play(frames))
        play(frames)
        data = pickle.dumps(env)
        loads = best_of_3(lambda data=data: pickle.loads(data))
        deep = best_of_3(lambda: copy.deepcopy(env))
        print(
            f"| {frames} | {1e3 * reference:.1f} | {1e3 * loads:.1f} | {loads / reference:.2f}x "
            f"| {1e3 * deep:.1f} | {deep / reference:.2f}x | {len(data) / 1e3:.0f} |"
        )


if __name__ == "__main__":
    main()
