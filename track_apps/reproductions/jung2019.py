"""The five experiments of Jung et al. (2019), Sec. IV, as batched Monte Carlo runs.

Jung, Schlangen, Charlish, "Sequential Monte Carlo Filtering with Long Short-Term Memory
Prediction" (FUSION 2019) compare the bootstrap particle filter with a Brownian displacement model
against the same filter with a learned (LSTM) one. Every Monte Carlo run of an experiment (all the
cells of a parameter grid and all their runs) is one target of one
[`agents.particle.agent.BatchParticleFilter`][agents.particle.agent.BatchParticleFilter] per displacement
model, so an experiment is one pass over the frames of the scene, and all the filters of a pass see the *same*
measurements (common random numbers; the filters' own draws come from one shared seed as well).

A run: the local trajectory ``x_t`` (the sine of Eq. (5), or a piecewise-linear one), the sensor of
SineTarget-v0 / PiecewiseTarget-v0
([`track_envs.envs.single_target.draw_detections`][track_envs.envs.single_target.draw_detections]: detected
with probability ``p_d``, never inside the occlusion, noise ``σ_m·Δ``), drawn in the local frame and mapped to
the world by [`to_world`][track_envs.envs.single_target.to_world] (a rotation of the scene rotates
measurements and truth alike under the same seed). The error of a run is the mean over its frames of
``||x*_t − x_t||`` from the filter's first estimate on (as
[`track_envs.metrics.single_target.SingleTargetError`][track_envs.metrics.SingleTargetError]); a run is lost
when that mean exceeds ``LOST_THRESHOLD`` (5). The gain of a learned model over Brownian motion is
``100 · (e_Brownian − e_learned) / e_Brownian`` percent.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from tqdm import tqdm

from agents.particle.agent import BatchParticleFilter
from predictors.displacement import make_displacement_model
from track_envs.envs.single_target import (
    LOST_THRESHOLD,
    STEP,
    draw_detections,
    n_frames_for,
    piecewise_trajectory,
    sine_trajectory,
    to_world,
)

#: Displacement models compared by default: the standard PF and the LSTM-PF of Jung et al. (2019).
MODELS = ("brownian", "lstm")


@dataclass
class FilterRuns:
    """What one displacement model's filter did over a batch of runs.

    Attributes:
        mean_error: (T,) mean estimation error per run (NaN if a run never got a detection).
        error_over_time: (F,) estimation error per frame averaged over the runs that have an estimate.
        estimates: (K, F, 2) world estimates of the traced runs (NaN before a filter started).
        spread: (K, F) weighted mean distance ``Σ_i w⁽ⁱ⁾ ||x⁽ⁱ⁾ − x_t||`` of the particles to the truth
            at the end of each frame (after a resampling), traced runs.
        spread_std: (K, F) weighted standard deviation of those distances over the particles.
        particle_error: (T,) the error of Jung et al. (2019), Sec. IV: the particles' weighted mean
            distance to the truth (as ``spread``), averaged over the frames of each run.
        errors: (T, F) estimation error of every run and frame (NaN before a start) when asked for.
    """

    mean_error: NDArray[np.float64]
    error_over_time: NDArray[np.float64]
    estimates: NDArray[np.float64]
    spread: NDArray[np.float64]
    spread_std: NDArray[np.float64]
    particle_error: NDArray[np.float64]
    errors: NDArray[np.float64] | None = None


@dataclass
class GridRuns:
    """Per-run errors of one filter over a parameter grid, shape (..., runs) each.

    Attributes:
        estimate: Mean estimation error of each run
            ([`FilterRuns.mean_error`][track_apps.reproductions.jung2019.FilterRuns.mean_error]).
        particles: Mean particle distance to the truth of each run
            ([`FilterRuns.particle_error`][track_apps.reproductions.jung2019.FilterRuns.particle_error]).
    """

    estimate: NDArray[np.float64]
    particles: NDArray[np.float64]


@dataclass
class Batch:
    """A batch of ``T`` runs stepped through every model
    ([`run_batch`][track_apps.reproductions.jung2019.run_batch]).

    Attributes:
        truth: (K, F, 2) world truth of the traced runs.
        detections: (K, F, 2) world measurements of the traced runs, NaN where missed.
        filters: Model name → [`FilterRuns`][track_apps.reproductions.jung2019.FilterRuns].
    """

    truth: NDArray[np.float64]
    detections: NDArray[np.float64]
    filters: dict[str, FilterRuns] = field(default_factory=dict)


def _per_run(name: str, value: ArrayLike, t_runs: int) -> NDArray[np.float64]:
    arr = np.broadcast_to(np.asarray(value, dtype=np.float64), (t_runs,))
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} must be finite, got {value!r}")
    return arr


def run_batch(
    truth: ArrayLike,
    p_detect: ArrayLike,
    sigma_p: ArrayLike,
    n_particles: int,
    *,
    models: tuple[str, ...] = MODELS,
    sigma_m: float = 0.5,
    occlusion: tuple[ArrayLike, ArrayLike] | None = None,
    rotation_deg: float = 0.0,
    n_runs: int | None = None,
    trace: ArrayLike = (),
    per_frame: bool = False,
    seed: int = 0,
    desc: str = "",
) -> Batch:
    """Step ``T`` independent runs through one filter per displacement model, frame by frame.

    Not an episode of an env ([`agents.run_episode`][agents.run_episode]): every run of the batch is one
    target of one batched filter per model, and all the filters see the same measurements.

    Args:
        truth: Local trajectory (F, 2) shared by every run, or one per run (T, F, 2).
        p_detect: Detection probability, scalar or (T,).
        sigma_p: Process noise in multiples of ``Δ``, scalar or (T,).
        n_particles: ``N``, common to the batch.
        models: Displacement model names
            ([`predictors.displacement.make_displacement_model`][predictors.displacement.registry.make_displacement_model]).
        sigma_m: Measurement noise in multiples of ``Δ`` (sensor, likelihood and initial cloud).
        occlusion: ``(start, stop)`` frames, scalars or (T,), of each run's occlusion; none if None.
        rotation_deg: Rotation of the scene about the origin (degrees).
        n_runs: ``T`` when neither ``truth`` nor the parameters have a run axis (default: their size).
        trace: Indices of the runs whose estimates and particle spread are recorded.
        per_frame: Also keep the estimation error of every run and frame
            ([`FilterRuns.errors`][track_apps.reproductions.jung2019.FilterRuns.errors]).
        seed: Seed of the measurements and of the filters' draws.
        desc: tqdm label.

    Returns:
        The [`Batch`][track_apps.reproductions.jung2019.Batch].
    """
    x_local = np.asarray(truth, dtype=np.float64)
    if x_local.ndim not in (2, 3) or x_local.shape[-1] != 2:
        raise ValueError(f"truth must have shape (F, 2) or (T, F, 2), got {x_local.shape}")
    sizes = [np.size(p_detect), np.size(sigma_p), *(x_local.shape[:1] if x_local.ndim == 3 else ())]
    t_runs = int(n_runs if n_runs is not None else max(sizes))
    n_frames = x_local.shape[-2]
    pd = _per_run("p_detect", p_detect, t_runs)
    sp = _per_run("sigma_p", sigma_p, t_runs)
    occ = (
        None
        if occlusion is None
        else (np.broadcast_to(occlusion[0], (t_runs,)), np.broadcast_to(occlusion[1], (t_runs,)))
    )
    traced = np.asarray(trace, dtype=np.intp).reshape(-1)
    std = sigma_m * STEP
    root = np.random.SeedSequence(seed)
    meas_seed, filter_seed = root.spawn(2)
    meas_rng = np.random.default_rng(meas_seed)
    filters = {
        name: BatchParticleFilter(
            t_runs,
            n_particles,
            make_displacement_model(name, sp, STEP),
            sigma_m=std,
            sigma_0=std,
            rng=np.random.default_rng(filter_seed),
        )
        for name in models
    }
    k = len(traced)
    batch = Batch(truth=np.zeros((k, n_frames, 2)), detections=np.full((k, n_frames, 2), np.nan))
    tallies = {name: _Tally.empty(t_runs, n_frames, traced, per_frame) for name in models}
    for frame in tqdm(range(n_frames), desc=desc, leave=False, mininterval=0.5, disable=not desc):
        here = x_local[:, frame] if x_local.ndim == 3 else np.broadcast_to(x_local[frame], (t_runs, 2))
        occluded = False if occ is None else (occ[0] <= frame) & (frame < occ[1])
        z_local, detected = draw_detections(here, meas_rng, noise_std=std, p_detect=pd, occluded=occluded)
        x = to_world(here, rotation_deg, (0.0, 0.0))
        z = to_world(z_local, rotation_deg, (0.0, 0.0))
        batch.truth[:, frame] = x[traced]
        batch.detections[:, frame] = np.where(detected[traced, None], z[traced], np.nan)
        for name, pf in filters.items():
            tallies[name].add(frame, pf.step(z, detected), x, pf)
    batch.filters = {name: tallies[name].runs() for name in models}
    return batch


@dataclass
class _Tally:
    """What one filter of [`run_batch`][track_apps.reproductions.jung2019.run_batch] did so far, frame by
    frame."""

    traced: NDArray[np.intp]
    total: NDArray[np.float64]
    count: NDArray[np.float64]
    over_time: NDArray[np.float64]
    estimates: NDArray[np.float64]
    spread: NDArray[np.float64]
    spread_std: NDArray[np.float64]
    particle_total: NDArray[np.float64]
    errors: NDArray[np.float64] | None

    @classmethod
    def empty(cls, t_runs: int, n_frames: int, traced: NDArray[np.intp], per_frame: bool) -> _Tally:
        k = len(traced)
        return cls(
            traced,
            np.zeros(t_runs),
            np.zeros(t_runs),
            np.full(n_frames, np.nan),
            np.full((k, n_frames, 2), np.nan),
            np.full((k, n_frames), np.nan),
            np.full((k, n_frames), np.nan),
            np.zeros(t_runs),
            np.full((t_runs, n_frames), np.nan) if per_frame else None,
        )

    def add(
        self, frame: int, estimate: NDArray[np.float64], x: NDArray[np.float64], pf: BatchParticleFilter
    ) -> None:
        """Count the filter's ``estimate`` (T, 2) of frame ``frame`` against the world truth ``x``,
        and its particles' distance to it (weighted mean and spread, traced runs)."""
        err = np.linalg.norm(estimate - x, axis=1)
        ok = np.isfinite(err)
        self.total[ok] += err[ok]
        self.count[ok] += 1
        if ok.any():
            self.over_time[frame] = err[ok].mean()
        if self.errors is not None:
            self.errors[:, frame] = err
        dist = np.linalg.norm(pf.particles - x[:, None, :], axis=2)
        mean = np.einsum("tn,tn->t", pf.weights, dist)
        self.particle_total[ok] += mean[ok]
        if len(self.traced):
            traced = self.traced
            self.estimates[:, frame] = estimate[traced]
            d, w, m = dist[traced], pf.weights[traced], mean[traced]
            var = np.einsum("kn,kn->k", w, (d - m[:, None]) ** 2)
            started = pf.started[traced]
            self.spread[started, frame] = m[started]
            self.spread_std[started, frame] = np.sqrt(var[started])

    def runs(self) -> FilterRuns:
        """The [`FilterRuns`][track_apps.reproductions.jung2019.FilterRuns] of the frames counted."""
        with np.errstate(invalid="ignore", divide="ignore"):
            mean_error = self.total / self.count
            particle_error = self.particle_total / self.count
        return FilterRuns(
            mean_error,
            self.over_time,
            self.estimates,
            self.spread,
            self.spread_std,
            particle_error,
            self.errors,
        )


