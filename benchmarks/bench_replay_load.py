"""Benchmark: loading a recorded belt-sorter track file with
[`track_envs.io.wide_tracks.load_track_csv`][track_envs.io.load_track_csv].

Generates a realistic file in a temporary directory (each particle visible for about 30 consecutive
frames, NaN elsewhere, positions in metres at full float precision), then times ``load_track_csv``
(best of 3) and, as the reference in the same run, ``numpy.genfromtxt(path, delimiter=",")`` (once;
if that would take over 120 s it is timed on the first 200 rows and extrapolated, which is said).

Usage::

    python benchmarks/bench_replay_load.py [--frames 2000] [--particles 4400] [--seed 0]
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from track_envs.io.wide_tracks import load_track_csv, write_track_csv

GENFROMTXT_LIMIT_S = 120.0
GENFROMTXT_SAMPLE_ROWS = 200


def make_positions(n_frames: int, n_particles: int, seed: int) -> NDArray[np.float64]:
    """Particles crossing a 0.2 m x 0.18 m belt window in ~30 frames each, arriving at random frames."""
    rng = np.random.default_rng(seed)
    pos = np.full((n_frames, n_particles, 2), np.nan)
    duration = rng.integers(25, 36, n_particles)  # frames visible
    first = rng.integers(-int(duration.max()) + 1, n_frames, n_particles)
    x0 = rng.uniform(0.0, 0.18, n_particles)  # metres across the belt
    speed = rng.normal(1.5, 0.05, n_particles) / 100.0  # metres per frame at 100 Hz
    drift = rng.normal(0.0, 2e-4, n_particles)
    for k in range(int(duration.max())):
        frame = first + k
        live = (k < duration) & (frame >= 0) & (frame < n_frames)
        idx = np.flatnonzero(live)
        pos[frame[idx], idx, 0] = x0[idx] + drift[idx] * k + rng.normal(0.0, 1e-4, idx.size)
        pos[frame[idx], idx, 1] = speed[idx] * k + rng.normal(0.0, 1e-4, idx.size)
    return pos


def write_fast(path: Path, positions: NDArray[np.float64]) -> None:
    """Write the track CSV with pandas, not the module (repr-exact floats, ``NaN`` for invisible)."""
    flat = positions.reshape(positions.shape[0], -1)
    pd.DataFrame(flat).to_csv(path, header=False, index=False, na_rep="NaN")


def time_genfromtxt(path: Path, n_frames: int) -> tuple[float, str]:
    """Time ``np.genfromtxt`` on the file, or extrapolate from its first rows if that would be slow.

    The first rows are timed first; when they project a whole-file time over the limit, that projection
    is returned (and said to be one), else the whole file is timed once.
    """
    sample = min(GENFROMTXT_SAMPLE_ROWS, n_frames)
    with path.open() as f:
        head = list(itertools.islice(f, sample))
    t0 = time.perf_counter()
    np.genfromtxt(head, delimiter=",")
    sample_s = time.perf_counter() - t0
    projected = sample_s * n_frames / sample
    if projected > GENFROMTXT_LIMIT_S:
        note = (
            f"extrapolated: first {sample} rows took {sample_s:.2f} s, x {n_frames / sample:g}; "
            f"the whole file would exceed {GENFROMTXT_LIMIT_S:.0f} s"
        )
        return projected, note
    t0 = time.perf_counter()
    np.genfromtxt(path, delimiter=",")
    return time.perf_counter() - t0, "measured once on the whole file"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=2000)
    parser.add_argument("--particles", type=int, default=4400)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    positions = make_positions(args.frames, args.particles, args.seed)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "tracks.csv"
        t0 = time.perf_counter()
        write_fast(path, positions)
        write_s = time.perf_counter() - t0
        size_mb = os.path.getsize(path) / 1e6
        visible = float(np.mean(~np.isnan(positions[..., 0])))
        print(
            f"file: {args.frames} frames x {args.particles} particles ({2 * args.particles} columns), "
            f"{size_mb:.1f} MB, {visible:.2%} of cells visible, written in {write_s:.1f} s"
        )

        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            loaded = load_track_csv(path)
            times.append(time.perf_counter() - t0)
        nan = np.isnan(positions)
        same = np.array_equal(np.isnan(loaded), nan) and np.array_equal(
            loaded[~nan].view(np.uint64), positions[~nan].view(np.uint64)
        )
        load_s = min(times)
        print(
            f"load_track_csv: best of 3 {load_s:.2f} s (runs: {', '.join(f'{t:.2f}' for t in times)}); "
            f"bit-exact vs generated: {same}"
        )
        if not same:
            raise SystemExit("loaded positions differ from the generated ones")

        import gymnasium as gym

        import track_envs  # noqa: F401

        t0 = time.perf_counter()
        env = gym.make("BeltReplay-v0", path=str(path))
        env.reset(seed=0)
        make_s = time.perf_counter() - t0
        print(f"gym.make('BeltReplay-v0', path=...) + reset: {make_s:.2f} s")
        del env

        t0 = time.perf_counter()
        write_track_csv(Path(tmp) / "written.csv", positions)
        own_write_s = time.perf_counter() - t0
        identical = (Path(tmp) / "written.csv").read_bytes() == path.read_bytes()
        print(
            f"write_track_csv: {own_write_s:.2f} s (byte-identical to the pandas-written file: {identical})"
        )

        ref_s, note = time_genfromtxt(path, args.frames)
        print(f"numpy.genfromtxt: {ref_s:.2f} s ({note})")
        ratio = ref_s / load_s
        print(f"speed-up: {ratio:.1f}x")
        print()
        print("| frames | particles | file MB | load_track_csv s (best of 3) | genfromtxt s | speed-up |")
        print("|---|---|---|---|---|---|")
        star = "" if note.startswith("measured") else " (extrapolated)"
        print(
            f"| {args.frames} | {args.particles} | {size_mb:.1f} | {load_s:.2f} | {ref_s:.2f}{star} "
            f"| {ratio:.1f}x |"
        )


if __name__ == "__main__":
    main()
