"""Per-frame cost of the tracking metrics at ≈150 targets × ≈150 tracks, with motmetrics in the same run.

    python benchmarks/bench_metrics.py [--frames 300] [--warmup 150]

A stream is recorded once: BeltSorter-v0 with a steady feed (≈150 particles in view) answered by
``gnn`` (kf-ca), keeping per frame exactly what ``TrackingMetrics`` hands its metrics (the truth
of the frame, its detection sources and the report answering it). Each metric of
``point_metrics`` then replays the stored stream (``reset`` + one ``update`` per frame; the
``compute`` at the end is timed separately); so does the env's per-step −GOSPA reward
(``gospa(visible truth, live report rows)``) and the ``TrackingMetrics`` wrapper's whole per-step
work. Reference: py-motmetrics' ``MOTAccumulator`` fed the same frames (Euclidean distances,
NaN above the threshold), timed the same way; its summary is compared with ``ClearMot``'s.
Timings are the best of three repetitions.

    python benchmarks/bench_metrics.py --targets 1500,10000,100000 [--frames 30]

instead measures how the per-frame cost of HOTA, CLEAR MOT (+IDF1) and GOSPA grows with the
number of targets: the truth is
[`track_envs.streams.constant_velocity_stream`][track_envs.streams.constant_velocity_stream] at ``N`` targets
in view, the window scaled with ``s = sqrt(N / 150)`` (``(0.5 s, 0.3 s)`` m, the belt's density) and clutter
``5 N / 150``; the reports are the truth with Gaussian noise (1 mm per axis), 2 % of the targets missed, 2 %
false tracks and track ids swapped between neighbours now and then (one swap per 400 targets and frame). Each
metric (match distance 5 mm, the belt's GOSPA cut-off) replays the frames (``reset``, one ``update`` per
frame, then ``compute``, amortised per frame). A metric linear in targets keeps ``µs / frame / target`` flat.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import track_envs  # noqa: F401
from agents import make_agent
from track_envs.envs.belt_physics import BeltParams
from track_envs.metrics import AssociationErrors, ClearMot, GospaMetric, Hota, Metric
from track_envs.metrics.base import live_report, live_truth
from track_envs.metrics.gospa import gospa
from track_envs.streams import constant_velocity_stream

Frame = tuple[dict[str, NDArray], NDArray[np.int64], dict[str, NDArray]]
MM_NAMES = {"mota": "mota", "motp": "motp", "id_switches": "num_switches", "idf1": "idf1"}


def record_stream(frames: int, warmup: int, seed: int) -> tuple[list[Frame], float]:
    """``frames`` (truth, detection_ids, report) triples after ``warmup`` frames, and gospa_c."""
    params = BeltParams(feed_rate=470.0, feed_burstiness=0.0)
    env = gym.make("BeltSorter-v0", physics=params, max_detections=512, max_tracks=512, max_targets=512)
    agent = make_agent("gnn", predictor="kf-ca")
    obs, info = env.reset(seed=seed)
    agent.reset(env.get_wrapper_attr("sensor_spec"), seed=seed)
    stream: list[Frame] = []
    for k in range(warmup + frames):
        report = {key: np.array(value, copy=True) for key, value in agent.act(obs).items()}
        if k >= warmup:
            truth = {key: np.array(value, copy=True) for key, value in info["truth"].items()}
            stream.append((truth, np.array(info["detection_ids"], copy=True), report))
        obs, _, _, _, info = env.step(report)
    return stream, float(env.get_wrapper_attr("gospa_c"))


def best_of_three(run: Callable[[], Any], frames: int) -> tuple[float, Any]:
    """Best wall time of ``run()`` over three repetitions, in µs per frame, and its last result."""
    best, result = np.inf, None
    for _ in range(3):
        start = time.perf_counter()
        result = run()
        best = min(best, time.perf_counter() - start)
    return best / frames * 1e6, result


def replay(metric: Metric, stream: list[Frame]) -> Callable[[], Metric]:
    def run() -> Metric:
        metric.reset()
        for truth, detection_ids, report in stream:
            metric.update(truth, detection_ids, report)
        return metric

    return run


def replay_all(metrics: list[Metric], stream: list[Frame]) -> Callable[[], None]:
    """The per-step work of ``TrackingMetrics``: every metric's update, in order."""

    def run() -> None:
        for metric in metrics:
            metric.reset()
        for truth, detection_ids, report in stream:
            for metric in metrics:
                metric.update(truth, detection_ids, report)

    return run


def reward_replay(stream: list[Frame], c: float) -> Callable[[], float]:
    """The env's reward: GOSPA of the live report rows against the visible truth (as ``_score``)."""
    points = [(live_truth(truth)[1], live_report(report)[1]) for truth, _, report in stream]

    def run() -> float:
        total = 0.0
        for x, y in points:
            total += gospa(x, y, c, 2.0).distance
        return total

    return run


def motmetrics_replay(stream: list[Frame], c: float) -> Callable[[], Any] | None:
    """py-motmetrics' accumulator on the same frames (distances computed per frame, as ours)."""
    try:
        import motmetrics as mm
    except ImportError:
        return None

    def run() -> Any:
        acc = mm.MOTAccumulator(auto_id=True)
        for truth, _, report in stream:
            oids, x = live_truth(truth)
            hids, y, _ = live_report(report)
            d = np.sqrt(((x[:, None, :] - y[None, :, :]) ** 2).sum(-1))
            d[d > c] = np.nan
            acc.update(oids, hids, d)
        return acc

    return run


