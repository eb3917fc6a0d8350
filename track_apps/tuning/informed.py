"""A sensor-informed reference for GateTuning-v0: the best fixed setting for the true sensor of
the moment.

How much is *following the drift* worth? If the knobs that minimise the association errors
depend on the sensor (noise std ``σ``, detection probability ``p_D``, clutter rate ``λ``), a
policy that tracks the sensor gains over the best fixed setting; if they do not, no estimate of
the sensor from the tracker's diagnostics can gain either. The
[`SensorInformedPolicy`][track_apps.tuning.SensorInformedPolicy] answers from above for that part of
adaptation: it reads the *true* sensor values of the last frame (truth side,
[`true_sensor`][track_apps.tuning.env.GateTuningEnv.true_sensor]) and sets the knobs a constant-sensor grid
found best there.

The grid ([`sensor_table`][track_apps.tuning.informed.sensor_table]): for every state ``x = (σ, p_D, λ)`` of a
regular grid over the drift's ranges and every setting ``k`` of a knob grid, episodes of GateTuning-v0 with
the sensor held at ``x`` and the knobs at ``k`` on training seeds give the mean errors ``E[x, k]``. Between
the states the table is interpolated multilinearly in ``(log σ, p_D, λ)`` and clamped at the
edges, ``Ê(x, k)``; the policy plays

.. math::

    k^*(x_t) = \\arg\\min_k \\hat E(x_t, k).

Unlike the [`LookaheadOracle`][track_apps.tuning.oracle.LookaheadOracle] it knows nothing of the future or of
the particles; it is the best a policy could do by following the sensor with per-state fixed
settings (up to the grid's resolution and what transients after a change cost).
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from track_apps.tuning.policy import FixedPolicy, SettingChooser
from track_envs.envs.drift import DRIFT_PRESETS, SensorValues
from track_envs.infra.atomic import write_text

#: The sensor parameters of a state, in the table's axis order.
SENSOR_AXES = SensorValues._fields  # ("noise_std", "p_detect", "clutter_rate")
#: Default knob grid of the table: around the belt's best fixed setting (0.7, 1, 32).
INFORMED_GRID: dict[str, tuple[float, ...]] = {
    "p_gate": (0.5, 0.7, 0.9, 0.99, 0.999),
    "recovery_inflation": (1.0, 25.0),
    "noise_scale": (4.0, 8.0, 16.0, 32.0, 64.0),
}
#: Format version of the table's JSON.
TABLE_VERSION = 1


def default_states(drift: str = "belt", n_noise: int = 5) -> dict[str, tuple[float, ...]]:
    """Grid axes over a drift preset's ranges: ``n_noise`` log-spaced noise stds from its low to
    its high, and the two ends of the detection probability and the clutter rate."""
    preset = DRIFT_PRESETS.get(drift)
    if preset is None:
        raise ValueError(f"unknown drift preset {drift!r}; the presets are {sorted(DRIFT_PRESETS)}")
    axes: dict[str, tuple[float, ...]] = {}
    for name in SENSOR_AXES:
        schedule = getattr(preset, name)
        if schedule is None:
            raise ValueError(f"drift preset {drift!r} does not drift {name}; give the states explicitly")
        lo, hi = float(schedule.low), float(schedule.high)
        if name == "noise_std":
            axes[name] = tuple(float(v) for v in np.geomspace(lo, hi, n_noise))
        else:
            axes[name] = (lo, hi) if hi > lo else (lo,)
    return axes


def constant_drift(noise_std: float, p_detect: float, clutter_rate: float) -> dict[str, Any]:
    """A ``drift`` holding the sensor at one state (steps between equal bounds)."""
    values = {"noise_std": noise_std, "p_detect": p_detect, "clutter_rate": clutter_rate}
    return {k: {"kind": "steps", "low": float(v), "high": float(v)} for k, v in values.items()}


@dataclass(frozen=True)
class SensorTable:
    """Mean errors of each knob setting at each constant sensor state (module docstring).

    Attributes:
        states: ``{parameter: increasing values}`` for the three
            [`SENSOR_AXES`][track_apps.tuning.informed.SENSOR_AXES].
        settings: The knob settings (``{knob: value}``), in the table's last axis.
        errors: Mean errors, shape ``(len(σ), len(p_D), len(λ), len(settings))``.
        seeds: The seeds each cell was played on.
        episode_steps: Steps of each episode.
    """

    states: Mapping[str, tuple[float, ...]]
    settings: Sequence[Mapping[str, float]]
    errors: NDArray[np.float64]
    seeds: tuple[int, ...]
    episode_steps: int

    def __post_init__(self) -> None:
        if tuple(self.states) != SENSOR_AXES:
            raise ValueError(
                f"the table's states must be {list(SENSOR_AXES)} in order, got {list(self.states)}"
            )
        for name, values in self.states.items():
            v = np.asarray(values, float)
            if len(v) == 0 or np.any(np.diff(v) <= 0) or not np.all(np.isfinite(v)):
                raise ValueError(f"states[{name!r}] must be finite and increasing, got {list(values)}")
        if min(self.states["noise_std"]) <= 0:
            raise ValueError(f"noise std states must be > 0 (log axis), got {list(self.states['noise_std'])}")
        shape = (*(len(v) for v in self.states.values()), len(self.settings))
        if len(self.settings) == 0 or np.shape(self.errors) != shape:
            raise ValueError(
                f"errors must have shape {shape} (states × settings), got {np.shape(self.errors)}"
            )

    def _axes(self) -> list[NDArray[np.float64]]:
        noise, p_detect, clutter = (np.asarray(self.states[k], float) for k in SENSOR_AXES)
        return [np.log(noise), p_detect, clutter]

    def expected_errors(self, sensor: Mapping[str, float]) -> NDArray[np.float64]:
        """``Ê(x, k)`` for every setting ``k`` at sensor ``x`` (multilinear in ``(log σ, p_D, λ)``,
        clamped to the grid)."""
        missing = [k for k in SENSOR_AXES if k not in sensor]
        if missing:
            raise ValueError(f"the sensor values lack {missing}; got {sorted(sensor)}")
        from scipy.interpolate import RegularGridInterpolator

        axes = self._axes()
        x = [math.log(max(float(sensor["noise_std"]), 1e-300)), float(sensor["p_detect"])]
        x.append(float(sensor["clutter_rate"]))
        clamped = [min(max(v, float(a[0])), float(a[-1])) for v, a in zip(x, axes, strict=True)]
        table = RegularGridInterpolator(axes, np.asarray(self.errors, float), method="linear")
        return np.asarray(table([clamped])[0], float)

    def best(self, sensor: Mapping[str, float]) -> int:
        """Index of the setting with the fewest expected errors at ``sensor`` (ties: the first)."""
        return int(np.argmin(self.expected_errors(sensor)))

    def to_dict(self) -> dict[str, Any]:
        """The table as JSON-ready data."""
        return {
            "version": TABLE_VERSION,
            "states": {k: list(v) for k, v in self.states.items()},
            "settings": [dict(s) for s in self.settings],
            "errors": np.asarray(self.errors, float).tolist(),
            "seeds": list(self.seeds),
            "episode_steps": self.episode_steps,
        }

    def save(self, path: str | Path) -> Path:
        """Write the table as JSON; returns the path."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text(path, json.dumps(self.to_dict(), indent=1) + "\n")
        return path

    @classmethod
    def load(cls, path: str | Path) -> SensorTable:
        """Read a table written by [`save`][track_apps.tuning.informed.SensorTable.save] (``ValueError``
        naming what is wrong)."""
        try:
            data = json.loads(Path(path).read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise ValueError(f"cannot read the sensor table {path}: {exc}") from None
        if not isinstance(data, dict) or data.get("version") != TABLE_VERSION:
            raise ValueError(
                f"{path} is not a sensor table of version {TABLE_VERSION} (track tune sensor-grid writes one)"
            )
        try:
            return cls(
                states={k: tuple(float(v) for v in data["states"][k]) for k in data["states"]},
                settings=[{k: float(v) for k, v in s.items()} for s in data["settings"]],
                errors=np.asarray(data["errors"], float),
                seeds=tuple(int(s) for s in data["seeds"]),
                episode_steps=int(data["episode_steps"]),
            )
        except (KeyError, TypeError, AttributeError) as exc:
            raise ValueError(f"{path}: malformed sensor table ({exc!r})") from None


def sensor_table(
    seeds: Sequence[int],
    episode_steps: int = 50,
    states: Mapping[str, Sequence[float]] | None = None,
    grid: Mapping[str, Sequence[float]] | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
    workers: int = 1,
) -> SensorTable:
    """Play the constant-sensor grid (module docstring) and return its table.

    Args:
        seeds: Training seeds of every cell (keep them below the held-out seeds).
        episode_steps: Steps of each episode.
        states: Sensor grid axes (default [`default_states`][track_apps.tuning.informed.default_states] of the
            ``"belt"`` drift).
        grid: Knob values (default [`INFORMED_GRID`][track_apps.tuning.informed.INFORMED_GRID]).
        env_kwargs: Further GateTuning-v0 kwargs (not ``drift``, which the states set).
        workers: Processes playing the episodes.
    """
    from track_apps.tuning.evaluate import grid_settings, play_episodes

    if not seeds:
        raise ValueError("the sensor grid needs at least one seed")
    kwargs = dict(env_kwargs or {})
    if "drift" in kwargs:
        raise ValueError("env_kwargs must not set 'drift': the sensor grid holds the sensor at each state")
    axes = {k: tuple(float(v) for v in (states or default_states())[k]) for k in SENSOR_AXES}
    settings = grid_settings(grid or INFORMED_GRID)
    policies = [FixedPolicy(s, ranges=kwargs.get("ranges")) for s in settings]
    cells = list(itertools.product(*axes.values()))
    tasks = [
        (policy, int(seed), {**kwargs, "episode_steps": episode_steps, "drift": constant_drift(*x)})
        for x in cells
        for policy in policies
        for seed in seeds
    ]
    errors = np.asarray(play_episodes(tasks, workers=workers), float)
    shape = (*(len(v) for v in axes.values()), len(settings), len(seeds))
    return SensorTable(axes, settings, errors.reshape(shape).mean(axis=-1), tuple(seeds), episode_steps)


class SensorInformedPolicy(SettingChooser):
    """Plays `SensorTable.best` for the bound env's true sensor
    (module docstring).

    Args:
        table: A `SensorTable`, or the path of one.

    Call `bind` with the env being played before the first
    `predict`;
    `track_apps.tuning.evaluate.evaluate` does so. The env must drift
    (report its sensor).
    """

    def __init__(self, table: SensorTable | str | Path):
        self.table = table if isinstance(table, SensorTable) else SensorTable.load(table)
        super().__init__(self.table.settings)

    def choose(self, env: Any) -> int:
        """The table's best setting for the true sensor of ``env``'s last frame.

        Raises:
            RuntimeError: when the env reports no sensor (built without drift).
        """
        sensor = env.true_sensor()
        if sensor is None:
            raise RuntimeError(
                "the env reports no true sensor values (built without drift): nothing to follow"
            )
        return self.table.best(sensor)
