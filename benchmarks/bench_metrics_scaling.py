"""Per-frame cost of the point metrics (HOTA, CLEAR MOT + IDF1, GOSPA) against the number of targets.

    python benchmarks/bench_metrics_scaling.py [--targets 1500,10000] [--frames 30]

The truth is :func:`track_envs.streams.constant_velocity_stream` at ``N`` targets in view, the
window scaled with ``s = sqrt(N / 150)`` (``(0.5 s, 0.3 s)`` m, the belt's density) and clutter
``5 N / 150``; the reports are the truth with Gaussian noise (1 mm per axis), 2 % of the targets
missed, 2 % false tracks, and track ids that swap between neighbours now and then (0.5 % of the
tracks per frame). Each metric (match distance ``c`` = 5 mm, the belt's GOSPA cut-off) replays
the frames (``reset``, one ``update`` per frame, ``compute``), timed per frame (update) and
``compute`` amortised per frame. A metric linear in targets keeps ``µs/frame ÷ N`` flat.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from track_envs.metrics import ClearMot, GospaMetric, Hota
from track_envs.streams import constant_velocity_stream

Frame = tuple[dict[str, NDArray], NDArray[np.int64], dict[str, NDArray]]
C = 0.005


def scaled_frames(n_targets: int, frames: int, seed: int) -> list[Frame]:
    """``frames`` (truth, detection_ids, report) triples at ``n_targets`` targets (module docstring)."""
    rng = np.random.default_rng(seed)
    s = float(np.sqrt(n_targets / 150.0))
    stream = constant_velocity_stream(
        rng, n_targets=n_targets, frames=frames, size=(0.5 * s, 0.3 * s), clutter_rate=5 * n_targets / 150
    )
    track_of: dict[int, int] = {}
    out: list[Frame] = []
    next_false = 10**9
    for t in range(frames):
        truth = stream.truth(t)
        ids, x = truth["ids"], truth["positions"]
        for i in ids.tolist():
            track_of.setdefault(i, len(track_of))
        tracks = np.array([track_of[i] for i in ids.tolist()], dtype=np.int64)
        # swap the track ids of a few pairs of targets that are next to each other in the list
        swaps = rng.choice(max(len(ids) - 1, 1), size=max(len(ids) // 400, 1), replace=False)
        for a in swaps[swaps + 1 < len(ids)].tolist():
            ga, gb = int(ids[a]), int(ids[a + 1])
            track_of[ga], track_of[gb] = track_of[gb], track_of[ga]
        keep = rng.random(len(ids)) > 0.02
        n_false = int(0.02 * len(ids))
        y = np.concatenate(
            [x[keep] + rng.normal(0, 1e-3, (int(keep.sum()), 2)), rng.uniform(0, 0.5 * s, (n_false, 2))]
        )
        report_ids = np.concatenate([tracks[keep], np.arange(next_false, next_false + n_false)])
        next_false += n_false
        report = {
            "ids": report_ids,
            "positions": y,
            "detection": np.full(len(y), -1, dtype=np.int64),
            "mask": np.ones(len(y), dtype=np.int8),
        }
        out.append((truth, np.full(1, -1, dtype=np.int64), report))
    return out


def per_frame_ms(metric: object, frames: list[Frame]) -> tuple[float, float, dict[str, float]]:
    """(update ms/frame, compute ms/frame amortised, the summary)."""
    metric.reset()  # type: ignore[attr-defined]
    start = time.perf_counter()
    for truth, detection_ids, report in frames:
        metric.update(truth, detection_ids, report)  # type: ignore[attr-defined]
    mid = time.perf_counter()
    result = metric.compute()  # type: ignore[attr-defined]
    end = time.perf_counter()
    return (mid - start) / len(frames) * 1e3, (end - mid) / len(frames) * 1e3, result


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--targets", default="1500,10000")
    parser.add_argument("--frames", type=int, default=30)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    warm = scaled_frames(150, 3, args.seed)
    makers = {
        "Hota": lambda: Hota(C),
        "ClearMot (+IDF1)": lambda: ClearMot(C),
        "GospaMetric": lambda: GospaMetric(C),
    }
    for make in makers.values():  # compile outside the timing
        per_frame_ms(make(), warm)
    print("| metric | targets | update ms/frame | compute ms/frame | total µs/frame/target |")
    print("|---|---|---|---|---|")
    for n in [int(v) for v in args.targets.split(",")]:
        frames = scaled_frames(n, args.frames, args.seed)
        mean_n = np.mean([len(f[0]["ids"]) for f in frames])
        for name, make in makers.items():
            up, comp, _ = per_frame_ms(make(), frames)
            print(f"| {name} | {mean_n:.0f} | {up:.2f} | {comp:.2f} | {(up + comp) / mean_n * 1e3:.2f} |")


if __name__ == "__main__":
    main()
