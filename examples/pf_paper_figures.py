"""The Brownian-side experiments of Jung et al. (2019) with the batched bootstrap particle filter.

Reproduces, for the standard PF (Brownian displacement model), on the sine scene of SineTarget-v0:

* Fig. 4a — mean estimation error over ``p_detect ∈ {0.1 … 1.0}`` × ``σ_p ∈ {0.25 … 2.0}``
  (N = 100, σ_m = 0.5);
* Fig. 5a — mean error over ``σ_p`` × ``N`` (p_detect = 0.9, σ_m = 0.5);
* Fig. 7 — occlusion of ``n = 0 … 100`` frames after frame 100 (p_detect = 1 elsewhere,
  σ_m = σ_p = 0.5): mean error of the tracks not lost, and the percentage lost (mean error > 5).

Every Monte Carlo run of a whole grid is one target of one :class:`agents.particle.BatchParticleFilter`,
so a figure is a single pass over the 786 frames. The measurements come from
:func:`track_envs.envs.single_target.draw_detections`, the function SineTarget-v0 senses with, and
the error of a run is that of :class:`track_envs.metrics.single_target.SingleTargetError` (frames
before the filter's first estimate are skipped). Writes ``fig4a_error_grid.png``,
``fig5a_error_sigma_n.png`` and ``fig7_occlusion.png`` into ``--out`` and prints markdown tables::

    python examples/pf_paper_figures.py --runs 20 --out figures
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from numpy.typing import NDArray
from tqdm import tqdm

from agents.particle import BatchParticleFilter, Brownian
from track_envs.envs.single_target import STEP, draw_detections, n_frames_for, sine_trajectory
from track_envs.metrics.single_target import LOST_THRESHOLD


def run_batch(
    p_detect: NDArray[np.float64],
    sigma_p: NDArray[np.float64],
    n_particles: int,
    *,
    sigma_m: float = 0.5,
    occlusion: tuple[NDArray[np.int64], NDArray[np.int64]] | None = None,
    periods: float = 25.0,
    seed: int = 0,
    desc: str = "",
) -> NDArray[np.float64]:
    """Mean estimation error of ``T`` independent runs (one per entry of the (T,) parameter arrays).

    Args:
        p_detect: Detection probability per run (T,).
        sigma_p: Brownian process noise per run, multiples of Δ (T,).
        n_particles: N, common to the batch.
        sigma_m: Measurement noise, multiples of Δ (sensor and likelihood).
        occlusion: ``(start, stop)`` frame arrays (T,) of each run's occlusion, or none.
        periods: Sine periods of the scene (25 in the paper).
        seed: Seed of the batch's generator (measurements and filter).
        desc: tqdm label.

    Returns:
        (T,) mean error per run (NaN if a run never got a detection).
    """
    t_runs = len(p_detect)
    rng = np.random.default_rng(seed)
    truth = sine_trajectory(n_frames_for(periods))
    pf = BatchParticleFilter(
        t_runs,
        n_particles,
        Brownian(sigma_p, STEP),
        sigma_m=sigma_m * STEP,
        sigma_0=sigma_m * STEP,
        rng=rng,
    )
    total = np.zeros(t_runs)
    count = np.zeros(t_runs)
    for frame in tqdm(range(len(truth)), desc=desc, leave=False, mininterval=0.5):
        x = np.broadcast_to(truth[frame], (t_runs, 2))
        occluded = False if occlusion is None else (occlusion[0] <= frame) & (frame < occlusion[1])
        z, detected = draw_detections(x, rng, noise_std=sigma_m * STEP, p_detect=p_detect, occluded=occluded)
        estimate = pf.step(z, detected)
        err = np.linalg.norm(estimate - x, axis=1)
        ok = np.isfinite(err)
        total[ok] += err[ok]
        count[ok] += 1
    with np.errstate(invalid="ignore", divide="ignore"):
        return total / count


def error_grid(
    p_values: NDArray, sigma_values: NDArray, runs: int, n_particles: int, periods: float, seed: int
) -> NDArray[np.float64]:
    """Fig. 4a: mean error (len(p), len(σ)) averaged over ``runs``."""
    p, s, _ = np.meshgrid(p_values, sigma_values, np.arange(runs), indexing="ij")
    err = run_batch(p.ravel(), s.ravel(), n_particles, periods=periods, seed=seed, desc="Fig. 4a")
    return np.nanmean(err.reshape(p.shape), axis=2)


def sigma_n_grid(
    sigma_values: NDArray, n_values: list[int], runs: int, periods: float, seed: int
) -> NDArray[np.float64]:
    """Fig. 5a: mean error (len(N), len(σ)) at p_detect = 0.9, one batch per N."""
    out = np.zeros((len(n_values), len(sigma_values)))
    s = np.repeat(sigma_values, runs)
    for i, n in enumerate(n_values):
        err = run_batch(np.full(len(s), 0.9), s, n, periods=periods, seed=seed + 1 + i, desc=f"Fig. 5a N={n}")
        out[i] = np.nanmean(err.reshape(len(sigma_values), runs), axis=1)
    return out


def occlusion_sweep(
    lengths: NDArray, runs: int, n_particles: int, start: int, periods: float, seed: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Fig. 7: mean error of the runs not lost and % lost per occlusion length."""
    n = np.repeat(lengths, runs)
    err = run_batch(
        np.ones(len(n)),
        np.full(len(n), 0.5),
        n_particles,
        occlusion=(np.full(len(n), start), start + n),
        periods=periods,
        seed=seed + 100,
        desc="Fig. 7",
    ).reshape(len(lengths), runs)
    lost = ~(err <= LOST_THRESHOLD)
    kept = np.where(lost, np.nan, err)
    with np.errstate(invalid="ignore"):
        mean_kept = np.array([np.nanmean(r) if np.isfinite(r).any() else np.nan for r in kept])
    return mean_kept, 100.0 * lost.mean(axis=1)


