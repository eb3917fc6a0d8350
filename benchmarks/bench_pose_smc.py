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

A second table times the LSTM alone on the windows the default variant encodes in those frames
(recorded in a separate, untimed run), median of ``--repeats`` passes: torch's ``nn.LSTM`` of the
network (oneDNN), and the shared float32 cell (:class:`predictors.lstm_cell.FusedLSTMCell`) with its
products by numpy (its BLAS, whose threads are its own, not ``--threads``) and by ``torch.matmul``
(the predictor's), with the largest difference of their outputs ``h`` from ``nn.LSTM``'s.

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
from predictors.lstm_cell import LSTMCellWeights
from predictors.pose_lstm.motion import DEFAULT_MODEL
from predictors.pose_lstm.predictor import PosePredictor
from track_envs.report import empty_report


class RecordingPredictor(PosePredictor):
    """The pose predictor, keeping a copy of every batch of windows it encodes."""

    def __init__(self, model: Path) -> None:
        super().__init__(model)
        self.windows: list[np.ndarray] = []

    def encode(self, inputs: np.ndarray) -> np.ndarray:
        self.windows.append(np.array(inputs))
        return super().encode(inputs)


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


def time_encodes(windows: list[np.ndarray], repeats: int) -> list[tuple[str, float, float]]:
    """(label, median ms per frame, max |h − h_nn.LSTM|) of each LSTM over the recorded windows."""
    predictor = PosePredictor(DEFAULT_MODEL)
    weights = LSTMCellWeights.from_tensors(predictor.model.tensors, "lstm.", "_l0")

    def nn_lstm(x: np.ndarray) -> np.ndarray:
        with torch.inference_mode():
            return predictor.net.lstm(torch.from_numpy(x))[1][0][0].numpy()

    encoders = {
        "torch nn.LSTM (oneDNN)": nn_lstm,
        "FusedLSTMCell, numpy matmul": lambda x: weights.fused("numpy").sequence(x)[0],
        "FusedLSTMCell, torch matmul (the predictor's)": predictor.encode,
    }
    reference = [nn_lstm(x) for x in windows]
    times: dict[str, list[float]] = {label: [] for label in encoders}
    for _ in range(repeats):  # interleaved, so that the machine's load weighs on each alike
        for label, encode in encoders.items():
            t0 = time.perf_counter()
            for x in windows:
                encode(x)
            times[label].append((time.perf_counter() - t0) / len(windows))
    rows = []
    for label, encode in encoders.items():
        err = max(float(np.abs(encode(x) - r).max()) for x, r in zip(windows, reference, strict=True))
        rows.append((label, float(np.median(times[label])), err))
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--people", type=int, default=10)
    parser.add_argument("--particles", type=int, default=300)
    parser.add_argument("--window", type=int, default=10)
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--warmup", type=int, default=5)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=5, help="passes of the LSTM timing (median)")
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
    recorder = PoseSmcAgent(particles=args.particles, window=args.window)
    recorder.motion.predictor = RecordingPredictor(DEFAULT_MODEL)
    recorder.reset(spec, seed=0)
    for i, obs in enumerate(stream):
        if i == args.warmup:
            recorder.motion.predictor.windows.clear()
        recorder.act(obs)
    windows = recorder.motion.predictor.windows
    print(
        f"\nLSTM of the default variant's windows: {np.mean([len(x) for x in windows]):.0f} sequences "
        f"x {args.window} steps per frame, median of {args.repeats} passes"
    )
    print("| LSTM | ms / frame | speed-up | max abs(h - h_nn.LSTM) |")
    print("|---|---|---|---|")
    encodes = time_encodes(windows, args.repeats)
    for label, dt, err in encodes:
        print(f"| {label} | {dt * 1e3:.1f} | {encodes[0][1] / dt:.2f}x | {err:.1e} |")


if __name__ == "__main__":
    main()
