"""Tracker frame time: 150 tracks × 150 detections, a dense recorded belt stream, the whole loop.

    python benchmarks/bench_tracker.py [--frames 300] [--tracker-only]

1. **Tracker**: the batched GNN tracker (``gnn`` + ``kf-cv`` and ``kf-ca``) against
   `FilterpyGnn`, a per-object loop over ``filterpy.kalman.KalmanFilter`` written here (not
   a filterpy tracker: filterpy ships filters only) — one ``KalmanFilter`` object per track, a
   vectorised Mahalanobis cost, χ² gate and ``scipy.optimize.linear_sum_assignment`` — on the same
   observations: 150 targets on a belt-like flow (1.2 m/s along x, small lateral jitter) seen every
   frame with 0.1 mm noise, detection rows shuffled. Both trackers are warmed up until they hold
   ≈150 tracks; then each frame (predict, gate, associate, update, births, deaths, report) is timed.
2. **Dense recorded stream**: BeltSorter-v0's true centroids at a feed of 330 particles/s
   (``record_belt_sorter``), replayed by BeltReplay-v0 with 0.1 mm noise: ≈100 detections per
   frame, ≈3 particles entering every frame, so births, start states and the second chance run
   in every frame. Each frame is timed on its own: the mean and the 99th percentile of the
   repetition with the least total time, against the same reference (its new tracks start at
   0.9 m/s, the entry speed). Then the longest of the first frames in a new process, without
   and with ``agent.warm_up()``.
3. **Whole loop**: BeltSorter-v0 with ≈150 particles in view + ``gnn`` (kf-ca) + TrackingMetrics,
   and the same loop without metrics, so the metrics' share of the frame is visible.

Timings are the best of three repetitions; ratios are against the reference timed in this run.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from functools import partial
from pathlib import Path

import gymnasium as gym
import numpy as np
from filterpy.kalman import KalmanFilter
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment
from scipy.stats import chi2

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import track_envs  # noqa: F401
from agents import make_agent
from predictors.kalman.predictor import cv_model
from track_envs.contracts.report import empty_report, pack_report
from track_envs.envs.belt_physics import BeltParams
from track_envs.envs.recording import record_belt_sorter
from track_envs.values.types import SensorSpec
from track_envs.wrappers import TrackingMetrics

N_TARGETS = 150
#: Feed rate (particles/s) of the dense recorded stream: ≈100 particles in view.
DENSE_FEED = 330.0
DT = 0.01
NOISE = 1e-4
SPEC = SensorSpec(
    dt=DT,
    dim=2,
    noise_std=NOISE,
    p_detect=1.0,
    clutter_rate=0.0,
    region_low=(-1.0, -1.0),
    region_high=(1e6, 2.0),
    max_detections=256,
    max_tracks=256,
)


def synthetic_observations(frames: int, seed: int) -> list[dict[str, np.ndarray]]:
    """150 targets on a grid moving at ≈1.2 m/s with jitter; all detected, shuffled rows."""
    rng = np.random.default_rng(seed)
    grid = np.stack(np.meshgrid(np.arange(15) * 0.02, np.arange(10) * 0.018 + 0.005), -1).reshape(-1, 2)
    velocity = np.column_stack([1.2 + 0.05 * rng.normal(size=N_TARGETS), 0.01 * rng.normal(size=N_TARGETS)])
    out = []
    x = grid.copy()
    for _ in range(frames):
        x = x + velocity * DT
        z = x + NOISE * rng.normal(size=x.shape)
        order = rng.permutation(N_TARGETS)
        det = np.zeros((SPEC.max_detections, 2), np.float32)
        det[:N_TARGETS] = z[order]
        mask = np.zeros(SPEC.max_detections, np.int8)
        mask[:N_TARGETS] = 1
        out.append({"detections": det, "mask": mask})
    return out


class FilterpyGnn:
    """Reference GNN written in this repository: a loop over one filterpy KalmanFilter per track (CV,
    same F, Q, H, R as kf-cv) for predict and update, a vectorised Mahalanobis cost, χ² gate and
    scipy's assignment; a track is dropped at its first miss."""

    def __init__(self, q: float = 1.0, p_gate: float = 0.999, velocity=(1.2, 0.0), spec: SensorSpec = SPEC):
        self.spec = spec
        self.noise = max(spec.noise_std, 1e-6)
        self.F, self.Q, self.H = cv_model(2, spec.dt, q)
        self.R = np.eye(2) * self.noise**2
        self.gate = chi2.ppf(p_gate, 2)
        self.velocity = np.asarray(velocity)
        self.filters: list[KalmanFilter] = []
        self.ids: list[int] = []
        self.next_id = 0

    def _new(self, z: np.ndarray) -> KalmanFilter:
        kf = KalmanFilter(dim_x=4, dim_z=2)
        kf.F, kf.Q, kf.H, kf.R = self.F, self.Q, self.H, self.R
        kf.x = np.array([z[0], z[1], *self.velocity])
        kf.P = np.diag([self.noise**2, self.noise**2, 0.1**2, 0.1**2])
        return kf

    def act(self, obs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        rows = np.flatnonzero(obs["mask"])
        z = obs["detections"][rows].astype(np.float64)
        for kf in self.filters:
            kf.predict()
        det_of = np.full(len(self.filters), -1)
        if self.filters and len(z):
            mean = np.array([kf.H @ kf.x for kf in self.filters])
            cov = np.array([kf.H @ kf.P @ kf.H.T + kf.R for kf in self.filters])
            diff = z[None] - mean[:, None]
            cost = np.einsum("nmi,nij,nmj->nm", diff, np.linalg.inv(cov), diff)
            big = 1e9
            r, c = linear_sum_assignment(np.where(cost <= self.gate, cost, big))
            ok = cost[r, c] <= self.gate
            det_of[r[ok]] = c[ok]
        for kf, d in zip(self.filters, det_of, strict=True):
            if d >= 0:
                kf.update(z[d])
        used = np.zeros(len(z), bool)
        used[det_of[det_of >= 0]] = True
        keep = det_of >= 0
        self.filters = [kf for kf, k in zip(self.filters, keep, strict=True) if k]
        self.ids = [i for i, k in zip(self.ids, keep, strict=True) if k]
        det_rows = [int(rows[d]) for d in det_of[keep]]
        for j in np.flatnonzero(~used):
            self.filters.append(self._new(z[j]))
            self.ids.append(self.next_id)
            self.next_id += 1
            det_rows.append(int(rows[j]))
        positions = np.array([kf.x[:2] for kf in self.filters]).reshape(-1, 2)
        return pack_report(np.array(self.ids), positions, np.array(det_rows), self.spec.max_tracks)


def dense_belt_stream(frames: int, seed: int = 0) -> tuple[SensorSpec, list[dict[str, np.ndarray]]]:
    """A recorded dense belt stream: ≈100 particles in view, ≈3 entering every frame.

    BeltSorter-v0's true centroids at a feed of 330 particles/s are recorded with
    ``record_belt_sorter`` and replayed by BeltReplay-v0 with 0.1 mm noise.
    """
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "dense.csv"
        record_belt_sorter(
            path, frames, seed=seed, feed_rate=DENSE_FEED, max_detections=512, max_tracks=512, max_targets=512
        )
        env = gym.make("BeltReplay-v0", path=str(path), noise_std=NOISE)
        spec = env.unwrapped.sensor_spec  # type: ignore[attr-defined]
        obs, _ = env.reset(seed=seed)
        report = empty_report(spec.max_tracks, (2,))
        out = []
        for _ in range(frames - 1):
            out.append(obs)
            obs, *_ = env.step(report)
    return spec, out


def frame_times(make, observations: list, warm: int, repeats: int = 3) -> tuple[NDArray, int]:
    """Per-frame times (s) of the repetition with the least total time, and the tracks at the end."""
    best: NDArray = np.full(1, np.inf)
    tracks = 0
    for _ in range(repeats):
        agent = make()
        for obs in observations[:warm]:
            agent.act(obs)
        times = np.empty(len(observations) - warm)
        for k, obs in enumerate(observations[warm:]):
            start = time.perf_counter()
            report = agent.act(obs)
            times[k] = time.perf_counter() - start
        if times.sum() < best.sum():
            best = times
        tracks = int(report["mask"].sum())
    return best, tracks


def time_tracker(make, observations: list, warm: int) -> tuple[float, int]:
    best = np.inf
    tracks = 0
    for _ in range(3):
        agent = make()
        for obs in observations[:warm]:
            agent.act(obs)
        start = time.perf_counter()
        for obs in observations[warm:]:
            report = agent.act(obs)
        best = min(best, time.perf_counter() - start)
        tracks = int(report["mask"].sum())
    return (len(observations) - warm) / best, tracks


def make_gnn(predictor: str, spec: SensorSpec = SPEC):
    def make():
        agent = make_agent("gnn", predictor=predictor)
        agent.reset(spec)
        return agent

    return make


def time_loop(frames: int, with_metrics: bool) -> tuple[float, float]:
    params = BeltParams(feed_rate=470.0, feed_burstiness=0.0)
    best, visible = np.inf, []
    for rep in range(3):
        env = gym.make("BeltSorter-v0", physics=params, max_detections=512, max_tracks=512, max_targets=512)
        if with_metrics:
            env = TrackingMetrics(env)
        agent = make_agent("gnn", predictor="kf-ca")
        obs, _ = env.reset(seed=rep)
        agent.reset(env.get_wrapper_attr("sensor_spec"))
        start = time.perf_counter()
        for _ in range(frames):
            obs, *_ = env.step(agent.act(obs))
            if rep == 0:
                visible.append(int(obs["mask"].sum()))
        best = min(best, time.perf_counter() - start)
    return frames / best, float(np.mean(visible))


def _print_tracker_table(rows: list[tuple[str, float, int, float]]) -> None:
    print("\n| tracker, 150 tracks × 150 detections | frames/s | tracks | vs reference |")
    print("|---|---|---|---|")
    for name, fps, tracks, ratio in rows:
        print(f"| {name} | {fps:.0f} | {tracks} | {ratio:.1f}x |")


def dense_belt_report(frames: int) -> list[tuple[str, float, float, int, float]]:
    """Mean and 99th-percentile frame times on the dense recorded stream, against the reference."""
    spec, observations = dense_belt_stream(frames + 40)
    mean_dets = np.mean([obs["mask"].sum() for obs in observations])
    print(f"dense recorded belt stream: {len(observations)} frames, {mean_dets:.0f} detections per frame")
    ref_times, ref_tracks = frame_times(
        partial(FilterpyGnn, velocity=(0.9, 0.0), spec=spec), observations, 40
    )
    reference = "per-object filterpy loop (FilterpyGnn)"
    out = [(reference, ref_times.mean(), np.percentile(ref_times, 99), ref_tracks, 1.0)]
    for predictor in ("kf-cv", "kf-ca"):
        times, tracks = frame_times(make_gnn(predictor, spec), observations, 40)
        out.append(
            (
                f"gnn + {predictor}",
                times.mean(),
                np.percentile(times, 99),
                tracks,
                ref_times.mean() / times.mean(),
            )
        )
    for name, mean, p99, tracks, ratio in out:
        print(f"{name}: {mean * 1e6:.0f} µs/frame (p99 {p99 * 1e6:.0f} µs), {tracks} tracks, {ratio:.1f}x")
    return out


def _print_dense_table(rows: list[tuple[str, float, float, int, float]]) -> None:
    print(
        "\n| tracker, dense recorded belt stream (≈100 detections/frame) "
        "| µs/frame | p99 µs | tracks | vs reference |"
    )
    print("|---|---|---|---|---|")
    for name, mean, p99, tracks, ratio in rows:
        print(f"| {name} | {mean * 1e6:.0f} | {p99 * 1e6:.0f} | {tracks} | {ratio:.1f}x |")


def first_frames(warm_up: bool, frames: int = 60) -> None:
    """In this (fresh) process: the longest of the first frames of the dense stream, with or
    without ``agent.warm_up()`` before the stream starts (the kernels load on first use)."""
    spec, observations = dense_belt_stream(frames + 1)
    agent = make_agent("gnn", predictor="kf-ca")
    start = time.perf_counter()
    if warm_up:
        agent.warm_up()
    warm_s = time.perf_counter() - start
    agent.reset(spec)
    times = []
    for obs in observations[:frames]:
        start = time.perf_counter()
        agent.act(obs)
        times.append(time.perf_counter() - start)
    label = f"with warm_up() ({warm_s * 1e3:.0f} ms before the stream)" if warm_up else "cold"
    print(f"| first {frames} frames, {label} | {max(times) * 1e3:.1f} | {sum(times) * 1e3:.1f} |")


def first_frames_table() -> None:
    """`first_frames` in two fresh processes (cold, then with the warm-up)."""
    print("\n| new process, dense stream, gnn + kf-ca | longest frame ms | sum ms |")
    print("|---|---|---|")
    for flag in ("cold", "warm"):
        subprocess.run([sys.executable, __file__, "--first-frames", flag], check=True)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--tracker-only", action="store_true", help="skip the whole-loop part (2.)")
    parser.add_argument("--first-frames", choices=["cold", "warm"], help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.first_frames:
        first_frames(args.first_frames == "warm")
        return
    observations = synthetic_observations(args.frames + 20, seed=0)
    ref_fps, ref_tracks = time_tracker(FilterpyGnn, observations, 20)
    print(
        "reference FilterpyGnn (per-object filterpy loop + vectorised cost + scipy): "
        f"{ref_fps:8.0f} frames/s, "
        f"{ref_tracks} tracks"
    )
    rows = [("per-object filterpy loop (FilterpyGnn)", ref_fps, ref_tracks, 1.0)]
    for predictor in ("kf-cv", "kf-ca"):
        fps, tracks = time_tracker(make_gnn(predictor), observations, 20)
        rows.append((f"gnn + {predictor} (batched)", fps, tracks, fps / ref_fps))
        print(f"gnn + {predictor}: {fps:8.0f} frames/s, {tracks} tracks, {fps / ref_fps:.1f}x the reference")
    dense = dense_belt_report(args.frames)
    if args.tracker_only:
        _print_tracker_table(rows)
        _print_dense_table(dense)
        first_frames_table()
        return
    loop_fps, visible = time_loop(args.frames, with_metrics=True)
    bare_fps, _ = time_loop(args.frames, with_metrics=False)
    share = 1.0 - loop_fps / bare_fps
    print(
        f"whole loop BeltSorter-v0 + gnn/kf-ca + TrackingMetrics: {loop_fps:.0f} frames/s "
        f"({visible:.0f} visible)"
    )
    print(f"same loop without metrics: {bare_fps:.0f} frames/s; metrics' share of the frame {share:.0%}")
    _print_tracker_table(rows)
    _print_dense_table(dense)
    first_frames_table()
    print("\n| whole loop (≈150 in view) | frames/s |")
    print("|---|---|")
    print(f"| BeltSorter-v0 + gnn (kf-ca) + TrackingMetrics | {loop_fps:.0f} |")
    print(f"| same, without TrackingMetrics | {bare_fps:.0f} (metrics {share:.0%} of the frame) |")


if __name__ == "__main__":
    main()
