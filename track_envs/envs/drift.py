"""Drifting sensors: the noise std, detection probability and clutter rate of a point sensor
following a schedule over an episode, while ``sensor_spec`` keeps the nominal values.

A tracker is told the sensor of ``sensor_spec`` once; a real sensor drifts (lighting, dirt on the
lens, a belt that carries dust). A [`SensorDrift`][track_envs.envs.SensorDrift] gives each of the three
parameters a schedule (or none: it stays nominal):

* [`Steps`][track_envs.envs.Steps] — piecewise constant. The value is held for
``H ~ Geometric(1 / mean_hold)``
  frames (mean ``mean_hold``), then jumps to a new value drawn uniformly in ``[low, high]``
  (log-uniformly with ``log=True``), independently of the old one.
* [`RandomWalk`][track_envs.envs.RandomWalk] — a bounded random walk. With ``u = x`` (or ``u = log x`` with
``log``),

  .. math::

      u_{t+1} = u_t + s\\,ε_t,\\quad ε_t \\sim N(0, 1), \\qquad
      x_t = \\operatorname{fold}(u_t),

  where ``fold`` reflects ``u`` into ``[u(low), u(high)]`` at both ends (a random walk with
  reflecting barriers: the value never leaves the range).

The first value of an episode is ``start`` when given, else uniform over the range (in ``u``).

Every draw comes from a generator seeded by one draw of the env's ``np_random`` at ``reset``, so
the same seed gives the same drift (and an env without drift draws nothing: its streams are
unchanged). The schedule is generated in blocks of [`BLOCK`][track_envs.envs.drift.BLOCK] frames, always in
the same order, so the value of frame ``t`` does not depend on when it is asked for; a pickled env carries
its drawn schedule ([`DriftProcess`][track_envs.envs.drift.DriftProcess]).

The envs report the true values of each frame in ``info["sensor"]`` (truth side).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.arguments import check_number, check_positive

__all__ = [
    "BLOCK",
    "DRIFT_PRESETS",
    "DriftProcess",
    "RandomWalk",
    "SensorDrift",
    "SensorValues",
    "Steps",
    "resolve_drift",
]

#: Frames of schedule drawn at a time.
BLOCK = 256

#: Valid range of each drifting parameter (closed), for the checks.
_VALID = {"noise_std": (0.0, math.inf), "p_detect": (0.0, 1.0), "clutter_rate": (0.0, math.inf)}


class SensorValues(NamedTuple):
    """The true sensor parameters of one frame."""

    noise_std: float
    p_detect: float
    clutter_rate: float


def _check_range(name: str, low: Any, high: Any, log: bool) -> tuple[float, float]:
    lo, hi = check_number(f"{name}.low", low), check_number(f"{name}.high", high)
    if hi < lo:
        raise ValueError(f"{name}: high must be >= low, got low={low!r}, high={high!r}")
    if log and lo <= 0:
        raise ValueError(f"{name}: a log-scaled schedule needs low > 0, got low={low!r}")
    return lo, hi


@dataclass(frozen=True)
class Steps:
    """Piecewise-constant schedule (module docstring).

    Attributes:
        low, high: Range of the values, low <= high.
        mean_hold: Mean frames a value is held (geometric holding times), >= 1.
        log: Draw new values log-uniformly (needs low > 0).
        start: First value of an episode (in the range); None: drawn like every other.
    """

    low: float
    high: float
    mean_hold: float = 200.0
    log: bool = False
    start: float | None = None

    def checked(self, name: str) -> Steps:
        """This schedule after checking it for parameter ``name`` (``ValueError`` naming it)."""
        lo, hi = _check_range(name, self.low, self.high, self.log)
        hold = check_number(f"{name}.mean_hold", self.mean_hold)
        if hold < 1:
            raise ValueError(f"{name}.mean_hold must be >= 1 frame, got {self.mean_hold!r}")
        return Steps(lo, hi, hold, bool(self.log), _checked_start(name, self.start, lo, hi))


@dataclass(frozen=True)
class RandomWalk:
    """Bounded random walk (module docstring).

    Attributes:
        low, high: Range of the values (reflecting barriers), low <= high.
        step: Std ``s`` of one frame's step in ``u`` (the value, or its log with ``log``), > 0.
        log: Walk in ``log x`` (needs low > 0).
        start: First value of an episode (in the range); None: uniform over the range.
    """

    low: float
    high: float
    step: float = 0.01
    log: bool = False
    start: float | None = None

    def checked(self, name: str) -> RandomWalk:
        """This schedule after checking it for parameter ``name`` (``ValueError`` naming it)."""
        lo, hi = _check_range(name, self.low, self.high, self.log)
        step = check_positive(f"{name}.step", self.step)
        return RandomWalk(lo, hi, step, bool(self.log), _checked_start(name, self.start, lo, hi))


Schedule = Steps | RandomWalk
SCHEDULES: dict[str, type[Steps] | type[RandomWalk]] = {"steps": Steps, "walk": RandomWalk}


def _checked_start(name: str, start: float | None, lo: float, hi: float) -> float | None:
    if start is None:
        return None
    s = check_number(f"{name}.start", start)
    if not lo <= s <= hi:
        raise ValueError(f"{name}.start must lie in [low, high] = [{lo}, {hi}], got {start!r}")
    return s


@dataclass(frozen=True)
class SensorDrift:
    """Schedules of the sensor's noise std, detection probability and clutter rate.

    A parameter without a schedule (None) stays at its nominal value. Values are absolute, in the
    env's units: ``noise_std`` in sensor units (the noise the env adds), ``p_detect`` in [0, 1],
    ``clutter_rate`` in detections per frame.

    Build one directly, from a mapping (``{"noise_std": {"kind": "steps", "low": 5e-5, "high":
    1e-3, "log": True}}``, kinds `SCHEDULES`) or by a name of
    `DRIFT_PRESETS`; see
    [`resolve_drift`][track_envs.envs.resolve_drift].
    """

    noise_std: Schedule | None = None
    p_detect: Schedule | None = None
    clutter_rate: Schedule | None = None

    def checked(self) -> SensorDrift:
        """This drift with every schedule checked against its parameter's valid range."""
        out: dict[str, Schedule | None] = {}
        for f in fields(self):
            schedule = getattr(self, f.name)
            if schedule is None:
                out[f.name] = None
                continue
            if not isinstance(schedule, Steps | RandomWalk):
                raise ValueError(
                    f"drift.{f.name} must be a Steps or RandomWalk schedule or None, got {schedule!r}"
                )
            s = schedule.checked(f"drift.{f.name}")
            lo, hi = _VALID[f.name]
            if s.low < lo or s.high > hi:
                raise ValueError(
                    f"drift.{f.name} range [{s.low}, {s.high}] leaves the valid range [{lo}, {hi}]"
                )
            out[f.name] = s
        return SensorDrift(**out)

    def highest(self, name: str, nominal: float) -> float:
        """The largest value parameter ``name`` can take (``nominal`` without a schedule)."""
        schedule = getattr(self, name)
        return nominal if schedule is None else float(schedule.high)


