"""Performance floors: the same-run ratios behind the headline figures, each against a floor kept in
``benchmarks/floors.toml``.

    python benchmarks/bench_check.py [--only NAME ...] [--runs 1]      (make bench-check)

Each check is a short version of a benchmark of this folder and reports one ratio, "higher is
better", of two things timed in the same process (or the same run of processes), so the load of
the machine cancels out to first order:

* ``tracker_vs_filterpy`` (``bench_tracker.py``): gnn + kf-cv frames/s over ``FilterpyGnn``, a
  per-object loop over ``filterpy.kalman.KalmanFilter`` written in this repository (vectorised
  Mahalanobis cost, ``scipy`` assignment; not a filterpy tracker), 150 tracks × 150 detections,
  60 timed frames, best of 3.
* ``belt_lstm_vs_torch`` (``bench_lstm_threads.py``): torch's eager ``LSTMCell`` pair at one
  thread over the nll-lstm step (predict + update, 150 tracks) at the default BLAS threads, best
  of 2 interleaved batches of processes, on the thread CPU clock (both are single-threaded; the
  wall-clock ratio is printed beside it).
* ``belt_lstm_busy_default_vs_one_thread`` (the same processes): the step at one BLAS thread over
  the step at the default threads, both beside a busy neighbour process (≈1: the default does
  not fall off a cliff when another process is busy).
* ``pose_smc_vs_lstm_reference`` (``bench_pose_smc.py``): the LSTM-and-head reference
  (``lstm_head_reference``: torch's ``nn.LSTM(3, 64)`` over every particle's window and the FC
  head, nothing else; median of 3) over the default pose-smc's median frame, KeypointWalkers-v0,
  10 people, P = 300, L = 10, 2 threads, frames 5-9 after reset (the benchmark: 5-24).
* ``pose_smc_vs_whole_frame`` (the same run): the whole-frame reference (a complete tracker frame
  whose predictor is the torch one, ``TorchReferencePredictor``) over the default.
* ``jpda_vs_gnn`` (``bench_jpda.py``): gnn + kf-cv's median frame time over jpda + kf-cv's, the
  synthetic 150 × 150 stream, 60 timed frames, best of 2 (jpda costs more: this is < 1).
* ``hota_vs_trackeval`` (``bench_hota.py``): TrackEval's ``HOTA.eval_sequence`` time over
  ``HotaAccumulator``'s on the synthetic 1,000-frame point scene, best of 3.
* ``env_vs_naive_pymunk`` (``bench_belt_sorter.py``): BeltSorter-v0 frames/s (≈150 in view, no
  merging) over the naive pymunk belt's, 300 frames, best of 3.

Every check runs in its own process (``--only NAME --json``). The table lists the ratio, the floor
and whether it held; the command exits 1 if any ratio fell below its floor or a check failed.
``--runs N`` runs every check N times and reports the median (what the floors' ``measured``
values are). Not part of ``make test``: timings are noisy on shared machines; the floors are set
well below the measured ratios (the lower of 0.6x their median and 0.75x the lowest run; the file
says so per check) so that a failure means a regression, not noise. One run takes 1-6 minutes on
two cores (1 at a load average of 2, 6 at 6-7).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
FLOORS = HERE / "floors.toml"


def _paths() -> None:
    for p in (str(ROOT), str(HERE)):
        if p not in sys.path:
            sys.path.insert(0, p)


def check_tracker_vs_filterpy() -> dict[str, Any]:
    _paths()
    from bench_tracker import FilterpyGnn, make_gnn, synthetic_observations, time_tracker

    observations = synthetic_observations(80, seed=0)
    ref_fps, _ = time_tracker(FilterpyGnn, observations, 20)
    fps, _ = time_tracker(make_gnn("kf-cv"), observations, 20)
    detail = f"gnn kf-cv {fps:.0f} fps, per-object filterpy loop {ref_fps:.0f} fps"
    return {"ratio": fps / ref_fps, "detail": detail}


def _lstm_threads() -> dict[str, Any]:
    _paths()
    from bench_lstm_threads import measure

    return measure(batches=2, modes=("default", "one thread", "torch"))


def check_belt_lstm() -> dict[str, Any]:
    """Both belt LSTM checks from one set of processes (see `main`)."""
    r = _lstm_threads()
    b = r["best"]
    return {
        "belt_lstm_vs_torch": {
            "ratio": r["ratios"]["torch / default, idle, CPU time"],
            "detail": f"CPU time: step {b['default']['cpu']:.0f} µs, torch {b['torch']['cpu']:.0f} µs "
            f"(wall {r['ratios']['torch / default, idle']:.2f}x)",
        },
        "belt_lstm_busy_default_vs_one_thread": {
            "ratio": r["ratios"]["one thread / default, busy"],
            "detail": f"busy: default {b['default']['busy']:.0f} µs, "
            f"one thread {b['one thread']['busy']:.0f} µs",
        },
    }


def check_pose_smc() -> dict[str, Any]:
    """Both pose-smc checks from one run: the default's median frame against the LSTM-and-head
    reference (``bench_pose_smc.lstm_head_reference``) and the whole-frame reference."""
    _paths()
    import bench_pose_smc
    import torch
    from bench_pose_smc import TorchReferencePredictor, record, run

    from agents.pose.smc import PoseSmcAgent
    from predictors.pose_lstm.motion import DEFAULT_MODEL

    torch.set_num_threads(2)
    warmup, frames, particles, window = 5, 5, 300, 10
    stream, spec = record(10, warmup + frames, 0)
    kw = {"particles": particles, "window": window}
    reference = PoseSmcAgent(share_windows=False, **kw)
    reference.motion.predictor = TorchReferencePredictor(DEFAULT_MODEL)  # type: ignore[attr-defined]
    ref_dt = run(reference, stream, spec, warmup)["dt"]
    default = run(PoseSmcAgent(**kw), stream, spec, warmup)
    dt = default["dt"]
    out: dict[str, Any] = {
        "pose_smc_vs_whole_frame": {
            "ratio": ref_dt / dt,
            "detail": f"default {1e3 * dt:.0f} ms/frame, whole-frame reference {1e3 * ref_dt:.0f}",
        }
    }
    lstm_head_reference = getattr(bench_pose_smc, "lstm_head_reference", None)
    if lstm_head_reference is None:
        out["pose_smc_vs_lstm_reference"] = {"error": "bench_pose_smc.lstm_head_reference is missing"}
    else:
        lstm_dt = lstm_head_reference(default["filters"], particles, window, repeats=3)
        out["pose_smc_vs_lstm_reference"] = {
            "ratio": lstm_dt / dt,
            "detail": f"default {1e3 * dt:.0f} ms/frame, LSTM-and-head reference {1e3 * lstm_dt:.0f}",
        }
    return out


def check_jpda_vs_gnn() -> dict[str, Any]:
    _paths()
    import numpy as np
    from bench_jpda import make, run_timed
    from bench_tracker import SPEC, synthetic_observations

    warm = 20
    observations = synthetic_observations(warm + 60, seed=0)
    trackers = {"gnn": ("gnn", {"predictor": "kf-cv"}), "jpda": ("jpda", {"predictor": "kf-cv"})}
    for name, kwargs in trackers.values():
        make(name, kwargs, SPEC).warm_up()
    best = {label: float("inf") for label in trackers}
    for _ in range(2):
        for label, (name, kwargs) in trackers.items():
            times, _, _ = run_timed(make(name, kwargs, SPEC), observations, warm)
            best[label] = min(best[label], float(np.median(times)))
    return {
        "ratio": best["gnn"] / best["jpda"],
        "detail": f"median frame: gnn {1e6 * best['gnn']:.0f} µs, jpda {1e6 * best['jpda']:.0f} µs",
    }


def check_hota_vs_trackeval() -> dict[str, Any]:
    _paths()
    import numpy as np
    from bench_hota import best_of, ours, synthetic_frames, trackeval_data
    from trackeval.metrics import HOTA

    frames = synthetic_frames(np.random.default_rng(0), 1000, 40)
    data = trackeval_data(frames)
    metric = HOTA({"PRINT_CONFIG": False})
    t_ours, _ = best_of(3, lambda: ours(frames))
    t_te, _ = best_of(3, lambda: metric.eval_sequence(data))
    return {"ratio": t_te / t_ours, "detail": f"ours {1e3 * t_ours:.1f} ms, TrackEval {1e3 * t_te:.1f} ms"}


def check_env_vs_naive_pymunk() -> dict[str, Any]:
    _paths()
    from bench_belt_sorter import LOADS, time_env, time_naive

    env_fps, _ = time_env(LOADS[150], 300, 0)
    naive_fps, _ = time_naive(LOADS[150], 300, 0)
    return {"ratio": env_fps / naive_fps, "detail": f"env {env_fps:.0f} fps, naive {naive_fps:.0f} fps"}


#: Check name → the function that measures it; one function may measure several checks (it then
#: returns ``{name: result}``).
CHECKS: dict[str, Callable[[], dict[str, Any]]] = {
    "tracker_vs_filterpy": check_tracker_vs_filterpy,
    "belt_lstm_vs_torch": check_belt_lstm,
    "belt_lstm_busy_default_vs_one_thread": check_belt_lstm,
    "pose_smc_vs_lstm_reference": check_pose_smc,
    "pose_smc_vs_whole_frame": check_pose_smc,
    "jpda_vs_gnn": check_jpda_vs_gnn,
    "hota_vs_trackeval": check_hota_vs_trackeval,
    "env_vs_naive_pymunk": check_env_vs_naive_pymunk,
}


def load_floors(path: Path = FLOORS) -> dict[str, dict[str, Any]]:
    """The floors file: ``{check: {"floor": float, "measured": [...], ...}}``.

    Raises:
        ValueError: a check of `CHECKS` without a floor, or a floor that is not a positive number.
    """
    floors = tomllib.loads(path.read_text())
    for name in CHECKS:
        floor = floors.get(name, {}).get("floor")
        if not (isinstance(floor, int | float) and floor > 0):
            raise ValueError(f"{path}: check {name!r} needs a positive 'floor', got {floor!r}")
    return floors


def run_in_process(func_name: str, timeout: float) -> dict[str, dict[str, Any]]:
    """The checks measured by ``func_name`` in a new process: ``{check: {"ratio", "detail"}}`` or
    ``{check: {"error": ...}}``."""
    names = [n for n, f in CHECKS.items() if f.__name__ == func_name]
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    env.setdefault("MPLBACKEND", "Agg")
    try:
        out = subprocess.run(
            [sys.executable, __file__, "--only", names[0], "--json"],
            env=env,
            capture_output=True,
            text=True,
            timeout=timeout,
        )
    except subprocess.TimeoutExpired:
        return {n: {"error": f"timed out after {timeout:.0f} s"} for n in names}
    if out.returncode != 0:
        tail = (out.stderr.strip().splitlines() or ["(no output)"])[-1]
        return {n: {"error": f"exit {out.returncode}: {tail}"} for n in names}
    result = json.loads(out.stdout.strip().splitlines()[-1])
    return {n: result[n] for n in names}


def measure_one(name: str) -> dict[str, dict[str, Any]]:
    """Run the function of check ``name`` here: ``{check: {"ratio", "detail"}}``."""
    func = CHECKS[name]
    r = func()
    if "ratio" in r or "error" in r:
        return {name: r}
    return r


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--only", nargs="+", choices=list(CHECKS), help="run only these checks")
    parser.add_argument("--runs", type=int, default=1, help="runs of every check; the median is compared")
    parser.add_argument("--timeout", type=float, default=300.0, help="seconds per check process")
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.json:  # worker: one check function in this process
        print(json.dumps(measure_one(args.only[0])))
        return 0
    floors = load_floors()
    names = args.only or list(CHECKS)
    funcs = list(dict.fromkeys(CHECKS[n].__name__ for n in names))
    one, five, _ = os.getloadavg()
    print(f"load average {one:.2f} (1 min), {five:.2f} (5 min) on {os.cpu_count()} CPUs")
    start = time.perf_counter()
    ratios: dict[str, list[float]] = {n: [] for n in names}
    details: dict[str, str] = {}
    for _ in range(args.runs):
        for func in funcs:
            for check, r in run_in_process(func, args.timeout).items():
                if check not in ratios:
                    continue
                if "error" in r:
                    details[check] = r["error"]
                else:
                    ratios[check].append(float(r["ratio"]))
                    details[check] = r["detail"]
    failed = []
    print("\n| check | ratio | floor | measured (floors.toml) | ok | last run |")
    print("|---|---|---|---|---|---|")
    for n in names:
        floor = float(floors[n]["floor"])
        measured = floors[n].get("measured", "")
        if ratios[n]:
            value = statistics.median(ratios[n])
            ok = value >= floor
            shown = f"{value:.3g}x" + (
                f" (runs {', '.join(f'{v:.3g}' for v in ratios[n])})" if args.runs > 1 else ""
            )
        else:
            ok, shown = False, "failed"
        if not ok:
            failed.append(n)
        print(
            f"| {n} | {shown} | {floor:g}x | {measured} | {'ok' if ok else 'BELOW'} | {details.get(n, '')} |"
        )
    print(
        f"\n{len(names) - len(failed)} of {len(names)} checks at or above their floors "
        f"({time.perf_counter() - start:.0f} s)"
    )
    if failed:
        print("below the floor or failed: " + ", ".join(failed))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
