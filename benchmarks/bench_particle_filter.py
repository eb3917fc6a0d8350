"""Speed of the bootstrap particle filter (agents/particle/agent.py), as ratios against references timed in
the same run, on the sine scene of SineTarget-v0 (p_detect = 0.9, σ_m = 0.5, σ_p = 1):

1. the agent ``make_agent("pf")`` through ``agent.act`` on a recorded observation stream, at
   N = 100, 1,000 and 10,000 particles, against `plain_bootstrap_filter`, a plain numpy
   bootstrap filter on the same detections (target at 10,000: ≥ 2x; the agent on the numpy path,
   its model wrapped so that only ``propose`` is seen, for comparison), and where the agent's time
   goes (observation check, filter, report; lower decile of single calls);
2. the compiled frame
([`predictors.displacement.CommonDisplacementModel`][predictors.displacement.base.CommonDisplacementModel])
against the numpy path of
   the same filter (the model wrapped so that only ``propose`` is seen), at 1 × 10,000 and 150 × 100;
3. 150 targets × 100 particles in one batched filter against a Python loop over 150 single-target
   filters (target: ≥ 3x);
4. ``--model NAME`` (default ``lstm``, the LSTM displacement model of Jung et al. 2019): the agent with that
   displacement model at N = 10,000 against the Brownian agent (target: ≥ 0.8x), and item 3 with it.

Every pair is timed interleaved, best of ``--repeats``. Prints markdown tables; asserts nothing
(machines are shared and noisy)::

    python benchmarks/bench_particle_filter.py [--model lstm] [--repeats 5]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

import track_envs  # noqa: F401
from agents import make_agent
from agents.particle.agent import BatchParticleFilter
from predictors.displacement import make_displacement_model
from track_envs.contracts.observation import check_observation
from track_envs.contracts.report import empty_report
from track_envs.envs.single_target import STEP, draw_detections, sine_trajectory
from track_envs.values.types import SensorSpec

SIGMA_M = 0.5 * STEP
SIGMA_P = 1.0


def plain_bootstrap_filter(
    zs: Sequence[NDArray[np.float64] | None], n: int, std: float, sigma_m: float, rng: np.random.Generator
) -> NDArray[np.float64]:
    """The reference: a plain numpy bootstrap filter (Brownian, Eq. (4), N_eff < N/2 systematic
    resampling) over the detections ``zs`` (None: no detection); returns the last estimate."""
    x = w = est = None
    for z in zs:
        if x is None or w is None:
            if z is not None:
                x, w = z + sigma_m * rng.standard_normal((n, 2)), np.full(n, 1.0 / n)
            continue
        x += std * rng.standard_normal((n, 2))
        if z is not None:
            w *= np.exp(-((x - z) ** 2).sum(axis=1) / (2 * sigma_m**2))
            w += 1e-300
            w /= w.sum()
        est = w @ x
        if 1.0 / (w @ w) < n / 2:
            idx = np.searchsorted(np.cumsum(w), (rng.random() + np.arange(n)) / n, side="right")
            x, w = x[np.minimum(idx, n - 1)], np.full(n, 1.0 / n)
    return np.asarray(est)


class ProposeOnly:
    """A model seen through ``propose`` only: the filter runs its numpy path."""

    def __init__(self, model: Any):
        self.model = model

    def propose(self, particles: NDArray, history: NDArray, rng: np.random.Generator) -> NDArray:
        return self.model.propose(particles, history, rng)


def record_observations(n_frames: int, seed: int = 0) -> tuple[SensorSpec, list[dict[str, NDArray]]]:
    """The sensor spec and ``n_frames`` observations of SineTarget-v0 (p_detect = 0.9, σ_m = 0.5)."""
    env = gym.make("SineTarget-v0", p_detect=0.9, sigma_m=SIGMA_M / STEP, periods=25.0)
    obs, _ = env.reset(seed=seed)
    spec = env.unwrapped.sensor_spec  # type: ignore[attr-defined]
    out = [obs]
    while len(out) < n_frames:
        obs, _, terminated, truncated, _ = env.step(empty_report(spec.max_tracks, (2,)))
        out.append(obs)
        if terminated or truncated:
            break
    return spec, out


def first_detections(observations: list[dict[str, NDArray]]) -> list[NDArray[np.float64] | None]:
    """The detection of each frame (None without one): what the plain filter is fed."""
    return [
        o["detections"][np.flatnonzero(o["mask"])[0]].astype(np.float64) if o["mask"].any() else None
        for o in observations
    ]


def interleaved_best(timers: Mapping[str, Callable[[], float]], repeats: int) -> dict[str, float]:
    """Best rate of each timer, the timers run in turn ``repeats`` times (one warm-up round first)."""
    best = {name: 0.0 for name in timers}
    for r in range(repeats + 1):
        for name, timer in timers.items():
            rate = timer()
            if r:
                best[name] = max(best[name], rate)
    return best


def agent_timer(
    spec: SensorSpec, observations: list[dict[str, NDArray]], n_particles: int, model: Any = "brownian"
) -> Callable[[], float]:
    """Steps/s of ``make_agent("pf")`` through ``act`` over the recorded observations."""

    def timer() -> float:
        agent = make_agent("pf", n_particles=n_particles, model=model, sigma_p=SIGMA_P)
        agent.reset(spec, seed=0)
        t0 = time.perf_counter()
        for obs in observations:
            agent.act(obs)
        return len(observations) / (time.perf_counter() - t0)

    return timer


def plain_timer(zs: list[NDArray[np.float64] | None], n_particles: int) -> Callable[[], float]:
    def timer() -> float:
        rng = np.random.default_rng(0)
        t0 = time.perf_counter()
        plain_bootstrap_filter(zs, n_particles, SIGMA_P * STEP, SIGMA_M, rng)
        return len(zs) / (time.perf_counter() - t0)

    return timer


def batch_measurements(n_targets: int, n_frames: int, seed: int) -> tuple[NDArray, NDArray]:
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


def make_filter(n_targets: int, n_particles: int, model: str, seed: int, numpy_path: bool = False) -> Any:
    m = make_displacement_model(model, SIGMA_P, STEP)
    return BatchParticleFilter(
        n_targets,
        n_particles,
        ProposeOnly(m) if numpy_path else m,
        sigma_m=SIGMA_M,
        sigma_0=SIGMA_M,
        rng=np.random.default_rng(seed),
    )


def batched_timer(
    z: NDArray, seen: NDArray, n_particles: int, model: str = "brownian", numpy_path: bool = False
) -> Callable[[], float]:
    """Frames/s of one filter over all targets of ``z`` (F, T, 2)."""

    def timer() -> float:
        pf = make_filter(z.shape[1], n_particles, model, 0, numpy_path)
        t0 = time.perf_counter()
        for f in range(len(z)):
            pf.step(z[f], seen[f])
        return len(z) / (time.perf_counter() - t0)

    return timer


def loop_timer(z: NDArray, seen: NDArray, n_particles: int, model: str = "brownian") -> Callable[[], float]:
    """Frames/s of a Python loop over one single-target filter per target."""

    def timer() -> float:
        filters = [make_filter(1, n_particles, model, k) for k in range(z.shape[1])]
        t0 = time.perf_counter()
        for f in range(len(z)):
            for k, pf in enumerate(filters):
                pf.step(z[f, k : k + 1], seen[f, k : k + 1])
        return len(z) / (time.perf_counter() - t0)

    return timer


def overhead(spec: SensorSpec, observations: list[dict[str, NDArray]], n_particles: int) -> dict[str, float]:
    """µs per frame of the agent's parts (``act`` and, inside it, ``check_observation``, the filter
    frame, the report), each the lower decile of single timed calls (robust on a shared machine)."""
    agent = make_agent("pf", n_particles=n_particles, sigma_p=SIGMA_P)
    agent.reset(spec, seed=0)
    for obs in observations[:5]:
        agent.act(obs)
    pf = agent.filter
    obs = next(o for o in observations[5:] if o["mask"].sum() == 1)
    _, z = check_observation(obs, spec)
    has = np.ones(1, dtype=bool)
    parts: dict[str, Callable[[], Any]] = {
        "act": lambda: agent.act(obs),
        "check_observation": lambda: check_observation(obs, spec),
        "filter step": lambda: pf.step(z, has),
        "report": lambda: empty_report(spec.max_tracks, (2,)),
    }
    calls = max(50, 300_000 // n_particles)
    out = {}
    for name, fn in parts.items():
        times = np.empty(calls)
        for k in range(calls):
            t0 = time.perf_counter()
            fn()
            times[k] = time.perf_counter() - t0
        out[name] = float(np.percentile(times, 10)) * 1e6
    return out


def pair_row(label: str, best: dict[str, float], a: str, b: str) -> float:
    """Print the markdown row ``label | a/s | b/s | a/b`` and return the ratio."""
    ratio = best[a] / best[b]
    print(f"| {label} | {best[a]:,.0f} | {best[b]:,.0f} | {ratio:.2f}x |")
    return ratio


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", default="lstm", help="model timed against Brownian (e.g. lstm, cv)")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--frames", type=int, default=400, help="frames of the recorded observation stream")
    args = parser.parse_args(argv)
    results: dict[str, float] = {}
    spec, observations = record_observations(args.frames)
    zs = first_detections(observations)

    print(
        "| agent `pf` through `act` (T = 1) | agent steps/s | plain numpy filter steps/s | ratio "
        "| agent on the numpy path steps/s | ratio |\n|---|---|---|---|---|---|"
    )
    for n in (100, 1_000, 10_000):
        numpy_model = ProposeOnly(make_displacement_model("brownian", SIGMA_P, STEP))
        timers = {
            "agent": agent_timer(spec, observations, n),
            "plain": plain_timer(zs, n),
            "numpy": agent_timer(spec, observations, n, numpy_model),
        }
        best = interleaved_best(timers, args.repeats)
        ratio, numpy_ratio = best["agent"] / best["plain"], best["numpy"] / best["plain"]
        results[f"agent_vs_plain_N{n}"], results[f"numpy_agent_vs_plain_N{n}"] = ratio, numpy_ratio
        print(
            f"| N = {n:,} | {best['agent']:,.0f} | {best['plain']:,.0f} | {ratio:.2f}x "
            f"| {best['numpy']:,.0f} | {numpy_ratio:.2f}x |"
        )

    parts = ("act", "check_observation", "filter step", "report")
    print("\n| where the agent's frame goes (µs) | " + " | ".join(parts) + " |\n|---|---|---|---|---|")
    for n in (100, 10_000):
        us = overhead(spec, observations, n)
        results.update({f"us_{k.replace(' ', '_')}_N{n}": v for k, v in us.items()})
        print(f"| N = {n:,} | " + " | ".join(f"{us[k]:.1f}" for k in parts) + " |")

    z1, s1 = batch_measurements(1, args.frames, 0)
    zb, sb = batch_measurements(150, 200, 1)
    print("\n| filter (targets × particles) | compiled frames/s | numpy path frames/s | ratio |")
    print("|---|---|---|---|")
    for label, (key, z, s, n) in {
        "1 × 10,000": ("1x10000", z1, s1, 10_000),
        "150 × 100": ("150x100", zb, sb, 100),
    }.items():
        timers = {"compiled": batched_timer(z, s, n), "numpy": batched_timer(z, s, n, numpy_path=True)}
        best = interleaved_best(timers, args.repeats)
        results[f"compiled_vs_numpy_{key}"] = pair_row(label, best, "compiled", "numpy")

    print("\n| 150 × 100, model | batched frames/s | loop of 150 T = 1 filters frames/s | ratio |")
    print("|---|---|---|---|")
    for model in dict.fromkeys(("brownian", args.model)):
        timers = {"batched": batched_timer(zb, sb, 100, model), "loop": loop_timer(zb, sb, 100, model)}
        best = interleaved_best(timers, max(1, args.repeats // 2))
        results[f"batched_vs_loop_{model}"] = pair_row(model, best, "batched", "loop")

    print(
        f"\n| agent at N = 10,000 | `{args.model}` steps/s | `brownian` steps/s | ratio |\n|---|---|---|---|"
    )
    timers = {
        "model": agent_timer(spec, observations, 10_000, args.model),
        "brownian": agent_timer(spec, observations, 10_000),
    }
    best = interleaved_best(timers, args.repeats)
    results["model_vs_brownian_N10000"] = pair_row(
        f'make_agent("pf", model="{args.model}")', best, "model", "brownian"
    )

    print(
        f"\nTargets: agent at N = 10,000 >= 2x the plain filter ({results['agent_vs_plain_N10000']:.2f}x); "
        f"batched >= 3x the loop ({results['batched_vs_loop_brownian']:.1f}x brownian, "
        f"{results[f'batched_vs_loop_{args.model}']:.1f}x {args.model}); "
        f"{args.model} >= 0.8x brownian at N = 10,000 ({results['model_vs_brownian_N10000']:.2f}x)"
    )
    return results


if __name__ == "__main__":
    main()
