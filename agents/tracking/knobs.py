"""The point trackers' live knobs (gnn, jpda): the settings that may change between frames, with
their defaults and valid values.

[`GnnAgent`][agents.gnn.agent.GnnAgent] takes its defaults from here and checks a new value with
[`LiveKnob.check`][agents.tracking.knobs.LiveKnob.check]; the gate tuning
([`track_apps.tuning`][track_apps.tuning]) reads the same table for its action ranges and its fixed baselines,
so neither restates a number of the other.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LiveKnob:
    """A setting of the gnn tracker that may change between frames.

    Attributes:
        name: The [`GnnAgent`][agents.gnn.agent.GnnAgent] argument and attribute.
        default: Its default value.
        valid: Its valid values in words (for error messages), e.g. ``"a finite number >= 1"``.
        accepts: Whether a real number is valid.
    """

    name: str
    default: float
    valid: str
    accepts: Callable[[float], bool]

    def check(self, value: object) -> float:
        """``value`` as a float.

        Raises:
            ValueError: naming the knob and its valid values, if ``value`` is not a real number
                (bools are not) that [`accepts`][agents.tracking.knobs.LiveKnob.accepts] takes.
        """
        real = isinstance(value, int | float | np.integer | np.floating) and not isinstance(
            value, bool | np.bool_
        )
        if not (real and self.accepts(float(value))):  # type: ignore[arg-type]
            raise ValueError(f"{self.name} must be {self.valid}, got {value!r}")
        return float(value)  # type: ignore[arg-type]


#: Gate probability of the χ² gate (Pollithy et al. 2020: 0.999).
P_GATE = LiveKnob("p_gate", 0.999, "a probability in (0, 1)", lambda v: 0.0 < v < 1.0)
#: Covariance scale of the second-chance association (1 turns it off).
RECOVERY_INFLATION = LiveKnob(
    "recovery_inflation", 25.0, "a finite number >= 1", lambda v: 1.0 <= v < math.inf
)
#: Factor on the sensor's declared noise std that the tracker assumes.
NOISE_SCALE = LiveKnob("noise_scale", 1.0, "a finite number > 0", lambda v: 0.0 < v < math.inf)

#: Every setting a running point tracker takes between frames, by name.
LIVE_KNOBS: dict[str, LiveKnob] = {k.name: k for k in (P_GATE, RECOVERY_INFLATION, NOISE_SCALE)}
