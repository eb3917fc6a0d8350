"""A clairvoyant reference for GateTuning-v0: greedy lookahead on copies of the environment.

How much can *any* adaptation of the knobs gain over the best fixed setting? The
[`LookaheadOracle`][track_apps.tuning.oracle.LookaheadOracle] answers from above: before every step it copies
the running environment (base env with its drawn drift, tracker, metric), plays each candidate setting on a
copy for ``horizon`` steps, and takes the setting whose copy collected the highest reward (the
fewest new association errors) — a choice that uses the truth and the future, which no real
tracker has. It is a greedy (receding-horizon) search, not the optimal adaptive policy, so it
bounds the attainable gain only approximately; but a learnt policy that sees only tracker
diagnostics is not expected to do better than it.

With ``resample_future=True`` the copies play *another* future: before its lookahead every copy's
base-env generator is reseeded (the same fresh seed for all candidates of a step, so they are
compared on one common random future). The choice then knows the whole present — particles,
tracks, the true sensor — but not the detections to come; what this oracle gains over the best
fixed setting is what knowing the present is worth, and the difference to the clairvoyant one is
what foresight of the actual noise and clutter is worth. (The drift's schedule is drawn ahead in
blocks, so a copy still sees the true sensor of the next frames: the drift is slow, a change
falls in a 20-frame lookahead about once in ten.)

Cost: ``len(candidates) · horizon`` extra steps plus one deep copy per candidate and step (with
the 18 default candidates and ``horizon = 2``, ≈6 minutes per 1,000-frame belt episode on one
core).
"""

from __future__ import annotations

import copy
import itertools
from collections.abc import Mapping, Sequence
from typing import Any, Self

import numpy as np
from numpy.typing import NDArray

from track_apps.tuning.policy import SettingChooser
from track_envs.infra.arguments import check_int

#: The default candidate settings: 3 gate probabilities × second chance off / default × 3 scales,
#: around the best fixed settings of the belt with drift.
ORACLE_GRID: dict[str, tuple[float, ...]] = {
    "p_gate": (0.7, 0.9, 0.99),
    "recovery_inflation": (1.0, 25.0),
    "noise_scale": (8.0, 16.0, 32.0),
}


class LookaheadOracle(SettingChooser):
    """Greedy lookahead over candidate settings on copies of a bound GateTuning-v0 (module doc).

    Args:
        candidates: Knob settings to choose from (default: every combination of
            [`ORACLE_GRID`][track_apps.tuning.oracle.ORACLE_GRID]); knobs a setting omits keep their initial
            values.
        horizon: Steps each candidate is played ahead (≥ 1).
        resample_future: Play the copies on a fresh random future (module docstring).
        seed: Seed of the fresh futures (with ``resample_future``).
        futures: Fresh futures each candidate is played on per step, its return averaged (with
            ``resample_future``; ≥ 1): more sharpen the choice, at that many times the cost.

    Call [`bind`][track_apps.tuning.oracle.LookaheadOracle.bind] with the environment being played before the
    first [`predict`][track_apps.tuning.policy.SettingChooser.predict];
    [`track_apps.tuning.evaluate.evaluate`][track_apps.tuning.evaluate.evaluate] does so.
    """

    def __init__(
        self,
        candidates: Sequence[Mapping[str, float]] | None = None,
        horizon: int = 2,
        resample_future: bool = False,
        seed: int = 0,
        futures: int = 1,
    ):
        if candidates is None:
            candidates = [
                dict(zip(ORACLE_GRID, v, strict=True)) for v in itertools.product(*ORACLE_GRID.values())
            ]
        super().__init__(candidates)
        self.horizon = check_int("horizon", horizon, 1)
        self.resample_future = bool(resample_future)
        self.seed = check_int("seed", seed, 0)
        self.futures = check_int("futures", futures, 1)
        self._futures = np.random.default_rng(self.seed)

    @property
    def candidates(self) -> list[dict[str, float]]:
        """The candidate settings."""
        return self.settings

    def bind(self, env: Any) -> Self:
        """Play against ``env``, with the fresh futures' generator restarted; returns self."""
        self._futures = np.random.default_rng(self.seed)
        return super().bind(env)

    def choose(self, env: Any) -> int:
        """The candidate whose ``horizon``-step lookahead from ``env``'s state scores best (ties:
        the first)."""
        if not self.resample_future:
            return int(np.argmax([self._lookahead(a, None) for a in self._actions]))
        seeds = [int(s) for s in self._futures.integers(2**63 - 1, size=self.futures)]
        returns = [np.mean([self._lookahead(a, s) for s in seeds]) for a in self._actions]
        return int(np.argmax(returns))

    def _lookahead(self, action: NDArray[np.float32], future: int | None) -> float:
        twin = copy.deepcopy(self._env)
        if future is not None:
            reseed_in_place(twin.base.unwrapped.np_random, future)
        total = 0.0
        for _ in range(self.horizon):
            _, reward, terminated, truncated, _ = twin.step(action)
            total += float(reward)
            if terminated or truncated:
                break
        return total


def reseed_in_place(generator: np.random.Generator, seed: int) -> None:
    """Give ``generator`` the state of a fresh bit generator of its kind seeded with ``seed``, in
    place (so every holder of the object — the env, its world, its sensor — draws the new stream)."""
    bit_generator = generator.bit_generator
    bit_generator.state = type(bit_generator)(seed).state