#: Named drifts, for ``drift="name"`` (CLI values and suite files).
DRIFT_PRESETS: dict[str, SensorDrift] = {
    # the belt camera (BeltSorter-v0, noise 0.1 mm nominal): noise steps between 0.05 and 1 mm
    # (Pollithy et al. 2020 sweep 0-0.5 mm), detections fading down to 85%, dust at up to 10
    # clutter points per frame; the default drift of GateTuning-v0.
    "belt": SensorDrift(
        noise_std=Steps(5e-5, 1e-3, mean_hold=200.0, log=True),
        p_detect=RandomWalk(0.85, 1.0, step=0.01),
        clutter_rate=Steps(0.0, 10.0, mean_hold=300.0),
    ),
}


def _schedule_from_mapping(name: str, data: Mapping[str, Any]) -> Schedule:
    kind = data.get("kind")
    if kind not in SCHEDULES:
        raise ValueError(f"drift.{name}: 'kind' must be one of {sorted(SCHEDULES)}, got {kind!r}")
    cls = SCHEDULES[kind]
    allowed = [f.name for f in fields(cls)]
    unknown = sorted(set(data) - {"kind", *allowed})
    if unknown:
        raise ValueError(f"drift.{name} ({kind}) has no field {unknown}; its fields are {allowed}")
    return cls(**{k: v for k, v in data.items() if k != "kind"})


