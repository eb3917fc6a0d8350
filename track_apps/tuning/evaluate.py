"""Paired evaluation of gate-tuning policies on held-out seeds, and the best fixed setting of a
``track bench`` grid.

Every policy plays the same episodes (GateTuning-v0 reset with the same seeds, so the same
particles, detections and drift); the measure is an episode's association errors ``E`` (minus
its return, [`track_apps.tuning.env.association_error_count`][track_apps.tuning.env.association_error_count]).
A comparison of policy A with B reports the mean and std of the paired differences, the relative change of the
mean ``(E_B − E_A) / E_B``, how many seeds A wins (strictly fewer errors), and the two-sided Wilcoxon
signed-rank p-value of the differences.
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from track_apps.tuning.env import BASE_MAX_TARGETS, BASE_MAX_TRACKS, HELD_OUT_SEEDS
from track_apps.tuning.knobs import knob_ranges
from track_apps.tuning.policy import PolicyCapability, policy_capability
from track_envs.infra.arguments import check_int

#: The grid of the fixed-setting baseline (values of each knob).
GRID: dict[str, tuple[float, ...]] = {
    "p_gate": (0.5, 0.7, 0.9, 0.99, 0.999, 0.9999, 0.99999),
    "recovery_inflation": (1.0, 25.0, 400.0),
    "noise_scale": (0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0),
}


def held_out_seeds(n: int) -> list[int]:
    """``n`` evaluation seeds, never drawn by training
    ([`HELD_OUT_SEEDS`][track_apps.tuning.evaluate.HELD_OUT_SEEDS] and up)."""
    return [HELD_OUT_SEEDS + i for i in range(n)]


def episode_errors(env: gym.Env, policy: Any, seed: int) -> dict[str, Any]:
    """One episode of ``policy`` on ``env`` from ``seed``: its errors and return, and per step
    the knobs set (``knobs``), the errors so far (``errors_so_far``) and the true sensor of the
    window's last frame (``sensor``; empty without drift).

    A policy that declares ``BINDS_ENV`` (`SettingChooser`) is
    bound to the env first; one that declares ``KNOB_RANGES`` must act on the env's knobs
    (`track_apps.tuning.policy`).
    """
    env_knobs = tuple(env.unwrapped.knobs)  # type: ignore[attr-defined]
    ranged = policy_capability(policy, PolicyCapability.KNOB_RANGES)
    policy_knobs = ranged.knobs if ranged is not None else None
    if policy_knobs is not None and tuple(policy_knobs) != env_knobs:
        raise ValueError(
            f"the policy's knob ranges {knob_ranges(policy_knobs)} differ from the env's "
            f"{knob_ranges(env_knobs)}: its actions would set other values; build the env with the "
            "policy's ranges (ranges=...)"
        )
    binding = policy_capability(policy, PolicyCapability.BINDS_ENV)
    if binding is not None:
        binding.bind(env)
    obs, info = env.reset(seed=seed)
    total, knobs, errors, sensor = 0.0, [], [], []
    while True:
        action, _ = policy.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, info = env.step(action)
        total += float(reward)
        knobs.append(info["knobs"])
        errors.append(int(info["association_errors"]))
        if "sensor" in info:
            sensor.append(info["sensor"])
        if terminated or truncated:
            break
    return {
        "errors": errors[-1],
        "return": total,
        "knobs": knobs,
        "errors_so_far": errors,
        "sensor": sensor,
    }


def evaluate(
    policies: Mapping[str, Any],
    seeds: Sequence[int],
    env_kwargs: Mapping[str, Any] | None = None,
    workers: int = 1,
) -> dict[str, list[int]]:
    """Errors per seed of each policy (same episodes for all).

    ``workers > 1`` plays the (policy, seed) episodes in that many processes (the policies must
    pickle); the result is the same as with one.
    """
    tasks = [(name, s) for name in policies for s in seeds]
    errors = play_episodes([(policies[n], s, env_kwargs) for n, s in tasks], workers=workers)
    out: dict[str, list[int]] = {name: [] for name in policies}
    for (name, _), e in zip(tasks, errors, strict=True):
        out[name].append(e)
    return out


def play_episodes(tasks: Sequence[tuple[Any, int, Mapping[str, Any] | None]], workers: int = 1) -> list[int]:
    """The errors of each ``(policy, seed, env_kwargs)`` episode, in order.

    Each distinct ``env_kwargs`` builds one GateTuning-v0 per process; ``workers > 1`` plays the
    episodes in that many processes (the policies must pickle), with the same result as one.
    """
    workers = check_int("workers", workers, 1)
    if workers == 1:
        envs: dict[str, gym.Env] = {}
        try:
            return [_episode_on(envs, policy, seed, kwargs) for policy, seed, kwargs in tasks]
        finally:
            for env in envs.values():
                env.close()
    import concurrent.futures as cf
    import multiprocessing as mp

    with cf.ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn")) as pool:
        futures = [pool.submit(_episode_task, policy, seed, kwargs) for policy, seed, kwargs in tasks]
        return [f.result() for f in futures]


#: Envs of distinct kwargs kept per process by [`play_episodes`][track_apps.tuning.evaluate.play_episodes].
_MAX_CACHED_ENVS = 4
#: The env of each kwargs in a worker process of [`evaluate`][track_apps.tuning.evaluate.evaluate] (built once
#: per process).
_WORKER_ENVS: dict[str, gym.Env] = {}


def _episode_task(policy: Any, seed: int, env_kwargs: Mapping[str, Any] | None) -> int:
    """The errors of one episode in a worker process, on the process's env of those kwargs."""
    return _episode_on(_WORKER_ENVS, policy, seed, env_kwargs)


