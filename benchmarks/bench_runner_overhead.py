"""Overhead of the track bench runner over a plain loop running the same episodes.

Both sides build the env (with TrackingMetrics) and the agent per cell and run the same seeded
episodes; the runner adds the cell hash, the record (metrics, timings, versions) and its atomic
write, the skip check and the progress bar. Both run in this process (``--workers 1``), each
timed ``--repeats`` times alternately; the best of each is compared.

python benchmarks/bench_runner_overhead.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import tempfile
import time

import track_envs  # noqa: F401
from track_apps.bench import Cell, run_cells
from track_apps.bench.runner import make_cell_agent, make_env, run_episode

CELLS = [
    *(Cell("BeltSorter-v0", "gnn", "kf-ca", s, steps=200) for s in range(4)),
    *(Cell("BeltSorter-v0", "detections", "-", s, steps=200) for s in range(2)),
    *(Cell("SineTarget-v0", "pf", "-", s, steps=200) for s in range(4)),
    *(Cell("KeypointWalkers-v0", "pose-baseline", "-", s, steps=100) for s in range(2)),
]


def plain_loop() -> float:
    t0 = time.perf_counter()
    for cell in CELLS:
        env, agent = make_env(cell), make_cell_agent(cell)
        run_episode(env, agent, cell.seed)
        env.close()
    return time.perf_counter() - t0


def runner() -> float:
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        run_cells(CELLS, out, workers=1, progress=True)
        return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    plain_loop()  # warm-up: imports, caches, replay file
    plain, bench = [], []
    for _ in range(args.repeats):
        plain.append(plain_loop())
        bench.append(runner())
    p, b = min(plain), min(bench)
    frames = sum(c.steps or 0 for c in CELLS)
    print(f"{len(CELLS)} cells, {frames} frames, best of {args.repeats}")
    print(f"plain loop: {p:.3f} s   runner: {b:.3f} s   overhead: {100 * (b - p) / p:+.1f} % (target < 5 %)")


if __name__ == "__main__":
    main()