def markdown_grid(title: str, rows: list[str], cols: list[str], values: NDArray) -> str:
    """A markdown table of ``values`` (len(rows), len(cols))."""
    lines = [f"| {title} | " + " | ".join(cols) + " |", "|---" * (len(cols) + 1) + "|"]
    lines += [
        f"| {r} | " + " | ".join(f"{v:.3f}" for v in row) + " |" for r, row in zip(rows, values, strict=True)
    ]
    return "\n".join(lines)


def heatmap(path: Path, values: NDArray, rows: list[str], cols: list[str], ylabel: str, title: str) -> None:
    fig, ax = plt.subplots(figsize=(7, 5))
    im = ax.imshow(values, origin="lower", cmap="viridis", aspect="auto")
    ax.set_xticks(range(len(cols)), cols)
    ax.set_yticks(range(len(rows)), rows)
    ax.set_xlabel("σ_p (multiples of Δ)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    for (i, j), v in np.ndenumerate(values):
        ax.text(j, i, f"{v:.2f}", ha="center", va="center", color="w", fontsize=7)
    fig.colorbar(im, ax=ax, label="mean estimation error")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--runs", type=int, default=20, help="Monte Carlo runs per grid cell (paper: 100)")
    parser.add_argument("--out", type=Path, default=Path("pf_figures"), help="folder for the PNGs")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true", help="a tiny grid on a short scene (for tests)")
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error("--runs must be >= 1")
    args.out.mkdir(parents=True, exist_ok=True)
    if args.quick:
        p_values, sigma_values = np.array([0.5, 1.0]), np.array([0.5, 1.0])
        n_values, lengths, periods, start, runs = [20, 50], np.array([0, 20]), 2.0, 20, min(args.runs, 2)
    else:
        p_values = np.round(np.arange(1, 11) * 0.1, 2)
        sigma_values = np.arange(1, 9) * 0.25
        n_values, lengths, periods, start, runs = (
            [10, 20, 50, 100, 200, 500],
            np.arange(0, 101, 10),
            25.0,
            100,
            args.runs,
        )

    grid = error_grid(p_values, sigma_values, runs, 100, periods, args.seed)
    sigma_cols = [f"{s:g}" for s in sigma_values]
    p_rows = [f"{p:g}" for p in p_values]
    heatmap(
        args.out / "fig4a_error_grid.png",
        grid,
        p_rows,
        sigma_cols,
        "p_detect",
        "Fig. 4a: Brownian PF, N = 100",
    )
    print(f"\nFig. 4a — mean error, Brownian PF, N = 100, σ_m = 0.5, {runs} runs\n")
    print(markdown_grid("p_d \\ σ_p", p_rows, sigma_cols, grid))

    sn = sigma_n_grid(sigma_values, n_values, runs, periods, args.seed)
    n_rows = [str(n) for n in n_values]
    heatmap(args.out / "fig5a_error_sigma_n.png", sn, n_rows, sigma_cols, "N particles", "Fig. 5a: p_d = 0.9")
    print(f"\nFig. 5a — mean error, p_d = 0.9, σ_m = 0.5, {runs} runs\n")
    print(markdown_grid("N \\ σ_p", n_rows, sigma_cols, sn))

    occ_err, occ_lost = occlusion_sweep(lengths, runs, 100, start, periods, args.seed)
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    a.plot(lengths, occ_err, "o-")
    a.set_xlabel("occlusion length n")
    a.set_ylabel("mean error (tracks not lost)")
    b.plot(lengths, occ_lost, "o-", color="C3")
    b.set_xlabel("occlusion length n")
    b.set_ylabel("% tracks lost")
    fig.suptitle("Fig. 7: Brownian PF, N = 100, σ_m = σ_p = 0.5, p_d = 1")
    fig.tight_layout()
    fig.savefig(args.out / "fig7_occlusion.png", dpi=100)
    plt.close(fig)
    print(f"\nFig. 7 — occlusion after frame {start}, {runs} runs\n")
    print("| n | mean error (not lost) | % lost |\n|---|---|---|")
    for n, e, lost in zip(lengths, occ_err, occ_lost, strict=True):
        print(f"| {n} | {e:.3f} | {lost:.0f} |")
    return {
        "error_grid": grid,
        "sigma_n_grid": sn,
        "occlusion_error": occ_err,
        "occlusion_lost_percent": occ_lost,
        "files": sorted(str(p) for p in args.out.glob("*.png")),
    }


if __name__ == "__main__":
    main()
