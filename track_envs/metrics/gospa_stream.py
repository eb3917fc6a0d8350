"""Episode GOSPA: the mean over frames of the per-frame GOSPA of the report against visible truth.

Rahmathullah, García-Fernández, Svensson, "Generalized optimal sub-pattern assignment metric",
FUSION 2017 (α = 2, cut-off ``c``, order ``p``; see :mod:`track_envs.metrics.gospa`). With
``d_t`` the GOSPA of frame ``t``,

.. math::

    \\overline{\\mathrm{GOSPA}} = \\frac{1}{T} \\sum_{t=1}^{T} d_p^{(c,2)}(X_t, Y_t),

and the decomposition is averaged the same way: localisation (sum of ``d^p`` over assigned
pairs), missed truths and false tracks per frame. This is also what the point environments
reward (−GOSPA, p = 2), so the episode mean is the negated mean reward.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from track_envs.metrics.base import live_report, live_truth
from track_envs.metrics.gospa import gospa


class GospaMetric:
    """Streaming mean per-frame GOSPA of reports (mask 1 rows) against the visible truth.

    Track identities play no part: duplicate ids are distinct estimates.

    Args:
        c: Cut-off distance in sensor units, > 0.
        p: Order, >= 1.
    """

    def __init__(self, c: float, p: float = 2.0) -> None:
        if not c > 0:
            raise ValueError(f"GOSPA cut-off c must be > 0, got {c!r}")
        if not p >= 1:
            raise ValueError(f"GOSPA order p must be >= 1, got {p!r}")
        self.c = float(c)
        self.p = float(p)
        self.reset()

    def reset(self) -> None:
        """Forget every frame (start a new episode)."""
        self._sums = np.zeros(4)  # distance, localisation, missed, false
        self._frames = 0

    def update(
        self, truth: Mapping[str, NDArray], detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> None:
        """Add one frame from ``info["truth"]`` and the report (``detection_ids`` is unused)."""
        del detection_ids
        _, x = live_truth(truth)
        _, y, _ = live_report(report)
        r = gospa(x, y, self.c, self.p)
        self._sums += (r.distance, r.localisation, r.missed, r.false)
        self._frames += 1

    def compute(self) -> dict[str, float]:
        """``gospa``, ``gospa_localisation``, ``gospa_missed``, ``gospa_false`` (means per frame),
        ``n_frames``; the means are NaN before the first frame."""
        mean = self._sums / self._frames if self._frames else np.full(4, np.nan)
        return {
            "gospa": float(mean[0]),
            "gospa_localisation": float(mean[1]),
            "gospa_missed": float(mean[2]),
            "gospa_false": float(mean[3]),
            "n_frames": float(self._frames),
        }