def motmetrics_summary(acc: Any) -> dict[str, float]:
    import motmetrics as mm

    out = mm.metrics.create().compute(acc, metrics=list(MM_NAMES.values()), return_dataframe=False)
    return {ours: float(out[theirs]) for ours, theirs in MM_NAMES.items()}


def compute_time(metric: Metric) -> float:
    """Wall time of ``compute()`` in ms (once; it is called once per episode)."""
    start = time.perf_counter()
    metric.compute()
    return (time.perf_counter() - start) * 1e3


def describe(stream: list[Frame]) -> str:
    targets = [len(live_truth(truth)[0]) for truth, _, _ in stream]
    tracks = [len(live_report(report)[0]) for _, _, report in stream]
    return f"{len(stream)} frames, {np.mean(targets):.0f} visible targets, {np.mean(tracks):.0f} tracks"


def summary_line(result: Mapping[str, float], keys: list[str]) -> str:
    return ", ".join(f"{k} {result[k]:.7g}" for k in keys)


#: The match distance of the scaling run (m): the belt's GOSPA cut-off.
SCALING_C = 0.005


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
            [
                x[keep] + rng.normal(0, 1e-3, (int(keep.sum()), 2)),
                rng.uniform(0, 1, (n_false, 2)) * (0.5 * s, 0.3 * s),
            ]
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


def scaling(targets: list[int], frames: int, seed: int) -> None:
    """The per-frame cost table of HOTA, CLEAR MOT (+IDF1) and GOSPA at each number of targets."""
    makers: dict[str, Callable[[], Metric]] = {
        "Hota": lambda: Hota(SCALING_C),
        "ClearMot (+IDF1)": lambda: ClearMot(SCALING_C),
        "GospaMetric": lambda: GospaMetric(SCALING_C),
    }
    warm = scaled_frames(150, 3, seed)
    for make in makers.values():  # compile outside the timing
        per_frame_ms(make(), warm)
    print("| metric | targets | update ms/frame | compute ms/frame | µs/frame/target |")
    print("|---|---|---|---|---|")
    for n in targets:
        stream = scaled_frames(n, frames, seed)
        mean_n = np.mean([len(f[0]["ids"]) for f in stream])
        for name, make in makers.items():
            up, comp, _ = per_frame_ms(make(), stream)
            print(
                f"| {name} | {mean_n:.0f} | {up:.2f} | {comp:.2f} | {(up + comp) / mean_n * 1e3:.2f} |",
                flush=True,
            )


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--warmup", type=int, default=150)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--targets", default="", help="comma-separated target counts: the scaling table")
    args = parser.parse_args()
    if args.targets:
        scaling([int(v) for v in args.targets.split(",")], args.frames, args.seed)
        return
    stream, c = record_stream(args.frames, args.warmup, args.seed)
    print(f"stream: {describe(stream)}, c = {c}")
    n = len(stream)
    metrics: list[tuple[str, Metric]] = [
        ("AssociationErrors (e1/e2)", AssociationErrors()),
        ("ClearMot (MOTA/MOTP/IDSW/IDF1)", ClearMot(threshold=c)),
        ("GospaMetric", GospaMetric(c=c)),
    ]
    for _, metric in metrics:  # compile / warm caches outside the timing
        replay(metric, stream[:5])()
    rows = []
    for name, metric in metrics:
        us, _ = best_of_three(replay(metric, stream), n)
        rows.append((name, us, compute_time(metric)))
    total_us, _ = best_of_three(replay_all([m for _, m in metrics], stream), n)
    reward_us, _ = best_of_three(reward_replay(stream, c), n)
    print("\n| metric (update per frame) | µs/frame | compute() ms |")
    print("|---|---|---|")
    for name, us, ms in rows:
        print(f"| {name} | {us:.1f} | {ms:.2f} |")
    print(f"| all of point_metrics (TrackingMetrics per step) | {total_us:.1f} | |")
    print(f"| env reward: gospa(visible truth, report) | {reward_us:.1f} | |")
    ours = dict(metrics)["ClearMot (MOTA/MOTP/IDSW/IDF1)"].compute()
    print(f"\nClearMot: {summary_line(ours, list(MM_NAMES))}")
    mm_run = motmetrics_replay(stream, c)
    if mm_run is None:
        print("py-motmetrics not installed: no same-run reference")
        return
    mm_us, acc = best_of_three(mm_run, n)
    theirs = motmetrics_summary(acc)
    same = all(np.isclose(ours[k], theirs[k], rtol=1e-12, atol=0) for k in MM_NAMES)
    clear_us = rows[1][1]
    print(f"motmetrics: {summary_line(theirs, list(MM_NAMES))} ({'same' if same else 'DIFFERENT'})")
    print(
        f"motmetrics MOTAccumulator.update: {mm_us:.1f} µs/frame; ClearMot.update {clear_us:.1f} µs/frame "
        f"= {mm_us / clear_us:.0f}x faster"
    )


if __name__ == "__main__":
    main()
