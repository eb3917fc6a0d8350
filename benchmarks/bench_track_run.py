"""Speed of detection-file reading and of ``track run``'s loop around an agent.

1. Reading a 50,000-frame file of 150,000 detections (a belt-like flow of about 3 particles in
   view, 0 to 8 per frame), in both layouts: `read_mot_detections` and
   `read_wide_detections`, against a plain-Python reader (the `csv` module, one list
   per frame) timed on the same files. Target: <= 2 s.
2. ``track run``'s overhead over the agent's own frame time: the same gnn (kf-ca) tracker over
   the same stream, (a) ``agent.act`` on observations packed before the clock starts (the
   agent's own time), (b) [`agents.files.points.run_agent`][agents.run_agent] (packing, the loop, gathering
   the reports into tracks, a tqdm bar), (c) the whole ``track run`` command (read, track, write the MOT
   file), each timed in the same process on the process's CPU time (the machine is shared: wall
   time counts the waits for a core), seven interleaved repetitions; the ratio is the median of
   the per-repetition ratios. On the sparse stream above and
   on a dense one (150 particles in view, 2,000 frames). Target: (b) / (a) <= 1.10.
3. ``--scale``: the file stages of ``track run`` at 10^3, 10^4 and 10^5 targets in view (20
   frames of [`track_envs.streams.constant_velocity_stream`][track_envs.streams.constant_velocity_stream] at
   the belt's density), each stage in a process of its own: wall time and peak resident memory above the
   stage's start, per detection; the tracker is the ``detections`` agent (no association), so the figures are
   the I/O's and the loop's own. Target: time and memory per detection flat in N.

Run: ``python benchmarks/bench_track_run.py`` (add ``--quick`` for a smaller run;
``--scale`` for 3 only).
"""

from __future__ import annotations

import argparse
import csv
import io
import os
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from contextlib import redirect_stderr
from pathlib import Path
from typing import Any

import numpy as np

from agents import make_agent
from agents.files.loop import packed_block
from agents.files.points import run_agent
from track_apps.cli.run import main as track_run
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


# ------------------------------------------------------------------------------------------ scale
#
# ``--scale``: ``track run``'s file stages at 10^3, 10^4 and 10^5 detections per frame, each
# stage in a process of its own (its wall time, and its peak resident memory above the process's
# resident memory when the stage starts, sampled every 5 ms), so that the I/O is measured apart
# from the tracker (the ``detections`` agent, which reports every detection as a track and does
# no association, stands in for it).

#: Frames of the scale streams.
SCALE_FRAMES = 20
#: The stages of one scale measurement (each: one child process).
SCALE_STAGES = (
    "write-mot",
    "write-wide",
    "read-mot",
    "read-wide",
    "loop",
    "write-tracks-mot",
    "write-tracks-long",
    "write-tracks-wide",
    "sensor-model-steps",
    "command",
)


def scale_stream(n: float, frames: int = SCALE_FRAMES, seed: int = 0) -> Detections:
    """The constant-density stream of issue-scale runs: ``N = n`` targets in view of a window
    ``(0.5 s, 0.3 s)`` m, ``s = sqrt(N / 150)`` (the belt's density whatever ``N``), clutter
    ``5 N / 150`` per frame, ``p_D = 0.9``; truth ids kept (−1: clutter)."""
    from track_envs.streams import constant_velocity_stream

    s = float(np.sqrt(n / 150))
    stream = constant_velocity_stream(
        np.random.default_rng(seed),
        n_targets=n,
        frames=frames,
        size=(0.5 * s, 0.3 * s),
        clutter_rate=5 * n / 150,
    )
    points = [o["detections"][o["mask"] == 1].astype(np.float64) for o in stream.observations]
    ids = [d[o["mask"] == 1] for d, o in zip(stream.detection_ids, stream.observations, strict=True)]
    return Detections.from_frames(points, ids, times=np.arange(frames) * stream.spec.dt)