def _episode_on(
    envs: dict[str, gym.Env], policy: Any, seed: int, env_kwargs: Mapping[str, Any] | None
) -> int:
    """The errors of one episode on the env of ``envs`` built with ``env_kwargs`` (built once)."""
    key = json.dumps(dict(env_kwargs or {}), sort_keys=True, default=str)
    if key not in envs:
        if len(envs) >= _MAX_CACHED_ENVS:  # the oldest goes (tasks come grouped by kwargs)
            envs.pop(next(iter(envs))).close()
        envs[key] = gym.make("GateTuning-v0", **dict(env_kwargs or {}))
    return int(episode_errors(envs[key], policy, seed)["errors"])


def paired(a: Sequence[float], b: Sequence[float]) -> dict[str, float]:
    """Paired comparison of A against B (module docstring); negative differences favour A."""
    from scipy.stats import wilcoxon

    x, y = np.asarray(a, float), np.asarray(b, float)
    d = x - y
    p = float(wilcoxon(x, y).pvalue) if np.any(d != 0) else 1.0
    mean_b = float(y.mean())
    return {
        "mean_a": float(x.mean()),
        "std_a": float(x.std(ddof=1)) if len(x) > 1 else 0.0,
        "mean_b": mean_b,
        "std_b": float(y.std(ddof=1)) if len(y) > 1 else 0.0,
        "mean_diff": float(d.mean()),
        "std_diff": float(d.std(ddof=1)) if len(d) > 1 else 0.0,
        "improvement": (mean_b - float(x.mean())) / mean_b if mean_b else 0.0,
        "wins": int(np.count_nonzero(d < 0)),
        "losses": int(np.count_nonzero(d > 0)),
        "n": len(d),
        "wilcoxon_p": p,
    }


def grid_settings(grid: Mapping[str, Sequence[float]] | None = None) -> list[dict[str, float]]:
    """Every combination of the grid's knob values."""
    g = dict(grid or GRID)
    return [dict(zip(g, values, strict=True)) for values in itertools.product(*g.values())]


