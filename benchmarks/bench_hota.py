"""HotaAccumulator against TrackEval's HOTA.eval_sequence on the same per-frame similarity matrices.

    python benchmarks/bench_hota.py [--frames 5000] [--targets 40] [--repeat 3]

Sequences: the two MOT15 sequences py-motmetrics ships (TUD-Campus, TUD-Stadtmitte; box IoU of
test.txt against gt.txt) and a long synthetic point scene (``--targets`` random walkers born and
dying, a tracker that misses 10%, adds clutter, swaps identities now and then; similarity
``max(0, 1 − d/τ)``). The similarity matrices are computed once; then each side is timed on
them, best of ``--repeat``: ours is ``add_frame`` for every frame plus ``compute()``, TrackEval's
is ``HOTA().eval_sequence`` on the data dict its datasets build (ids already relabelled 0.., which
its dataset loaders do outside the metric and this script does not time). The figures of the two
are compared (max abs difference over the α-arrays).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from track_envs.metrics.hota import HOTA_FIELDS, HotaAccumulator
from track_envs.metrics.hota_similarity import box_iou, point_similarity

Frame = tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]


def tud_frames(name: str) -> list[Frame]:
    """(gt ids, tracker ids, IoU) per frame of a MOT15 sequence shipped with py-motmetrics."""
    import motmetrics

    data = Path(motmetrics.__file__).parent / "data" / name
    gt = np.loadtxt(data / "gt.txt", delimiter=",")
    dt = np.loadtxt(data / "test.txt", delimiter=",")
    frames = []
    for t in range(1, int(max(gt[:, 0].max(), dt[:, 0].max())) + 1):
        g, d = gt[gt[:, 0] == t], dt[dt[:, 0] == t]
        frames.append((g[:, 1].astype(np.int64), d[:, 1].astype(np.int64), box_iou(g[:, 2:6], d[:, 2:6])))
    return frames


def synthetic_frames(
    rng: np.random.Generator, n_frames: int, n_targets: int, tau: float = 1.0
) -> list[Frame]:
    """Random walkers in a 20 × 20 box (each dies with probability 1/200 per frame and is replaced
    by a new id), tracked with noise 0.2, 10% misses, 3 clutter rows per frame, and a tracker id
    that changes with probability 1/300 per frame."""
    positions = rng.uniform(0, 20, (n_targets, 2))
    velocity = rng.normal(0, 0.05, (n_targets, 2))
    ids = np.arange(n_targets)
    track_of = np.arange(n_targets) + 100_000
    next_id, next_track = n_targets, 100_000 + n_targets
    frames = []
    for _ in range(n_frames):
        dead = rng.random(n_targets) < 1 / 200
        n_dead = int(dead.sum())
        ids[dead] = np.arange(next_id, next_id + n_dead)
        next_id += n_dead
        positions[dead] = rng.uniform(0, 20, (n_dead, 2))
        switched = dead | (rng.random(n_targets) < 1 / 300)
        n_new = int(switched.sum())
        track_of[switched] = np.arange(next_track, next_track + n_new)
        next_track += n_new
        velocity += rng.normal(0, 0.01, velocity.shape)
        positions += velocity
        seen = rng.random(n_targets) > 0.1
        reported = positions[seen] + rng.normal(0, 0.2, (int(seen.sum()), 2))
        clutter = rng.uniform(0, 20, (3, 2))
        tracker_ids = np.concatenate([track_of[seen], rng.integers(10**9, 2 * 10**9, 3)])
        points = np.concatenate([reported, clutter])
        frames.append((ids.copy(), tracker_ids, point_similarity(positions, points, tau)))
    return frames


def trackeval_data(frames: list[Frame]) -> dict[str, Any]:
    gt_values = np.unique(np.concatenate([f[0] for f in frames]))
    tr_values = np.unique(np.concatenate([f[1] for f in frames]))
    return {
        "num_gt_dets": sum(f[0].size for f in frames),
        "num_tracker_dets": sum(f[1].size for f in frames),
        "num_gt_ids": gt_values.size,
        "num_tracker_ids": tr_values.size,
        "gt_ids": [np.searchsorted(gt_values, f[0]) for f in frames],
        "tracker_ids": [np.searchsorted(tr_values, f[1]) for f in frames],
        "similarity_scores": [f[2] for f in frames],
    }


def best_of(repeat: int, work: Callable[[], Any]) -> tuple[float, Any]:
    times, out = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        out = work()
        times.append(time.perf_counter() - start)
    return min(times), out


def ours(frames: list[Frame]) -> dict[str, NDArray[np.float64]]:
    acc = HotaAccumulator()
    for frame in frames:
        acc.add_frame(*frame)
    return acc.compute_arrays()


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=5000, help="frames of the synthetic scene")
    parser.add_argument("--targets", type=int, default=40, help="targets in view in the synthetic scene")
    parser.add_argument("--repeat", type=int, default=3, help="timings per side (the best is kept)")
    args = parser.parse_args(argv)

    from trackeval.metrics import HOTA

    sequences = {
        "TUD-Campus (MOT15, IoU)": tud_frames("TUD-Campus"),
        "TUD-Stadtmitte (MOT15, IoU)": tud_frames("TUD-Stadtmitte"),
        f"synthetic points ({args.targets} targets)": synthetic_frames(
            np.random.default_rng(0), args.frames, args.targets
        ),
    }
    load = os.getloadavg()
    print(f"load average: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} (1/5/15 min), {os.cpu_count()} CPUs")
    print(
        f"{'sequence':34s} {'frames':>6s} {'rows':>7s} {'HOTA':>7s} {'ours ms':>9s} {'TrackEval ms':>12s} "
        f"{'speed-up':>8s} {'max |diff|':>10s}"
    )
    for name, frames in sequences.items():
        data = trackeval_data(frames)
        metric = HOTA({"PRINT_CONFIG": False})
        t_ours, mine = best_of(args.repeat, lambda frames=frames: ours(frames))
        t_te, theirs = best_of(args.repeat, lambda data=data, metric=metric: metric.eval_sequence(data))
        diff = max(float(np.max(np.abs(mine[k] - theirs[k]))) for k in HOTA_FIELDS)
        rows = data["num_gt_dets"] + data["num_tracker_dets"]
        print(
            f"{name:34s} {len(frames):6d} {rows:7d} {np.mean(mine['HOTA']):7.4f} {1e3 * t_ours:9.1f} "
            f"{1e3 * t_te:12.1f} {t_te / t_ours:7.1f}x {diff:10.1e}"
        )


if __name__ == "__main__":
    main()
