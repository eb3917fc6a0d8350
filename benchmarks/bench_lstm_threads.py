"""The belt LSTM step (nll-lstm predict + update, 150 tracks) at the default BLAS threads and at one,
idle and with a busy neighbour process, against torch's eager ``LSTMCell`` pair at one thread.

    python benchmarks/bench_lstm_threads.py [--tracks 150] [--batches 3]

Every variant runs in its own process, in interleaved batches (the order rotates from batch to
batch); the best of each variant over the batches is kept. In each process the step is timed
idle, then with a **busy neighbour**: a process spinning on the last CPU of the machine for the
duration of the timing (the timing process itself is not pinned, so the BLAS threads may land on
that CPU, as they would beside a camera driver or a valve controller). Variants:

* ``default``: the library as installed, BLAS at its default thread count (the step limits its
  products to one thread,
  [`track_envs.infra.blas_threads.frame_blas`][track_envs.infra.blas_threads.frame_blas]);
* ``unpinned``: the same process setup with that limit switched off
  (``set_frame_threads(None)``), i.e. BLAS splitting the small products over all its threads;
* ``one thread``: ``OPENBLAS_NUM_THREADS=1`` (and ``OMP_NUM_THREADS``, ``MKL_NUM_THREADS``) set
  before numpy loads;
* ``torch``: the same network as torch eager ``nn.LSTMCell`` layers (4 → 64 → 32) and a linear
  head, one step of the 150 rows under ``no_grad``, ``torch.set_num_threads(1)``
  (`bench_lstm.torch_reference`).

Each timing is the best of 7 repetitions of as many calls as fill ≈20 ms, and each process times
idle and busy three times, alternating (best kept). Wall clock, and idle also on the thread's CPU
clock (``time.thread_time``: the work itself; on a shared machine a descheduled process is not
charged, so the ratio of two single-threaded steps is steadier than on the wall clock). Printed:
µs per step, the ratios ``one thread / default`` idle and busy (≥ 1: the default is no slower),
``torch / default`` (the step's speed-up over torch), and the BLAS libraries that ran
(``threadpoolctl.threadpool_info()``: library, version, the kernel ``architecture``, threads).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
MODES = ("default", "unpinned", "one thread", "torch")
_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
_SPIN = "import os, sys\nos.sched_setaffinity(0, {int(sys.argv[1])})\nwhile True:\n    pass\n"


def best_time(
    fn: Callable[[], object],
    repeat: int = 7,
    fill: float = 0.02,
    clock: Callable[[], float] = time.perf_counter,
) -> float:
    """Best mean seconds per call on ``clock`` over ``repeat`` runs of as many calls as fill ``fill`` s."""
    fn()
    t0 = time.perf_counter()
    fn()
    number = max(3, min(500, int(fill / max(time.perf_counter() - t0, 1e-7))))
    best = float("inf")
    for _ in range(repeat):
        t0 = clock()
        for _ in range(number):
            fn()
        best = min(best, (clock() - t0) / number)
    return best


class BusyNeighbour:
    """A process spinning on the machine's last CPU while the ``with`` block runs."""

    def __enter__(self) -> BusyNeighbour:
        core = max(os.sched_getaffinity(0))
        self.proc = subprocess.Popen([sys.executable, "-c", _SPIN, str(core)])
        time.sleep(0.3)  # let it start spinning
        return self

    def __exit__(self, *exc: object) -> None:
        self.proc.kill()
        self.proc.wait()


def _step(mode: str, tracks: int) -> Callable[[], object]:
    """The timed call of ``mode`` (in a worker process)."""
    sys.path.insert(0, str(ROOT))
    sys.path.insert(0, str(ROOT / "benchmarks"))
    if mode == "torch":
        import torch
        from bench_lstm import torch_reference

        torch.set_num_threads(1)
        return torch_reference(tracks)
    import gymnasium as gym
    import numpy as np

    import track_envs  # noqa: F401
    from predictors import make_predictor
    from track_envs.infra.blas_threads import set_frame_threads

    if mode == "unpinned":
        set_frame_threads(None)
    spec = gym.make("BeltSorter-v0").unwrapped.sensor_spec  # type: ignore[attr-defined]
    rng = np.random.default_rng(0)
    low, size = np.asarray(spec.region_low), np.asarray(spec.region_size)
    start = low + rng.random((tracks, 2)) * size * [0.8, 1.0]
    z = np.stack([start + np.array([0.011 * k, 0.0]) for k in range(3)])
    predictor = make_predictor("nll-lstm")
    predictor.reset(spec, rng=np.random.default_rng(0))
    state = predictor.start(z[0])
    state, _ = predictor.predict(state)
    state = predictor.update(state, z[1], np.ones(tracks, dtype=bool))
    seen = np.ones(tracks, dtype=bool)

    def run() -> object:
        s, _ = predictor.predict(state)
        return predictor.update(s, z[2], seen)

    return run