def grid_suite(
    seeds: Sequence[int],
    steps: int,
    drift: str | None = "belt",
    predictor: str = "kf-ca",
    grid: Mapping[str, Sequence[float]] | None = None,
) -> str:
    """The ``track bench`` suite (TOML) of the grid: one group per setting, BeltSorter-v0 with
    ``drift`` and GateTuning-v0's ``max_tracks`` and ``max_targets`` for ``steps`` frames on
    ``seeds`` (the episodes GateTuning-v0 plays with that constant setting from the same seeds)."""
    lines = ["# the fixed-setting grid of GateTuning-v0 (written by track tune grid-suite)"]
    env_kwargs = (
        f'{{ drift = "{drift}", max_tracks = {BASE_MAX_TRACKS}, max_targets = {BASE_MAX_TARGETS} }}'
        if drift
        else f"{{ max_tracks = {BASE_MAX_TRACKS}, max_targets = {BASE_MAX_TARGETS} }}"
    )
    for setting in grid_settings(grid):
        knobs = ", ".join(f"{k} = {v!r}" for k, v in setting.items())
        lines += [
            "",
            "[[group]]",
            'envs = ["BeltSorter-v0"]',
            'agents = ["gnn"]',
            f'predictors = ["{predictor}"]',
            f"seeds = {list(seeds)}",
            f"steps = {steps}",
            f"env_kwargs = {env_kwargs}",
            f"agent_kwargs = {{ {knobs}, predict_sorting = false }}",
        ]
    return "\n".join(lines) + "\n"


def record_errors(record: Mapping[str, Any]) -> int:
    """``E`` of a ``track bench`` record (its e1, e2, n_tracks, n_particles)."""
    m = record["metrics"]
    return round(float(m["e1"]) * float(m["n_tracks"])) + round(float(m["e2"]) * float(m["n_particles"]))


def best_fixed(records: Iterable[Mapping[str, Any]], knobs: Sequence[str] = tuple(GRID)) -> dict[str, Any]:
    """The setting with the fewest mean errors over the seeds of the records, and the table.

    Raises:
        ValueError: without records, or when settings have different seed sets.
    """
    table: dict[tuple[tuple[str, float], ...], dict[int, int]] = {}
    for rec in records:
        cell = rec["cell"]
        kwargs = dict(cell.get("agent_kwargs", {}))
        key = tuple((k, float(kwargs[k])) for k in knobs if k in kwargs)
        table.setdefault(key, {})[int(cell["seed"])] = record_errors(rec)
    if not table:
        raise ValueError("no track bench records of the grid")
    seed_sets = {tuple(sorted(v)) for v in table.values()}
    if len(seed_sets) != 1:
        raise ValueError(f"the grid's settings ran on different seeds: {sorted(seed_sets)}")
    rows = [
        {"setting": dict(k), "mean": float(np.mean(list(v.values()))), "std": _std(list(v.values()))}
        for k, v in table.items()
    ]
    rows.sort(key=lambda r: float(r["mean"]))  # type: ignore[arg-type]
    return {"best": rows[0]["setting"], "seeds": list(next(iter(seed_sets))), "rows": rows}


def read_records(out: str | Path) -> list[dict[str, Any]]:
    """The JSON records of a ``track bench`` out dir."""
    records = []
    for path in sorted(Path(out).glob("*.json")):
        data = json.loads(path.read_text())
        if isinstance(data, dict) and "cell" in data and "metrics" in data:
            records.append(data)
    return records


def format_comparison(name_a: str, name_b: str, r: Mapping[str, float]) -> str:
    """One line of a paired comparison."""
    return (
        f"{name_a} vs {name_b}: {r['mean_a']:.1f} ± {r['std_a']:.1f} vs {r['mean_b']:.1f} ± {r['std_b']:.1f} "
        f"errors/episode, paired diff {r['mean_diff']:+.1f} ± {r['std_diff']:.1f} "
        f"({100 * r['improvement']:+.1f}% fewer), wins {r['wins']}/{r['n']} (losses {r['losses']}), "
        f"Wilcoxon p = {r['wilcoxon_p']:.3g}"
    )


def _std(values: list[int]) -> float:
    return float(np.std(values, ddof=1)) if len(values) > 1 else 0.0