def resolve_drift(drift: SensorDrift | Mapping[str, Any] | str | None) -> SensorDrift | None:
    """A checked [`SensorDrift`][track_envs.envs.SensorDrift] from a drift, a mapping, a preset name, or None.

    Raises:
        ValueError: for an unknown preset (listing them), an unknown parameter or schedule kind,
            or a schedule outside its parameter's valid range.
    """
    if drift is None:
        return None
    if isinstance(drift, str):
        if drift not in DRIFT_PRESETS:
            raise ValueError(f"unknown drift preset {drift!r}; valid names are {sorted(DRIFT_PRESETS)}")
        return DRIFT_PRESETS[drift].checked()
    if isinstance(drift, SensorDrift):
        return drift.checked()
    if isinstance(drift, Mapping):
        unknown = sorted(set(drift) - set(_VALID))
        if unknown:
            raise ValueError(f"drift has no parameter {unknown}; drifting parameters are {sorted(_VALID)}")
        built = {
            k: v if isinstance(v, Steps | RandomWalk) or v is None else _schedule_from_mapping(k, v)
            for k, v in drift.items()
        }
        return SensorDrift(**built).checked()
    raise ValueError(
        f"drift must be a SensorDrift, a mapping, a preset name {sorted(DRIFT_PRESETS)} or None, "
        f"got {drift!r}"
    )


class _Stream:
    """The values of one parameter, drawn block by block from its own generator."""

    def __init__(self, schedule: Schedule, rng: np.random.Generator):
        self.schedule, self.rng = schedule, rng
        s = schedule
        self._lo, self._hi = (math.log(s.low), math.log(s.high)) if s.log else (s.low, s.high)
        self._u = self._to_u(s.start) if s.start is not None else self._draw_u()
        self._remaining = int(rng.geometric(1.0 / s.mean_hold)) if isinstance(s, Steps) else 0

    def _to_u(self, x: float) -> float:
        return math.log(x) if self.schedule.log else x

    def _draw_u(self) -> float:
        return float(self._lo + (self._hi - self._lo) * self.rng.random())

    def _from_u(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        x = np.exp(u) if self.schedule.log else u
        return np.clip(x, self.schedule.low, self.schedule.high)  # exp(log x) may round past x

    def block(self, n: int) -> NDArray[np.float64]:
        """The next ``n`` frames' values."""
        if isinstance(self.schedule, Steps):
            return self._from_u(self._steps(n))
        width = self._hi - self._lo
        u = self._u + np.cumsum(self.schedule.step * self.rng.standard_normal(n))
        self._u = float(u[-1])
        if width == 0:
            return self._from_u(np.full(n, self._lo))
        y = np.mod(u - self._lo, 2 * width)  # reflect at both barriers
        return self._from_u(self._lo + np.where(y > width, 2 * width - y, y))

    def _steps(self, n: int) -> NDArray[np.float64]:
        assert isinstance(self.schedule, Steps)
        out = np.empty(n)
        filled = 0
        while filled < n:  # one pass per held value: a few per block
            if self._remaining == 0:
                self._u = self._draw_u()
                self._remaining = int(self.rng.geometric(1.0 / self.schedule.mean_hold))
            take = min(self._remaining, n - filled)
            out[filled : filled + take] = self._u
            filled += take
            self._remaining -= take
        return out


class DriftProcess:
    """The drawn drift of one episode: the true sensor values of every frame.

    Args:
        drift: A checked [`SensorDrift`][track_envs.envs.SensorDrift].
        nominal: The values of the parameters without a schedule.
        seed: Seed of the episode's drift (one draw of the env's ``np_random``).
    """

    def __init__(self, drift: SensorDrift, nominal: SensorValues, seed: int):
        self.nominal = nominal
        children = np.random.SeedSequence(seed).spawn(len(SensorValues._fields))
        self._streams: dict[str, _Stream] = {}
        for name, child in zip(SensorValues._fields, children, strict=True):
            schedule = getattr(drift, name)
            if schedule is not None:
                self._streams[name] = _Stream(schedule, np.random.default_rng(child))
        self._values = np.empty((len(SensorValues._fields), 0))

    def values(self, n: int) -> NDArray[np.float64]:
        """(3, n) values of frames ``0 .. n-1`` (rows: noise_std, p_detect, clutter_rate)."""
        while self._values.shape[1] < n:
            block = np.empty((len(SensorValues._fields), BLOCK))
            for row, name in enumerate(SensorValues._fields):
                stream = self._streams.get(name)
                block[row] = stream.block(BLOCK) if stream is not None else getattr(self.nominal, name)
            self._values = np.concatenate([self._values, block], axis=1)
        return self._values[:, :n]

    def at(self, frame: int) -> SensorValues:
        """The true sensor values of ``frame`` (>= 0)."""
        if frame < 0:
            raise ValueError(f"frame must be >= 0, got {frame}")
        column = self.values(frame + 1)[:, frame]
        return SensorValues(float(column[0]), float(column[1]), float(column[2]))
