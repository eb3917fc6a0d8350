"""Speed of the batched bootstrap particle filter (agents/particle.py).

Two measurements, on the sine scene of SineTarget-v0 (p_detect = 0.9, σ_m = 0.5, Brownian σ_p = 1):

1. filter steps per second of one target at N = 100, 1,000 and 10,000 particles
   (target: ≥ 1,500 steps/s at 10,000);
2. 150 targets × 100 particles in one batched filter against a Python loop over 150 single-target
   filters (the same class with T = 1), timed in the same run (target: ≥ 3x).

Prints a markdown table and the ratio; asserts nothing (machines are shared and noisy)::

    python benchmarks/bench_particle_filter.py
"""

from __future__ import annotations

import time

import numpy as np

from agents.particle import BatchParticleFilter, Brownian
from track_envs.envs.single_target import STEP, draw_detections, n_frames_for, sine_trajectory

SIGMA_M = 0.5 * STEP


def measurements(n_targets: int, n_frames: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Detections (F, T, 2) and flags (F, T) of ``n_targets`` runs of the sine scene."""
    rng = np.random.default_rng(seed)
    truth = sine_trajectory(n_frames)
    z = np.zeros((n_frames, n_targets, 2))
    seen = np.zeros((n_frames, n_targets), dtype=bool)
    for f in range(n_frames):
        z[f], seen[f] = draw_detections(
            np.broadcast_to(truth[f], (n_targets, 2)), rng, noise_std=SIGMA_M, p_detect=0.9
        )
    return z, seen


def make_filter(n_targets: int, n_particles: int, seed: int) -> BatchParticleFilter:
    return BatchParticleFilter(
        n_targets,
        n_particles,
        Brownian(1.0),
        sigma_m=SIGMA_M,
        sigma_0=SIGMA_M,
        rng=np.random.default_rng(seed),
    )


def time_batched(z: np.ndarray, seen: np.ndarray, n_particles: int, repeats: int = 3) -> float:
    """Best frames/s of one filter over all targets of ``z`` (F, T, 2)."""
    best = 0.0
    for r in range(repeats):
        pf = make_filter(z.shape[1], n_particles, r)
        t0 = time.perf_counter()
        for f in range(len(z)):
            pf.step(z[f], seen[f])
        best = max(best, len(z) / (time.perf_counter() - t0))
    return best


def time_loop(z: np.ndarray, seen: np.ndarray, n_particles: int, repeats: int = 3) -> float:
    """Best frames/s of a Python loop over one single-target filter per target."""
    best = 0.0
    for r in range(repeats):
        filters = [make_filter(1, n_particles, 1000 * r + k) for k in range(z.shape[1])]
        t0 = time.perf_counter()
        for f in range(len(z)):
            for k, pf in enumerate(filters):
                pf.step(z[f, k : k + 1], seen[f, k : k + 1])
        best = max(best, len(z) / (time.perf_counter() - t0))
    return best


def main() -> dict[str, float]:
    frames = n_frames_for(25.0)
    z1, s1 = measurements(1, frames, 0)
    rows = []
    results: dict[str, float] = {}
    for n in (100, 1_000, 10_000):
        rate = time_batched(z1, s1, n)
        results[f"steps_per_s_N{n}"] = rate
        rows.append(
            f"| 1 × {n:,} (one filter) | {rate:,.0f} steps/s | {rate * n / 1e6:.1f} M particle-steps/s |"
        )
    zb, sb = measurements(150, 200, 1)
    batched = time_batched(zb, sb, 100)
    loop = time_loop(zb, sb, 100)
    results["batched_150x100_frames_per_s"] = batched
    results["loop_150x100_frames_per_s"] = loop
    results["ratio"] = batched / loop
    rows.append(
        f"| 150 × 100 batched | {batched:,.0f} frames/s | {batched * 15_000 / 1e6:.1f} M particle-steps/s |"
    )
    rows.append(
        f"| 150 × 100 loop of T = 1 filters | {loop:,.0f} frames/s "
        f"| {loop * 15_000 / 1e6:.1f} M particle-steps/s |"
    )
    print("| filter (targets × particles) | speed | throughput |\n|---|---|---|")
    print("\n".join(rows))
    print(
        f"\nN = 10,000: {results['steps_per_s_N10000']:,.0f} steps/s (target >= 1,500); "
        f"batched / loop over 150 targets: {results['ratio']:.1f}x (target >= 3x)"
    )
    return results


if __name__ == "__main__":
    main()