class PeakMemory:
    """The peak resident memory (MB) of this process above its resident memory at entry,
    sampled every 5 ms on a thread (numpy, pandas and Python allocations alike)."""

    def __enter__(self) -> PeakMemory:
        import threading

        self.start = self.peak = _rss_mb()
        self._stop = threading.Event()

        def sample() -> None:
            while not self._stop.wait(0.005):
                self.peak = max(self.peak, _rss_mb())

        self._thread = threading.Thread(target=sample, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()
        self.peak = max(self.peak, _rss_mb())

    @property
    def above_start(self) -> float:
        return self.peak - self.start


def _rss_mb() -> float:
    with open("/proc/self/statm") as handle:
        return int(handle.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


def scale_stage(stage: str, folder: Path, n: int) -> dict[str, float]:
    """Run one ``stage`` on the files of the ``n``-detections stream in ``folder`` (written by
    the ``write-*`` stages); seconds and peak MB of the stage alone."""
    from track_apps.cli.run import main as run_main
    from track_envs.io.tracks import write_tracks

    det_mot, det_wide = folder / "det.txt", folder / "det.csv"
    work: Callable[[], object]
    if stage.startswith("write-") and not stage.startswith("write-tracks"):
        stream = scale_stream(n)
        if stage == "write-mot":
            work = lambda: write_mot_detections(det_mot, stream, box_size=0.01)  # noqa: E731
        else:
            work = lambda: write_wide_detections(det_wide, stream)  # noqa: E731
    elif stage == "read-mot":
        work = lambda: read_mot_detections(det_mot)  # noqa: E731
    elif stage == "read-wide":
        work = lambda: read_wide_detections(det_wide, time_column="time")  # noqa: E731
    elif stage in ("loop", "sensor-model-steps") or stage.startswith("write-tracks"):
        stream = read_mot_detections(det_mot)
        spec = detection_sensor_spec(stream, dt=0.01, measurement_noise_std=1e-4)
        if stage == "loop":
            work = lambda: run_agent("detections", stream, spec, progress=False)  # noqa: E731
        elif stage == "sensor-model-steps":
            work = lambda: _sensor_model_steps(stream, spec)  # noqa: E731
        else:
            tracks = run_agent("detections", stream, spec, progress=False).updated_rows()
            fmt = stage.rsplit("-", 1)[1]
            work = lambda: write_tracks(folder / f"tracks.{fmt}", tracks, fmt)  # noqa: E731
    elif stage == "command":
        argv = [str(det_mot), "--agent=detections", "--dt=0.01", "--declared-noise-std=1e-4"]
        argv += [f"--out={folder / 'command.txt'}", "--no-progress"]
        work = lambda: _quiet(run_main, argv)  # noqa: E731
    else:
        raise ValueError(f"unknown stage {stage!r}; stages: {SCALE_STAGES}")
    _warm_up(stage, folder)
    with PeakMemory() as memory:
        start, cpu = time.perf_counter(), time.process_time()
        work()
        seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    return {"seconds": seconds, "cpu_seconds": cpu, "peak_mb": memory.above_start}


def _quiet(fn: Callable[..., Any], *args: Any) -> Any:
    with redirect_stderr(io.StringIO()):
        return fn(*args)


def _warm_up(stage: str, folder: Path) -> None:
    """Load the kernels and modules of a tracking or sensor-model stage on a small stream, so that
    the stage's time is its own (not the first call's)."""
    if stage not in ("loop", "sensor-model-steps", "command"):
        return
    small = scale_stream(300, frames=8, seed=1)
    spec = detection_sensor_spec(small, dt=0.01, measurement_noise_std=1e-4)
    if stage == "sensor-model-steps":
        _sensor_model_steps(small, spec)
        return
    run_agent("detections", small, spec, progress=False)
    if stage == "command":
        from track_apps.cli.run import main as run_main

        write_mot_detections(folder / "warm.txt", small, box_size=0.01)
        argv = [str(folder / "warm.txt"), "--agent=detections", "--dt=0.01", "--declared-noise-std=1e-4"]
        with redirect_stderr(io.StringIO()):
            run_main([*argv, f"--out={folder / 'warm-out.txt'}", "--no-progress"])


def _sensor_model_steps(stream: Detections, spec: Any) -> None:
    """The sensor model estimate's own steps on the truth labels (no tracking run): the data scales,
    the noise and start-motion estimate, the re-appearances and the live-track bound."""
    from agents.sensor_model.coasting import coasting_radii
    from agents.sensor_model.estimate import (
        Settings,
        _reappearances,
        estimate_settings,
        live_track_bound,
        tracking_model,
    )
    from agents.sensor_model.scales import data_scales

    scales = data_scales(stream)
    assert scales is not None
    before = Settings(1e-4, 1.0, np.zeros(2), 1.0, 1.0)
    found = estimate_settings(stream, stream.ids, spec.dt, 3, scales.length, before)
    assert found is not None
    settings = found[0]
    model = tracking_model("kf-ca")[1]
    radii = coasting_radii(model, spec.dt, settings.q, settings.noise_std**2, 0.999, 2, 100)
    _reappearances(stream, stream.ids, spec.dt, radii, scales.length)
    live_track_bound(stream, 2)


def scale(sizes: Sequence[int], stages: Sequence[str]) -> None:
    """Every stage at every size, each in a child process; a markdown table per size."""
    import json
    import subprocess

    print(f"\n## track run's file stages at scale ({SCALE_FRAMES} frames, detections agent)")
    print("N targets in view; µs and bytes per detection of the file (about 0.93 N a frame)")
    print("| N targets | stage | wall s | CPU s | CPU µs / detection | peak MB | bytes / detection |")
    print("|---|---|---|---|---|---|---|")
    for n in sizes:
        total = len(scale_stream(n))
        with tempfile.TemporaryDirectory() as name:
            for stage in stages:
                command = [sys.executable, __file__, "--stage", stage, "--folder", name, "--n", str(n)]
                done = subprocess.run(command, capture_output=True, text=True, check=False)
                if done.returncode:
                    print(f"| {n} | {stage} | failed: {done.stderr.strip().splitlines()[-1:]} | | | | |")
                    continue
                r = json.loads(done.stdout.strip().splitlines()[-1])
                print(
                    f"| {n:,} | {stage} | {r['seconds']:.3f} | {r['cpu_seconds']:.3f} | "
                    f"{1e6 * r['cpu_seconds'] / total:.2f} | "
                    f"{r['peak_mb']:.0f} | {1e6 * r['peak_mb'] / total:.0f} |",
                    flush=True,
                )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="5,000 frames instead of 50,000")
    parser.add_argument(
        "--scale",
        action="store_true",
        help="only the file stages at 10^3, 10^4, 10^5 targets in view (see --sizes)",
    )
    parser.add_argument("--sizes", default="1000,10000,100000", help="--scale: targets in view")
    parser.add_argument("--stages", default=",".join(SCALE_STAGES), help="--scale: the stages")
    parser.add_argument("--stage", help=argparse.SUPPRESS)  # a child process of --scale
    parser.add_argument("--folder", help=argparse.SUPPRESS)
    parser.add_argument("--n", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.stage:
        import json

        print(json.dumps(scale_stage(args.stage, Path(args.folder), args.n)))
        return 0
    if args.scale:
        scale([int(v) for v in args.sizes.split(",")], args.stages.split(","))
        return 0
    n = 5_000 if args.quick else 50_000
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        reading(tmp, n, 3 * n)
        overhead(tmp, belt_stream(n, in_view=3.0, seed=1), "sparse")
        overhead(tmp, belt_stream(200 if args.quick else 2_000, in_view=150.0, seed=2), "dense")
    return 0


if __name__ == "__main__":
    sys.exit(main())
