"""A simple adaptive rule for GateTuning-v0: scale the assumed noise so that the NIS fits χ².

When the tracker's noise model is right, the normalised innovation squared of an assigned pair
is ``χ²_D`` distributed with mean ``D`` ([`track_apps.tuning.diagnostics`][track_apps.tuning.diagnostics]). If
the sensor's true noise std is ``c`` times the declared one and the innovation is dominated by the noise, the
mean NIS under noise scale ``k`` is about ``D c² / k²``, so

.. math::

    k \\leftarrow k \\, \\Big(\\frac{\\overline{ε}}{D}\\Big)^{η/2}

moves ``k`` toward ``c`` (``η = 1``: in one step; smaller ``η`` averages over windows, a running
mean in log space). The rule reads the window's mean NIS and the scale in effect from the
observation and leaves the gate probability and the second-chance inflation fixed. It keeps no
state, so it runs in vector envs like any SB3 policy.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from track_apps.tuning.diagnostics import FEATURES, N_FEATURES
from track_apps.tuning.knobs import make_knobs
from track_apps.tuning.policy import FixedPolicy, PolicyCapability


class NisRule:
    """The NIS rule (module docstring) with SB3's ``predict``.

    Args:
        gain: ``η`` in (0, 1] (default 0.5).
        fixed: Values of the other knobs (default the gnn's,
            `agents.tracking.knobs.LIVE_KNOBS`).
        ranges: The env's knob ranges.
    """

    capabilities = frozenset({PolicyCapability.KNOB_RANGES})

    def __init__(
        self,
        gain: float = 0.5,
        fixed: Mapping[str, float] | None = None,
        ranges: Mapping[str, Any] | None = None,
    ):
        if not (isinstance(gain, int | float) and 0 < gain <= 1):
            raise ValueError(f"gain must be a number in (0, 1], got {gain!r}")
        self.gain = float(gain)
        self.knobs = make_knobs(ranges)
        self._fixed = FixedPolicy(fixed, ranges=ranges).action
        self._scale = [k.name for k in self.knobs].index("noise_scale")
        self._nis = FEATURES.index("log_mean_nis")

    def predict(
        self,
        observation: NDArray[np.floating],
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.float32], None]:
        """The next action for one observation or a batch (the rule is deterministic)."""
        obs = np.atleast_2d(np.asarray(observation, dtype=np.float64))
        knob = self.knobs[self._scale]
        out = np.broadcast_to(self._fixed, (len(obs), len(self._fixed))).copy()
        for row, o in enumerate(obs):
            current = knob.value(float(o[N_FEATURES + self._scale]))
            log_ratio = float(o[self._nis])  # log(mean NIS / D); 0 before the first window
            out[row, self._scale] = knob.action(current * np.exp(0.5 * self.gain * log_ratio))
        out = out.astype(np.float32)
        return (out if np.ndim(observation) == 2 else out[0]), None
