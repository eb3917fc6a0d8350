"""Speed of detection-file reading and of ``track run``'s loop around an agent.

1. Reading a 50,000-frame file of 150,000 detections (a belt-like flow of about 3 particles in
   view, 0 to 8 per frame), in both layouts: :func:`read_mot_detections` and
   :func:`read_wide_detections`, against a plain-Python reader (the :mod:`csv` module, one list
   per frame) timed on the same files. Target: <= 2 s.
2. ``track run``'s overhead over the agent's own frame time: the same gnn (kf-ca) tracker over
   the same stream, (a) ``agent.act`` on observations packed before the clock starts (the
   agent's own time), (b) :func:`agents.files.points.run_agent` (packing, the loop, gathering the reports
   into tracks, a tqdm bar), (c) the whole ``track run`` command (read, track, write the MOT
   file), each timed in the same process on the process's CPU time (the machine is shared: wall
   time counts the waits for a core), seven interleaved repetitions; the ratio is the median of
   the per-repetition ratios. On the sparse stream above and
   on a dense one (150 particles in view, 2,000 frames). Target: (b) / (a) <= 1.10.

Run: ``python benchmarks/bench_track_run.py`` (add ``--quick`` for a smaller run).
"""

from __future__ import annotations

import argparse
import csv
import io
import sys
import tempfile
import time
from contextlib import redirect_stderr
from pathlib import Path

import numpy as np

from agents import make_agent
from agents.cli.run import main as track_run
from agents.files.points import packed_block, run_agent
from track_envs.io.detections import (
    read_mot_detections,
    read_wide_detections,
    write_mot_detections,
    write_wide_detections,
)
from track_envs.values.detections import Detections, detection_sensor_spec

#: Interleaved repetitions of each variant of the overhead measurement (the least CPU time counts).
REPEATS = 7


def belt_stream(n_frames: int, in_view: float, seed: int = 0, dt: float = 0.005) -> Detections:
    """Particles entering at random across a 0.18 m belt, moving at 1.2 m/s through a 0.4 m window,
    0.1 mm noise; about ``in_view`` in view per frame."""
    rng = np.random.default_rng(seed)
    speed, length, width = 1.2, 0.4, 0.18
    frames_in_view = length / (speed * dt)
    n = int(in_view * n_frames / frames_in_view) + 1
    birth = np.sort(rng.uniform(-frames_in_view, n_frames, n))
    lateral = rng.uniform(0.01, width - 0.01, n)
    frames = []
    for t in range(n_frames):
        alive = (birth <= t) & (birth > t - frames_in_view)
        x = (t - birth[alive]) * speed * dt
        z = np.stack([x, lateral[alive]], axis=1) + rng.normal(0, 1e-4, (int(alive.sum()), 2))
        frames.append(z)
    return Detections.from_frames(frames, times=np.arange(n_frames) * dt)


def best(fn, repeats: int = 3, clock=time.perf_counter) -> float:
    """Least time of ``repeats`` calls of ``fn`` on ``clock``."""
    times = []
    for _ in range(repeats):
        start = clock()
        fn()
        times.append(clock() - start)
    return min(times)


def python_reader(path: Path) -> list[list[tuple[float, float]]]:
    """The reference: csv module, one list of (x, y) per frame (MOT rows)."""
    frames: dict[int, list[tuple[float, float]]] = {}
    with open(path, newline="") as handle:
        for row in csv.reader(handle):
            f = int(row[0])
            frames.setdefault(f, []).append(
                (float(row[2]) + float(row[4]) / 2, float(row[3]) + float(row[5]) / 2)
            )
    last = max(frames)
    return [frames.get(f, []) for f in range(1, last + 1)]


