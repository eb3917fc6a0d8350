"""One GateTuning-v0 episode, traced: the drifting sensor, the knobs each policy sets, its errors.

Plays the shipped PPO policy, a fixed setting and (with ``--table``, a table of
``track tune sensor-grid``) the sensor-informed reference on the same held-out episode, and plots
the true sensor (noise std, detection probability, clutter rate), the gate probability and noise
scale each policy set, and each policy's cumulative association errors::

    python examples/gate_tuning_trace.py --seed 1000000000 --png trace.png
    python examples/gate_tuning_trace.py --table results/sensor_table.json --png trace.png
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import track_apps.tuning
from track_apps.tuning import FixedPolicy, episode_errors, knob_ranges
from track_envs.io import save_figure

#: The best fixed setting of the 168-setting grid on training seeds 0-4 (docs/gate_tuning.md).
BEST_FIXED = {"p_gate": 0.7, "recovery_inflation": 1.0, "noise_scale": 32.0}


def trace(env: gym.Env, policy: Any, seed: int) -> dict[str, np.ndarray]:
    """One episode of ``policy`` from ``seed``: per step the true sensor of the window's last
    frame, the knobs set and the errors so far."""
    episode = episode_errors(env, policy, seed)
    rows = {k: np.array([s[k] for s in episode["sensor"]]) for k in ("noise_std", "p_detect", "clutter_rate")}
    rows |= {k: np.array([knobs[k] for knobs in episode["knobs"]]) for k in ("p_gate", "noise_scale")}
    rows["errors"] = np.asarray(episode["errors_so_far"])
    return rows


def plot(traces: dict[str, dict[str, np.ndarray]], path: Path, seed: int) -> None:
    """The four panels of the module docstring, written to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    first = next(iter(traces.values()))
    steps = np.arange(1, len(first["errors"]) + 1)
    fig, axes = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    ax = axes[0]
    ax.semilogy(steps, 1e3 * first["noise_std"], color="k", label="noise std (mm)")
    ax.set_ylabel("noise std (mm)")
    twin = ax.twinx()
    twin.plot(steps, first["clutter_rate"], color="tab:red", label="clutter / frame")
    twin.plot(steps, 10 * first["p_detect"], color="tab:green", label="10 × p_detect")
    twin.set_ylabel("clutter, 10 × p_detect")
    lines = ax.get_lines() + twin.get_lines()
    ax.legend(lines, [str(line.get_label()) for line in lines], fontsize=8, loc="upper left")
    ax.set_title(f"true sensor, held-out seed {seed}")
    for name, t in traces.items():
        axes[1].semilogy(steps, 1 - t["p_gate"], label=name)
        axes[2].semilogy(steps, t["noise_scale"], label=name)
        axes[3].plot(steps, t["errors"], label=f"{name}: {int(t['errors'][-1])}")
    axes[1].set_ylabel("1 − p_gate")
    axes[2].set_ylabel("noise scale")
    axes[3].set_ylabel("association errors so far")
    axes[3].set_xlabel("step (10 frames)")
    for ax in axes[1:]:
        ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, path, dpi=90)
    plt.close(fig)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--seed", type=int, default=1_000_000_000, help="episode seed (held out: ≥ 10⁹)")
    parser.add_argument("--steps", type=int, default=100, help="GateTuning-v0 steps of the episode")
    parser.add_argument("--table", default=None, help="sensor table for the informed reference")
    parser.add_argument("--png", default="gate_tuning_trace.png")
    args = parser.parse_args(argv)
    env = gym.make("GateTuning-v0", episode_steps=args.steps)
    ranges = knob_ranges(env.unwrapped.knobs)  # type: ignore[attr-defined]
    policies: dict[str, Any] = {
        "PPO": track_apps.tuning.load_policy(),
        "best fixed": FixedPolicy(BEST_FIXED, ranges=ranges),
    }
    if args.table:
        from track_apps.tuning import SensorInformedPolicy

        policies["sensor-informed"] = SensorInformedPolicy(args.table)
    traces = {name: trace(env, policy, args.seed) for name, policy in policies.items()}
    plot(traces, Path(args.png), args.seed)
    errors = {name: int(t["errors"][-1]) for name, t in traces.items()}
    for name, e in errors.items():
        print(f"{name:>16}: {e} association errors")
    print(f"wrote {args.png}")
    return {"errors": errors, "traces": traces, "png": args.png}


if __name__ == "__main__":
    main()
