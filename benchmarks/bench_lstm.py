"""Speed of the belt LSTM predictors: one frame of 150 tracks, MC dropout, and the whole loop.

    python benchmarks/bench_lstm.py [--tracks 150] [--frames 300]

1. **lstm / nll-lstm predict + update** for 150 tracks (one frame of the tracker's predictor
   work), against the reference of the same network as plain torch eager ``nn.LSTMCell`` layers
   and a linear head on one thread, timed in this run.
2. **mc-lstm, T = 250 samples**, predict + update for 150 tracks: the grouped inference (each
   distinct dropout sample once, [`predictors.belt_lstm.mc_dropout`][predictors.belt_lstm.mc_dropout]) against
   the plain computation of all ``T`` masked passes in numpy, and against fully batched torch (``150 × 250``
   rows through the same cells), all timed in this run.
3. **Whole loop**: BeltSorter-v0 with ≈150 particles in view, gnn with ``nll-lstm``, and
   TrackingMetrics, frames per second (the reference is the same loop with ``kf-ca``), with
   touching particles merged into blobs (the default) and without.

Timings are the best of several repetitions on one thread (numpy's BLAS included: the
``OPENBLAS_NUM_THREADS`` default below must be set before numpy loads).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import track_envs  # noqa: F401
from agents import make_agent
from predictors import make_predictor
from predictors.belt_lstm.predictor import LSTMPredictor
from track_envs.envs.belt_physics import BeltParams
from track_envs.wrappers import TrackingMetrics


def best_time(fn: Callable[[], object], repeat: int = 7, number: int = 20) -> float:
    """Best mean seconds per call over ``repeat`` runs of ``number`` calls."""
    fn()
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter() - t0) / number)
    return best


def tracks_in_view(n: int) -> tuple[object, np.ndarray]:
    """A sensor spec and ``n`` plausible track positions (three frames) inside its window."""
    env = gym.make("BeltSorter-v0")
    spec = env.unwrapped.sensor_spec  # type: ignore[attr-defined]
    rng = np.random.default_rng(0)
    low, size = np.asarray(spec.region_low), np.asarray(spec.region_size)
    start = low + rng.random((n, 2)) * size * [0.8, 1.0]
    z = np.stack([start + np.array([0.011 * k, 0.0]) for k in range(3)])
    return spec, z


def torch_reference(n: int, samples: int = 1) -> Callable[[], object]:
    """Plain torch eager cells (4 → 64 → 32 → head), one step of ``n × samples`` rows."""
    torch.manual_seed(0)
    c1, c2, head = torch.nn.LSTMCell(4, 64), torch.nn.LSTMCell(64, 32), torch.nn.Linear(32, 4)
    rows = n * samples
    x = torch.randn(rows, 4)
    s = [torch.zeros(rows, 64), torch.zeros(rows, 64), torch.zeros(rows, 32), torch.zeros(rows, 32)]

    def step() -> object:
        with torch.no_grad():
            h1, _ = c1(x, (s[0], s[1]))
            h2, _ = c2(h1, (s[2], s[3]))
            return head(h2)

    return step


def frame(predictor: LSTMPredictor, spec: object, z: np.ndarray) -> Callable[[], object]:
    """One tracker frame of predictor work: predict, then update every track."""
    predictor.reset(spec, rng=np.random.default_rng(0))  # type: ignore[arg-type]
    state = predictor.start(z[0])
    state, _ = predictor.predict(state)
    state = predictor.update(state, z[1], np.ones(len(z[1]), dtype=bool))
    seen = np.ones(len(z[2]), dtype=bool)

    def run() -> object:
        s, _ = predictor.predict(state)
        return predictor.update(s, z[2], seen)

    return run


#: Nozzle-bar settings of the whole loop: ``(label, env kwargs, gnn kwargs)``.
SORTING_SETTINGS = (
    ("nozzle bar, sorting predicted (default)", {}, {}),
    ("nozzle bar, predict_sorting=False", {}, {"predict_sorting": False}),
    ("no nozzle bar (nozzle_offset=None)", {"nozzle_offset": None}, {}),
)


def whole_loop(
    predictor: str,
    frames: int,
    merge: bool = True,
    repeat: int = 3,
    env_kwargs: dict | None = None,
    agent_kwargs: dict | None = None,
) -> float:
    """Frames per second of BeltSorter-v0 (≈150 in view) + gnn(predictor) + TrackingMetrics,
    the best of ``repeat`` runs of ``frames`` frames (each after 60 frames that fill the window)."""
    best = 0.0
    for _ in range(repeat):
        physics = BeltParams(feed_rate=470.0, feed_burstiness=0.0)
        env = TrackingMetrics(
            gym.make("BeltSorter-v0", physics=physics, merge_touching=merge, **(env_kwargs or {}))
        )
        agent = make_agent("gnn", predictor=predictor, **(agent_kwargs or {}))
        obs, _ = env.reset(seed=0)
        agent.reset(env.get_wrapper_attr("sensor_spec"), seed=0)
        for _ in range(60):  # fill the window
            obs, *_ = env.step(agent.act(obs))
        t0 = time.perf_counter()
        for _ in range(frames):
            obs, *_ = env.step(agent.act(obs))
        best = max(best, frames / (time.perf_counter() - t0))
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tracks", type=int, default=150)
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--parts", default="123", help="which parts to run, e.g. 3 for the whole loop")
    args = parser.parse_args()
    torch.set_num_threads(1)
    n = args.tracks
    spec, z = tracks_in_view(n)

    if "1" in args.parts:
        frame_part(n, spec, z)
    if "2" in args.parts:
        mc_part(n, spec, z)
    if "3" in args.parts:
        loop_part(args.frames)


def frame_part(n: int, spec: object, z: np.ndarray) -> None:
    """Part 1: predict + update of the lstm and nll-lstm against plain torch cells."""
    print(f"1. predict + update, {n} tracks (µs per frame)")
    ref = best_time(torch_reference(n), number=200)
    print(f"   torch eager LSTMCell reference  {1e6 * ref:8.1f}")
    for name in ("lstm", "nll-lstm"):
        t = best_time(frame(make_predictor(name), spec, z), number=200)
        print(f"   {name:<31} {1e6 * t:8.1f}   {ref / t:.2f}x the reference")


def mc_part(n: int, spec: object, z: np.ndarray) -> None:
    """Part 2: mc-lstm, grouped against plain numpy and batched torch."""
    print(f"2. mc-lstm, T = 250, {n} tracks (ms per frame)")
    grouped = best_time(frame(make_predictor("mc-lstm"), spec, z), repeat=5, number=5)
    plain_p = LSTMPredictor("mc-lstm", make_predictor("mc-lstm").model, mc_inference="plain")
    plain = best_time(frame(plain_p, spec, z), repeat=3, number=2)
    batched = best_time(torch_reference(n, 250), repeat=3, number=2)
    dropout = make_predictor("mc-lstm").dropout
    print(f"   dropout rate {dropout:g}")
    print(f"   grouped (each distinct sample once)   {1e3 * grouped:7.2f}")
    print(f"   plain numpy, all T passes    {1e3 * plain:7.2f}   grouped: {plain / grouped:.1f}x faster")
    print(f"   batched torch, {n * 250} rows  {1e3 * batched:7.2f}   grouped: {batched / grouped:.1f}x")


def loop_part(frames: int) -> None:
    """Part 3: the whole loop, merged blobs on and off, against the same loop with kf-ca."""
    print(f"3. whole loop, BeltSorter-v0 (≈150 in view) + gnn + TrackingMetrics, {frames} frames")
    for label, env_kwargs, agent_kwargs in SORTING_SETTINGS:
        for merge in (True, False):
            print(f"   {label}; touching particles merged into blobs: {merge}")
            ref_fps = whole_loop("kf-ca", frames, merge, env_kwargs=env_kwargs, agent_kwargs=agent_kwargs)
            print(f"   kf-ca     {ref_fps:8.0f} frames/s")
            for name in ("nll-lstm", "lstm"):
                fps = whole_loop(name, frames, merge, env_kwargs=env_kwargs, agent_kwargs=agent_kwargs)
                print(f"   {name:<9} {fps:8.0f} frames/s   {fps / ref_fps:.2f}x kf-ca")


if __name__ == "__main__":
    main()