def worker(mode: str, tracks: int, rounds: int = 3) -> dict[str, Any]:
    """Time ``mode`` idle and beside a busy neighbour, ``rounds`` times each, alternating (best µs
    per step, wall clock), and idle on this thread's CPU clock (``cpu``: the work itself, what a
    descheduled process does not count), in this process."""
    fn = _step(mode, tracks)
    idle = busy = cpu = float("inf")
    for _ in range(rounds):
        idle = min(idle, best_time(fn))
        cpu = min(cpu, best_time(fn, clock=time.thread_time))
        with BusyNeighbour():
            busy = min(busy, best_time(fn))
    from threadpoolctl import threadpool_info

    blas = [
        f"{i['internal_api']} {i['version']} {i.get('architecture', '?')} ({i['num_threads']} threads, "
        f"{Path(i['filepath']).name})"
        for i in threadpool_info()
        if i["user_api"] == "blas"
    ]
    return {"mode": mode, "idle": 1e6 * idle, "busy": 1e6 * busy, "cpu": 1e6 * cpu, "blas": blas}


def run_worker(mode: str, tracks: int, timeout: float = 300.0) -> dict[str, Any]:
    """`worker` in a new process with ``mode``'s environment."""
    env = {k: v for k, v in os.environ.items() if k not in _THREAD_VARS}
    if mode == "one thread":
        env.update(dict.fromkeys(_THREAD_VARS, "1"))
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    out = subprocess.run(
        [sys.executable, __file__, "--worker", mode, "--tracks", str(tracks)],
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def measure(batches: int = 3, tracks: int = 150, modes: tuple[str, ...] = MODES) -> dict[str, Any]:
    """Best µs per step of every mode, idle and busy, over ``batches`` interleaved batches of
    processes; the ratios; the BLAS libraries of the default process."""
    conds = ("idle", "busy", "cpu")
    best: dict[str, dict[str, float]] = {m: dict.fromkeys(conds, float("inf")) for m in modes}
    blas: list[str] = []
    for b in range(batches):
        order = modes[b % len(modes) :] + modes[: b % len(modes)]
        for mode in order:
            r = run_worker(mode, tracks)
            for cond in conds:
                best[mode][cond] = min(best[mode][cond], r[cond])
            if mode == "default":
                blas = r["blas"]
    ratios: dict[str, float] = {}
    if "default" in best:
        d = best["default"]
        if "one thread" in best:
            ratios["one thread / default, idle"] = best["one thread"]["idle"] / d["idle"]
            ratios["one thread / default, busy"] = best["one thread"]["busy"] / d["busy"]
        if "torch" in best:
            ratios["torch / default, idle"] = best["torch"]["idle"] / d["idle"]
            ratios["torch / default, busy"] = best["torch"]["busy"] / d["busy"]
            ratios["torch / default, idle, CPU time"] = best["torch"]["cpu"] / d["cpu"]
        if "unpinned" in best:
            ratios["unpinned / default, busy"] = best["unpinned"]["busy"] / d["busy"]
    return {"best": best, "ratios": ratios, "blas": blas, "batches": batches, "tracks": tracks}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tracks", type=int, default=150)
    parser.add_argument("--batches", type=int, default=3)
    parser.add_argument("--worker", choices=MODES, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        print(json.dumps(worker(args.worker, args.tracks)))
        return
    one, five, _ = os.getloadavg()
    print(f"load average {one:.2f} (1 min), {five:.2f} (5 min) on {os.cpu_count()} CPUs")
    r = measure(args.batches, args.tracks)
    print(f"nll-lstm predict + update, {args.tracks} tracks, best of {args.batches} batches (µs per step)")
    print("| variant | idle | busy neighbour | idle, CPU time |")
    print("|---|---|---|---|")
    for mode, t in r["best"].items():
        cpu = f"{t['cpu']:.0f}" if mode != "unpinned" else "(other threads not counted)"
        print(f"| {mode} | {t['idle']:.0f} | {t['busy']:.0f} | {cpu} |")
    print()
    for label, value in r["ratios"].items():
        print(f"{label}: {value:.2f}x")
    print("BLAS (default process): " + "; ".join(r["blas"]))


if __name__ == "__main__":
    main()