def gain_percent(brownian: ArrayLike, learned: ArrayLike) -> NDArray[np.float64]:
    """``100 · (e_B − e_L) / e_B``: the accuracy gained by the learned model, percent."""
    b = np.asarray(brownian, dtype=np.float64)
    return 100.0 * (b - np.asarray(learned, dtype=np.float64)) / b


def paired_gain(brownian: ArrayLike, learned: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gain of the mean errors and its standard error from per-run errors (..., runs) of both filters.

    The runs are paired (the filters see the same measurements): with ``d = e_B − e_L`` per run, the
    gain is ``100 · mean(d) / mean(e_B)`` and its standard error ``100 · std(d) / (√runs · mean(e_B))``
    (runs without an error in either filter are left out).
    """
    b, lrn = np.asarray(brownian, dtype=np.float64), np.asarray(learned, dtype=np.float64)
    ok = np.isfinite(b) & np.isfinite(lrn)
    n = ok.sum(axis=-1)
    d = np.where(ok, b - lrn, 0.0)
    b_mean = np.where(ok, b, 0.0).sum(axis=-1) / n
    d_mean = d.sum(axis=-1) / n
    d_var = (np.where(ok, d - d_mean[..., None], 0.0) ** 2).sum(axis=-1) / np.maximum(n - 1, 1)
    return 100.0 * d_mean / b_mean, 100.0 * np.sqrt(d_var / n) / b_mean


def lost_and_kept(mean_error: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per row of ``mean_error`` (R, runs): the mean error of the runs not lost and the percent lost.

    A run is lost when its mean error exceeds ``LOST_THRESHOLD`` (or it has none); the mean of the
    kept runs is NaN when every run of a row is lost.
    """
    lost = ~(mean_error <= LOST_THRESHOLD)
    kept = np.where(lost, 0.0, mean_error)
    n_kept = (~lost).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_kept = np.where(n_kept > 0, kept.sum(axis=1) / n_kept, np.nan)
    return mean_kept, 100.0 * lost.mean(axis=1)


def after_turns(scenes: ArrayLike, window: int = 10) -> NDArray[np.bool_]:
    """(T, F) mask of the frames ``t … t + window − 1`` after each turn of piecewise-linear scenes
    (T, F, 2): frames whose step ``x_t − x_{t−1}`` has another heading than the step before."""
    x = np.asarray(scenes, dtype=np.float64)
    v = np.diff(x, axis=1)
    heading = np.arctan2(v[..., 1], v[..., 0])
    turn = np.zeros(x.shape[:2], dtype=bool)
    turn[:, 2:] = ~np.isclose(heading[:, 1:], heading[:, :-1], atol=1e-9)
    kernel = np.ones(window, dtype=np.int64)
    counts = np.stack([np.convolve(row.astype(np.int64), kernel)[: x.shape[1]] for row in turn])
    return counts > 0


def sine(periods: float) -> NDArray[np.float64]:
    """The local sine scene of ``periods`` periods (Eq. (5), ``Δ`` = 0.2)."""
    return sine_trajectory(n_frames_for(periods))


def piecewise_scenes(runs: int, periods: float, seed: int) -> NDArray[np.float64]:
    """(runs, F, 2) local piecewise-linear trajectories, run ``r`` as PiecewiseTarget-v0 resets with
    ``seed + r`` (its defaults: segments of 10–50 steps, headings within ±60°)."""
    n = n_frames_for(periods)
    return np.stack([piecewise_trajectory(n, np.random.default_rng(seed + r)) for r in range(runs)])


# -- the experiments (Sec. IV-B); each returns per-model results keyed by model name -----------------


def exp1_rotation(
    runs: int, *, models: tuple[str, ...] = MODELS, periods: float = 25.0, seed: int = 0
) -> dict[float, Batch]:
    """Exp. 1 (Fig. 3): the sine and the sine rotated by 45° (N = 100, p_d = 0.5, σ_p = σ_m = 0.5).

    Both rotations use the same seed, so their measurements are rotations of each other; run 0 is
    traced. Returns rotation (degrees) → [`Batch`][track_apps.reproductions.jung2019.Batch].
    """
    return {
        rot: run_batch(
            sine(periods),
            0.5,
            0.5,
            100,
            models=models,
            rotation_deg=rot,
            n_runs=runs,
            trace=[0],
            seed=seed,
            desc=f"Exp. 1 ({rot:g}°)",
        )
        for rot in (0.0, 45.0)
    }


def exp2_grid(
    p_values: ArrayLike,
    sigma_values: ArrayLike,
    runs: int,
    *,
    models: tuple[str, ...] = MODELS,
    periods: float = 25.0,
    seed: int = 1,
) -> dict[str, GridRuns]:
    """Exp. 2 (Fig. 4): the errors of every run (len(p), len(σ_p), runs), N = 100, σ_m = 0.5."""
    p, s, _ = np.meshgrid(np.asarray(p_values), np.asarray(sigma_values), np.arange(runs), indexing="ij")
    batch = run_batch(sine(periods), p.ravel(), s.ravel(), 100, models=models, seed=seed, desc="Exp. 2")
    return {
        name: GridRuns(f.mean_error.reshape(p.shape), f.particle_error.reshape(p.shape))
        for name, f in batch.filters.items()
    }


def exp3_grid(
    sigma_values: ArrayLike,
    n_values: list[int],
    runs: int,
    *,
    models: tuple[str, ...] = MODELS,
    periods: float = 25.0,
    seed: int = 2,
) -> dict[str, GridRuns]:
    """Exp. 3 (Fig. 5): the errors of every run (len(N), len(σ_p), runs) at p_d = 0.9, σ_m = 0.5, one
    batch per N."""
    s = np.repeat(np.asarray(sigma_values, dtype=np.float64), runs)
    shape = (len(n_values), len(s) // runs, runs)
    out = {name: GridRuns(np.zeros(shape), np.zeros(shape)) for name in models}
    for i, n in enumerate(n_values):
        batch = run_batch(sine(periods), 0.9, s, n, models=models, seed=seed + 10 * i, desc=f"Exp. 3 (N={n})")
        for name, f in batch.filters.items():
            out[name].estimate[i] = f.mean_error.reshape(-1, runs)
            out[name].particles[i] = f.particle_error.reshape(-1, runs)
    return out


def exp4_example(
    runs: int,
    length: int = 25,
    *,
    start: int = 100,
    models: tuple[str, ...] = MODELS,
    periods: float = 25.0,
    seed: int = 3,
) -> Batch:
    """Exp. 4 (Fig. 6): an occlusion of ``length`` frames from frame ``start`` (p_d = 1 elsewhere,
    σ_m = σ_p = 0.5, N = 100); run 0 traced, the error over time averaged over ``runs``."""
    return run_batch(
        sine(periods),
        1.0,
        0.5,
        100,
        models=models,
        occlusion=(start, start + length),
        n_runs=runs,
        trace=[0],
        seed=seed,
        desc=f"Exp. 4 (n={length})",
    )


def exp4_sweep(
    lengths: ArrayLike,
    runs: int,
    *,
    start: int = 100,
    models: tuple[str, ...] = MODELS,
    periods: float = 25.0,
    seed: int = 4,
) -> dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """Exp. 4 (Fig. 7): per occlusion length, the mean error of the runs not lost and the % lost."""
    n = np.repeat(np.asarray(lengths, dtype=np.int64), runs)
    batch = run_batch(
        sine(periods),
        1.0,
        0.5,
        100,
        models=models,
        occlusion=(np.full(len(n), start), start + n),
        n_runs=len(n),
        seed=seed,
        desc="Exp. 4 (sweep)",
    )
    return {name: lost_and_kept(f.mean_error.reshape(-1, runs)) for name, f in batch.filters.items()}


def exp5_piecewise(
    runs: int,
    p_detect: float = 0.5,
    *,
    models: tuple[str, ...] = MODELS,
    periods: float = 25.0,
    seed: int = 5,
) -> Batch:
    """Exp. 5 (Fig. 8): piecewise-linear targets (PiecewiseTarget-v0), σ_m = σ_p = 0.5, N = 100,
    ``p_detect`` (paper: 0.5); one trajectory per run
    ([`piecewise_scenes`][track_apps.reproductions.jung2019.piecewise_scenes] of ``seed``), run 0 traced, the
    error of every frame kept."""
    return run_batch(
        piecewise_scenes(runs, periods, seed),
        p_detect,
        0.5,
        100,
        models=models,
        trace=[0],
        per_frame=True,
        seed=seed,
        desc=f"Exp. 5 (p_d={p_detect:g})",
    )
