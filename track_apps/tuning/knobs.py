"""The tracker's association knobs as a normalised action: ranges, log scales and checks.

An action ``a ∈ [-1, 1]^K`` sets ``K`` knobs of a running [`GnnAgent`][agents.gnn.agent.GnnAgent]. Knob
``k`` with range ``[low, high]`` on the scale ``u`` takes

.. math::

    v = u^{-1}\\big(u(\\text{low}) + \\tfrac{a + 1}{2}\\,(u(\\text{high}) - u(\\text{low}))\\big),

with ``u = log v`` (``"log"``: recovery inflation, noise scale) or ``u = log(1 − v)``
(``"log-miss"``: the gate probability, whose miss probability ``1 − p_gate`` spans decades). So
``a = -1`` is ``low``, ``a = 1`` is ``high`` and equal steps of ``a`` are equal factors.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.tracking.knobs import LIVE_KNOBS

#: The scale of each knob (its valid values are the tracker's,
#: [`agents.tracking.knobs.LIVE_KNOBS`][agents.tracking.knobs.LIVE_KNOBS]).
SCALES = {"p_gate": "log-miss", "recovery_inflation": "log", "noise_scale": "log"}
#: Default ranges: gate misses 0.5 … 1e-6, second-chance scale 1 (off) … 1000, noise ×0.25 … ×64.
#: (The best fixed setting of the belt with drift, p_gate 0.7 and noise ×32, lies inside.)
DEFAULT_RANGES: dict[str, tuple[float, float]] = {
    "p_gate": (0.5, 0.999999),
    "recovery_inflation": (1.0, 1000.0),
    "noise_scale": (0.25, 64.0),
}


@dataclass(frozen=True)
class Knob:
    """One tracker knob with its range (module docstring).

    Attributes:
        name: The `GnnAgent` attribute (``p_gate``, ``recovery_inflation``,
            ``noise_scale``).
        low, high: Its range, ``low < high``.
    """

    name: str
    low: float
    high: float

    @property
    def scale(self) -> str:
        """``"log"`` or ``"log-miss"``."""
        return SCALES[self.name]

    def _u(self, v: float | NDArray[np.float64]) -> Any:
        return np.log1p(-np.asarray(v)) if self.scale == "log-miss" else np.log(v)

    def _v(self, u: float | NDArray[np.float64]) -> Any:
        return -np.expm1(u) if self.scale == "log-miss" else np.exp(u)

    def value(self, a: float) -> float:
        """The knob's value for the normalised action ``a`` in [-1, 1]."""
        lo, hi = self._u(self.low), self._u(self.high)
        v = float(self._v(lo + 0.5 * (float(a) + 1.0) * (hi - lo)))
        return min(max(v, self.low), self.high)  # exp and log1p round a hair past the ends

    def action(self, value: float) -> float:
        """The normalised action in [-1, 1] that gives ``value`` (clipped to the range)."""
        v = min(max(float(value), self.low), self.high)
        lo, hi = self._u(self.low), self._u(self.high)
        return float(np.clip(2.0 * (self._u(v) - lo) / (hi - lo) - 1.0, -1.0, 1.0))


def make_knobs(ranges: Mapping[str, Sequence[float]] | None = None) -> tuple[Knob, ...]:
    """The knobs of `DEFAULT_RANGES` with ``ranges`` overriding
    some, in that order.

    Raises:
        ValueError: for an unknown knob name (listing the valid ones) or a range that is not
            ``(low, high)`` with ``low < high`` inside the knob's valid values.
    """
    given = dict(ranges or {})
    unknown = sorted(set(given) - set(DEFAULT_RANGES))
    if unknown:
        raise ValueError(f"unknown knob {unknown}; the knobs are {list(DEFAULT_RANGES)}")
    knobs = []
    for name, default in DEFAULT_RANGES.items():
        pair = given.get(name, default)
        if not (isinstance(pair, Sequence) and len(pair) == 2) or isinstance(pair, str):
            raise ValueError(f"range of {name} must be (low, high), got {pair!r}")
        lo, hi = pair
        valid, ok = LIVE_KNOBS[name].valid, LIVE_KNOBS[name].accepts
        for end in (lo, hi):
            real = isinstance(end, int | float | np.integer | np.floating) and not isinstance(end, bool)
            if not (real and ok(float(end))):
                raise ValueError(f"range of {name}: each end must be {valid}, got {pair!r}")
        if not float(lo) < float(hi):
            raise ValueError(f"range of {name} must have low < high, got {pair!r}")
        knobs.append(Knob(name, float(lo), float(hi)))
    return tuple(knobs)


def knob_ranges(knobs: Sequence[Knob]) -> dict[str, tuple[float, float]]:
    """``{name: (low, high)}`` of ``knobs``: the ``ranges=`` that builds them again."""
    return {k.name: (k.low, k.high) for k in knobs}


def check_action(action: Any, n_knobs: int) -> NDArray[np.float64]:
    """``action`` as a float64 vector of ``n_knobs`` entries in [-1, 1].

    Raises:
        ValueError: naming the shape, dtype or the entries outside [-1, 1] or not finite.
    """
    try:
        a = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"action must be a numeric array of shape ({n_knobs},), got {action!r}") from None
    if a.shape != (n_knobs,):
        raise ValueError(f"action must have shape ({n_knobs},) (one entry per knob), got shape {a.shape}")
    bad = ~np.isfinite(a) | (np.abs(a) > 1.0 + 1e-6)
    if bad.any():
        raise ValueError(
            f"action entries must be finite and in [-1, 1], got {a[bad].tolist()} "
            f"at {np.flatnonzero(bad).tolist()}"
        )
    return np.clip(a, -1.0, 1.0)
