"""Benchmark: frames per second of the SMC pose tracker (pose-smc) against the straightforward one.

The scene: KeypointWalkers-v0 with ``--people`` people in view from the first frame, no arrivals,
no vanishing, the recorded observations of one episode (so every tracker sees the same frames).
Each tracker runs the frames ``--warmup`` … ``--warmup + --frames`` (after tracking the warm-up
frames, so the filters are set up) on ``--threads`` threads (``torch.set_num_threads``, which also
sizes the predictor's compiled products). Variants, timed in the same run:

* **reference** — the straightforward implementation of the stateless predictor: torch's
  ``nn.LSTM(3, 64)`` of the network re-run over every particle's L-window for all
  ``filters × P × 17`` keypoint sequences, then the network's FC head (torch), every frame. The
  random draws (dropout masks, Gaussian noise, resampling, selection) are the tracker's own, so
  its tracks equal the others' to float32 rounding.
* **every window** (``share_windows=False``): the same work through the predictor's own float32
  cell (products summed in a fixed order): the exactness reference of the default.
* **default** (``share_windows=True``): the LSTM once per distinct input prefix of the filters'
  distinct queues
  ([`predictors.pose_lstm.prefix_tree.PrefixTree`][predictors.pose_lstm.prefix_tree.PrefixTree]) and the FC
  block's first layer once per distinct queue; dropout and the draw per particle. Bit for bit the reports of
  *every window* (checked here on the timed frames).
* **carried** (``recurrence="carried"``): one LSTM step per particle and keypoint per frame; its
  semantics differ (see [`predictors.pose_lstm.motion`][predictors.pose_lstm.motion]).

The frame time is the **median** of the timed frames (``--warmup 5 --frames 20``: frames 5–24
after ``reset(seed=0)``). Two references are timed in the same run, and the default's ratio to each
is printed:

* the **LSTM-and-head reference** — torch's ``nn.LSTM(3, 64)`` over ``filters × P × 17`` windows of
  L poses (about 51,000 at 10 people) plus the network's FC head with a torch dropout mask, and
  nothing else (no windows built, no OKS, no resampling): the network's arithmetic done the
  straightforward way, the yardstick of the 30 frames/s goal (7.5x this reference);
* the **whole-frame reference** (the first variant above): a complete tracker frame whose
  predictor is the torch one.

Then the default's time per stage (window features, the prefix tree, the LSTM steps, the FC head,
the draw, OKS, the rest of the loop), with the LSTM's arithmetic rate against the machine's float32
GEMM rate (``torch.matmul`` of two 1024 × 1024 matrices) measured in the same run.

``--scale`` instead times the default alone at several people counts and particle counts, with
the LSTM node steps per frame (the distinct work) next to ``filters × P × 17 × L``.

Usage::

    python benchmarks/bench_pose_smc.py [--people 10] [--particles 300] [--window 10] [--frames 20]
    python benchmarks/bench_pose_smc.py --scale [--threads 2]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import gymnasium as gym
import numpy as np
import torch

import track_envs  # noqa: F401
from agents.pose.smc import PoseSmcAgent
from predictors.pose_lstm import motion as motion_module
from predictors.pose_lstm import prefix_tree
from predictors.pose_lstm.motion import DEFAULT_MODEL
from predictors.pose_lstm.predictor import PosePredictor, dropout_masks
from track_envs.contracts.report import empty_report

#: Multiply-adds of one LSTM step of one sequence: 4 gates × 64 units × (3 inputs + 64 + bias).
MACS_PER_STEP = 4 * 64 * (3 + 64 + 1)


class TorchReferencePredictor(PosePredictor):
    """The pose predictor computed the straightforward way: ``nn.LSTM`` and the network's head."""

    def encode(self, inputs: np.ndarray) -> np.ndarray:
        with torch.inference_mode():
            return self.net.lstm(torch.from_numpy(np.ascontiguousarray(inputs)))[1][0][0].numpy()

    def head_of(
        self, h: np.ndarray, rng: Any, epistemic: bool = True, rows: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        h = h if rows is None else h[rows]
        masks = None
        if epistemic and self.dropout > 0:
            masks = torch.from_numpy(dropout_masks(rng, len(h), self.fc_units, self.dropout))
        with torch.inference_mode():
            mu, log_sigma = self.net.head(torch.from_numpy(h), masks)
        return mu.numpy().astype(np.float64), np.exp(log_sigma.numpy().astype(np.float64))


def record(people: int, frames: int, seed: int) -> tuple[list[dict], Any]:
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


def run(agent: PoseSmcAgent, stream: list[dict], spec: Any, warmup: int) -> dict[str, Any]:
    """Seconds per timed frame, mean filters and distinct queues, the timed frames' reports."""
    agent.reset(spec, seed=0)
    for obs in stream[:warmup]:
        agent.act(obs)
    filters, distinct, reports, times = [], [], [], []
    for obs in stream[warmup:]:
        m: Any = agent.motion
        distinct.append(int(np.sum(m.rep == np.arange(m.P))))
        t0 = time.perf_counter()
        report = agent.act(obs)
        times.append(time.perf_counter() - t0)
        reports.append({k: np.array(v) for k, v in report.items()})
        filters.append(len(agent.ids))
    return {
        "dt": float(np.median(times)),
        "mean_dt": float(np.mean(times)),
        "filters": float(np.mean(filters)),
        "distinct": float(np.mean(distinct)),
        "reports": reports,
    }


def lstm_head_reference(filters: float, particles: int, window: int, repeats: int = 5) -> float:
    """Median seconds of the LSTM-and-head reference: ``nn.LSTM(3, 64)`` of the shipped network over
    ``round(filters) × particles × 17`` random windows of ``window`` poses, then its FC head with a
    dropout mask drawn by torch — the network's work of one frame and nothing else."""
    net = PosePredictor(DEFAULT_MODEL).net
    n = round(filters) * particles * 17
    gen = torch.Generator().manual_seed(0)
    x = torch.randn(n, window, 3, generator=gen)  # batch first, as the network takes it
    keep = 1.0 - float(net.dropout)
    times = []
    with torch.inference_mode():
        for _ in range(repeats + 1):  # the first call warms torch up
            t0 = time.perf_counter()
            h = net.lstm(x)[1][0][0]
            masks = torch.bernoulli(torch.full((n, net.fc_units), keep), generator=gen) / keep
            net.head(h, masks)
            times.append(time.perf_counter() - t0)
    return float(np.median(times[1:]))


def same_reports(a: list[dict], b: list[dict]) -> tuple[bool, float]:
    """(ids equal in every frame, largest position difference in px)."""
    ids = all(np.array_equal(x["ids"], y["ids"]) for x, y in zip(a, b, strict=True))
    diff = max(
        float(np.nanmax(np.abs(x["positions"] - y["positions"]), initial=0.0))
        for x, y in zip(a, b, strict=True)
    )
    return ids, diff


class StageClock:
    """Wall time per stage of the default variant, by wrapping the functions each stage calls."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = defaultdict(float)
        self.nodes = 0

    @contextmanager
    def wrapped(self, agent: PoseSmcAgent) -> Iterator[None]:
        motion: Any = agent.motion
        predictor = motion.predictor
        patches: list[tuple[Any, str, Any]] = []

        def patch(owner: Any, name: str, label: str) -> None:
            original = getattr(owner, name)

            def timed(*args: Any, **kwargs: Any) -> Any:
                t0 = time.perf_counter()
                try:
                    return original(*args, **kwargs)
                finally:
                    self.seconds[label] += time.perf_counter() - t0

            patches.append((owner, name, original))
            setattr(owner, name, timed)

        tree_of = prefix_tree.PrefixTree.of

        def counted_tree(x: np.ndarray) -> prefix_tree.PrefixTree:
            t0 = time.perf_counter()
            tree = tree_of(x)
            self.seconds["prefix tree (lexsort)"] += time.perf_counter() - t0
            self.nodes += tree.nodes
            return tree

        patches.append((prefix_tree.PrefixTree, "of", prefix_tree.PrefixTree.__dict__["of"]))
        prefix_tree.PrefixTree.of = staticmethod(counted_tree)  # type: ignore[method-assign]
        patch(motion_module, "window_features", "window features (queues → steps)")
        patch(prefix_tree.PrefixTree, "encode_nodes", "LSTM node steps")
        patch(predictor, "head_of", "FC head (dropout masks drawn)")
        patch(predictor, "draw", "Gaussian draw")
        patch(motion, "score", "OKS + elites")
        patch(motion, "update", "push, resample, select")
        try:
            yield
        finally:
            for owner, name, original in reversed(patches):
                setattr(owner, name, original)


def gemm_rate(repeats: int = 5) -> float:
    """GFLOP/s of ``torch.matmul`` on two float32 1024 × 1024 matrices (median of ``repeats``)."""
    a = torch.rand(1024, 1024)
    torch.matmul(a, a)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        torch.matmul(a, a)
        times.append(time.perf_counter() - t0)
    return 2 * 1024**3 / float(np.median(times)) / 1e9


def load_note() -> str:
    one, five, _ = os.getloadavg()
    return f"load average {one:.2f} (1 min), {five:.2f} (5 min) on {os.cpu_count()} CPUs"


def compare(args: argparse.Namespace) -> None:
    stream, spec = record(args.people, args.warmup + args.frames, args.seed)
    kw = {"particles": args.particles, "window": args.window}
    reference = PoseSmcAgent(share_windows=False, **kw)
    reference.motion.predictor = TorchReferencePredictor(DEFAULT_MODEL)  # type: ignore[attr-defined]
    variants: dict[str, PoseSmcAgent] = {
        "reference: nn.LSTM over every particle's window + FC head": reference,
        "every window, the predictor's cell (share_windows=False)": PoseSmcAgent(share_windows=False, **kw),
        "default: prefix tree over distinct queues": PoseSmcAgent(**kw),
        "carried state (other semantics)": PoseSmcAgent(recurrence="carried", **kw),
    }
    print(f"people {args.people}, P = {args.particles}, L = {args.window}, threads {args.threads}")
    print(load_note())
    gflops = gemm_rate()
    results = {label: run(agent, stream, spec, args.warmup) for label, agent in variants.items()}
    labels = list(results)
    ref_dt = results[labels[0]]["dt"]
    default = results[labels[2]]
    lstm_ref = lstm_head_reference(default["filters"], args.particles, args.window)
    print("| variant | filters | LSTM sequences / frame | steps | GMAC / frame", end="")
    print(" | ms / frame | frames / s | speed-up |")
    print("|---|---|---|---|---|---|---|---|")
    for label, r in results.items():
        seq = r["filters"] * args.particles * 17
        steps = 1 if label.startswith("carried") else args.window
        gmac = (seq + (r["filters"] * 17 if steps == 1 else 0)) * steps * MACS_PER_STEP / 1e9
        cells = f"{r['filters']:.1f} | {seq:.0f} | {steps} | {gmac:.2f}"
        cells += f" | {r['dt'] * 1e3:.1f} | {1 / r['dt']:.1f} | {ref_dt / r['dt']:.1f}x"
        print(f"| {label} | {cells} |")
    print(
        f"\ndefault: {default['dt'] * 1e3:.1f} ms per frame (median of {args.frames} frames), "
        f"{1 / default['dt']:.1f} frames/s; {lstm_ref / default['dt']:.2f}x the LSTM-and-head reference "
        f"({lstm_ref * 1e3:.0f} ms: nn.LSTM over {round(default['filters']) * args.particles * 17:,} "
        f"windows + FC head), {ref_dt / default['dt']:.1f}x the whole-frame reference ({ref_dt * 1e3:.0f} ms)"
    )
    ids, diff = same_reports(results[labels[1]]["reports"], results[labels[2]]["reports"])
    print(f"\ndefault vs every window: ids equal {ids}, largest position difference {diff:.3g} px")
    ids, diff = same_reports(results[labels[0]]["reports"], results[labels[2]]["reports"])
    print(f"default vs nn.LSTM reference: ids equal {ids}, largest position difference {diff:.3g} px")
    stages(args, stream, spec, gflops)


def stages(args: argparse.Namespace, stream: list[dict], spec: Any, gflops: float) -> None:
    agent = PoseSmcAgent(particles=args.particles, window=args.window)
    clock = StageClock()
    agent.reset(spec, seed=0)
    for obs in stream[: args.warmup]:
        agent.act(obs)
    total = 0.0
    with clock.wrapped(agent):
        for obs in stream[args.warmup :]:
            t0 = time.perf_counter()
            agent.act(obs)
            total += time.perf_counter() - t0
    frames = len(stream) - args.warmup
    ms: dict[str, float] = {k: v / frames * 1e3 for k, v in clock.seconds.items()}
    rows = list(ms.items())
    rest = total / frames * 1e3 - sum(ms.values())
    rows.append(("rest of the frame (matching, births, queue bookkeeping)", rest))
    nodes = clock.nodes / frames
    lstm_ms = ms.get("LSTM node steps", float("nan"))
    rate = 2 * nodes * MACS_PER_STEP / (lstm_ms / 1e3) / 1e9
    print(f"\nwhere the default's {total / frames * 1e3:.1f} ms per frame go ({frames} frames):")
    print("| stage | ms / frame | share |")
    print("|---|---|---|")
    for label, v in rows:
        print(f"| {label} | {v:.1f} | {v / (total / frames * 1e3):.0%} |")
    print(
        f"\nLSTM: {nodes:.0f} node steps per frame, {2 * nodes * MACS_PER_STEP / 1e9:.2f} GFLOP in "
        f"{lstm_ms:.1f} ms = {rate:.1f} GFLOP/s; torch.matmul 1024² float32 in the same run: "
        f"{gflops:.1f} GFLOP/s ({rate / gflops:.0%} of it)"
    )


def scale(args: argparse.Namespace) -> None:
    grid = [(p, args.particles) for p in (5, 10, 20, 50)] + [(args.people, P) for P in (100, 300, 1000)]
    print(f"L = {args.window}, threads {args.threads}; {load_note()}")
    print("| people | P | filters | particle sequences × L / frame | LSTM node steps / frame", end="")
    print(" | ms / frame | frames / s |")
    print("|---|---|---|---|---|---|---|")
    for people, P in dict.fromkeys(grid):
        stream, spec = record(people, args.warmup + args.frames, args.seed)
        agent = PoseSmcAgent(particles=P, window=args.window)
        clock = StageClock()
        agent.reset(spec, seed=0)
        for obs in stream[: args.warmup]:
            agent.act(obs)
        total, filters = 0.0, []
        with clock.wrapped(agent):
            for obs in stream[args.warmup :]:
                t0 = time.perf_counter()
                agent.act(obs)
                total += time.perf_counter() - t0
                filters.append(len(agent.ids))
        f = float(np.mean(filters))
        dt = total / args.frames
        naive = f * P * 17 * args.window
        nodes = clock.nodes / args.frames
        print(f"| {people} | {P} | {f:.1f} | {naive:,.0f} | {nodes:,.0f} | {dt * 1e3:.1f} | {1 / dt:.1f} |")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--people", type=int, default=10)
    parser.add_argument("--particles", type=int, default=300)
    parser.add_argument("--window", type=int, default=10)
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--warmup", type=int, default=5)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--scale", action="store_true", help="the scale table instead of the comparison")
    args = parser.parse_args(argv)
    torch.set_num_threads(args.threads)
    run_mode: Callable[[argparse.Namespace], None] = scale if args.scale else compare
    run_mode(args)


if __name__ == "__main__":
    main()
