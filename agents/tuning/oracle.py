"""A clairvoyant reference for GateTuning-v0: greedy lookahead on copies of the environment.

How much can *any* adaptation of the knobs gain over the best fixed setting? The
:class:`LookaheadOracle` answers from above: before every step it copies the running
environment (base env with its drawn drift, tracker, metric), plays each candidate setting on a
copy for ``horizon`` steps, and takes the setting whose copy collected the highest reward (the
fewest new association errors) — a choice that uses the truth and the future, which no real
tracker has. It is a greedy (receding-horizon) search, not the optimal adaptive policy, so it
bounds the attainable gain only approximately; but a learnt policy that sees only tracker
diagnostics is not expected to do better than it.

Cost: ``len(candidates) · horizon`` extra steps plus one deep copy per candidate and step (with
the 18 default candidates and ``horizon = 2``, ≈6 minutes per 1,000-frame belt episode on one
core).
"""

from __future__ import annotations

import copy
import itertools
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.tuning.knobs import knob_ranges
from agents.tuning.policy import FixedPolicy
from track_envs.arguments import check_int

#: The default candidate settings: 3 gate probabilities × second chance off / default × 3 scales,
#: around the best fixed settings of the belt with drift.
ORACLE_GRID: dict[str, tuple[float, ...]] = {
    "p_gate": (0.7, 0.9, 0.99),
    "recovery_inflation": (1.0, 25.0),
    "noise_scale": (8.0, 16.0, 32.0),
}


class LookaheadOracle:
    """Greedy lookahead over candidate settings on copies of a bound GateTuning-v0 (module doc).

    Args:
        candidates: Knob settings to choose from (default: every combination of
            :data:`ORACLE_GRID`); knobs a setting omits keep their initial values.
        horizon: Steps each candidate is played ahead (≥ 1).

    Call :meth:`bind` with the (unwrapped) environment being played before the first
    :meth:`predict`; :func:`agents.tuning.evaluate.evaluate` does so.
    """

    needs_env = True

    def __init__(self, candidates: Sequence[Mapping[str, float]] | None = None, horizon: int = 2):
        if candidates is None:
            candidates = [
                dict(zip(ORACLE_GRID, v, strict=True)) for v in itertools.product(*ORACLE_GRID.values())
            ]
        self.candidates = [dict(c) for c in candidates]
        if not self.candidates:
            raise ValueError("the oracle needs at least one candidate setting")
        self.horizon = check_int("horizon", horizon, 1)
        self._env: Any = None
        self._actions: list[NDArray[np.float32]] = []
        self.choices: list[int] = []

    def bind(self, env: Any) -> LookaheadOracle:
        """Play against ``env`` (a :class:`~agents.tuning.env.GateTuningEnv`); returns self."""
        env = getattr(env, "unwrapped", env)
        initial = {k.name: k.value(float(a)) for k, a in zip(env.knobs, env.initial_action, strict=True)}
        ranges = knob_ranges(env.knobs)
        actions = [FixedPolicy(c, defaults=initial, ranges=ranges).action for c in self.candidates]
        self._env, self._actions, self.choices = env, actions, []
        return self

    def predict(
        self,
        observation: NDArray[np.floating],
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.float32], None]:
        """The candidate whose ``horizon``-step lookahead from the bound env's state scores best.

        Raises:
            RuntimeError: before :meth:`bind`.
        """
        if self._env is None:
            raise RuntimeError("LookaheadOracle.predict before bind(env): bind it to the env it plays")
        returns = [self._lookahead(a) for a in self._actions]
        best = int(np.argmax(returns))  # ties: the first candidate
        self.choices.append(best)
        return self._actions[best].copy(), None

    def _lookahead(self, action: NDArray[np.float32]) -> float:
        twin = copy.deepcopy(self._env)
        total = 0.0
        for _ in range(self.horizon):
            _, reward, terminated, truncated, _ = twin.step(action)
            total += float(reward)
            if terminated or truncated:
                break
        return total