def reading(tmp: Path, n_frames: int, n_detections: int) -> None:
    stream = belt_stream(n_frames, in_view=n_detections / n_frames * 1.0)
    write_mot_detections(tmp / "det.txt", stream)
    write_wide_detections(tmp / "det.csv", stream)
    mb = (tmp / "det.txt").stat().st_size / 1e6, (tmp / "det.csv").stat().st_size / 1e6
    mot = best(lambda: read_mot_detections(tmp / "det.txt"))
    wide = best(lambda: read_wide_detections(tmp / "det.csv", time_column="time"))
    ref = best(lambda: python_reader(tmp / "det.txt"), repeats=1)
    print(
        f"\n## reading {stream.n_frames} frames, {len(stream)} detections "
        f"(most in a frame: {stream.max_per_frame})"
    )
    print("| layout | file MB | read s | csv-module reference s | speed-up |")
    print("|---|---|---|---|---|")
    print(f"| MOT det.txt | {mb[0]:.1f} | {mot:.3f} | {ref:.3f} | {ref / mot:.1f}x |")
    print(f"| wide CSV | {mb[1]:.1f} | {wide:.3f} | - | - |")


def overhead(tmp: Path, stream: Detections, label: str) -> None:
    spec = detection_sensor_spec(stream, measurement_noise_std=1e-4)
    write_mot_detections(tmp / f"{label}.txt", stream)
    agent = make_agent("gnn", predictor="kf-ca")
    agent.warm_up()
    det, mask = packed_block(stream, 0, stream.n_frames, spec)
    observations = [{"detections": det[t], "mask": mask[t]} for t in range(stream.n_frames)]

    def own() -> None:
        agent.reset(spec, seed=0)
        for obs in observations:
            agent.act(obs)

    def loop() -> None:
        with redirect_stderr(io.StringIO()):
            run_agent(agent, stream, spec, seed=0, progress=True)

    def loop_with_cov() -> None:
        run_agent(agent, stream, spec, seed=0, covariance=True)

    def command() -> None:
        argv = [str(tmp / f"{label}.txt"), "--dt=0.005", "--declared-noise-std=1e-4"]
        argv.append(f"--out={tmp / 'out.txt'}")
        with redirect_stderr(io.StringIO()):
            assert track_run(argv) == 0

    results: dict[str, list[float]] = {"own": [], "loop": [], "cov": [], "command": []}
    variants = {"own": own, "loop": loop, "cov": loop_with_cov, "command": command}
    for _ in range(REPEATS):  # interleaved, so that a slow spell of the shared machine hits every variant
        for name, fn in variants.items():
            results[name].append(best(fn, 1, time.process_time))
    t = {k: min(v) for k, v in results.items()}
    # the ratio of each repetition (variant and reference timed back to back), median over repetitions
    ratio = {k: float(np.median(np.array(v) / np.array(results["own"]))) for k, v in results.items()}
    per = 1e6 / stream.n_frames
    print(
        f"\n## track run overhead, {label}: {stream.n_frames} frames, {len(stream)} detections, gnn + kf-ca"
    )
    print("| what | least CPU s | µs / frame | vs agent alone (median of paired ratios) |")
    print("|---|---|---|---|")
    rows = [
        ("agent.act on packed observations (the agent's own time)", "own"),
        ("run_agent (pack, loop, gather, tqdm bar)", "loop"),
        ("run_agent with covariances", "cov"),
        ("track run command (read MOT, track, write MOT)", "command"),
    ]
    for what, key in rows:
        print(f"| {what} | {t[key]:.3f} | {t[key] * per:.1f} | {ratio[key]:.3f} |")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="5,000 frames instead of 50,000")
    args = parser.parse_args(argv)
    n = 5_000 if args.quick else 50_000
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        reading(tmp, n, 3 * n)
        overhead(tmp, belt_stream(n, in_view=3.0, seed=1), "sparse")
        overhead(tmp, belt_stream(200 if args.quick else 2_000, in_view=150.0, seed=2), "dense")
    return 0


if __name__ == "__main__":
    sys.exit(main())
