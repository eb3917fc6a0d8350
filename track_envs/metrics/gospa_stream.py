"""Episode GOSPA: the mean over frames of the per-frame GOSPA of the report against visible truth.

Rahmathullah, García-Fernández, Svensson, "Generalized optimal sub-pattern assignment metric",
FUSION 2017 (α = 2, cut-off ``c``, order ``p``; see [`track_envs.metrics.gospa`][track_envs.metrics.gospa]).
With ``d_t`` the GOSPA of frame ``t``,

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

from track_envs.metrics.base import MetricTraits, report_arrays, truth_arrays
from track_envs.metrics.gospa import check_gospa_parameters, gospa_frame


class GospaMetric:
    """Streaming mean per-frame GOSPA of reports (mask 1 rows) against the visible truth.

    Track identities play no part (in a report they are unique and non-negative within a frame
    by the report contract,
    [`track_envs.contracts.report.validate_report`][track_envs.contracts.validate_report]). Nor do
    associations:
    GOSPA compares positions only, so it has no notion of a merged detection (touching particles
    seen as one blob). A track following a blob sits at its area-weighted centroid, within half
    the centres' distance of either particle for equal areas, and is scored by that distance like
    any other estimate; the metric stays a metric on sets of positions.

    Args:
        c: Cut-off distance in sensor units, > 0 and finite.
        p: Order, >= 1 and finite.
    """

    traits = MetricTraits(needs_truth=True)

    def __init__(self, c: float, p: float = 2.0) -> None:
        check_gospa_parameters(c, p)
        self.c = float(c)
        self.p = float(p)
        self._cp = self.c**self.p
        self.reset()

    def reset(self) -> None:
        """Forget every frame (start a new episode)."""
        self._sums = [0.0, 0.0, 0.0, 0.0]  # distance, localisation, missed, false
        self._frames = 0

    def update(
        self, truth: Mapping[str, NDArray], detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> None:
        """Add one frame from ``info["truth"]`` and the report (``detection_ids`` is unused)."""
        del detection_ids
        truth_ids, x, visible = truth_arrays(truth)
        report_ids, y, _, mask = report_arrays(report)
        if x.ndim != 2 or y.ndim != 2 or x.shape[1] != y.shape[1]:
            raise ValueError(
                "GospaMetric scores point reports (max_tracks, D) against truth (max_targets, D); got "
                f"report positions {y.shape} and truth {x.shape}"
            )
        loc, pairs, m, n = gospa_frame(truth_ids, x, visible, report_ids, y, mask, self.c, self.p, self._cp)
        total = loc + self._cp / 2 * (m + n - 2 * pairs)  # as gospa_result, without the dataclass
        sums = self._sums
        sums[0] += total ** (1 / self.p)
        sums[1] += loc
        sums[2] += m - pairs
        sums[3] += n - pairs
        self._frames += 1

    def compute(self) -> dict[str, float]:
        """``gospa``, ``gospa_localisation``, ``gospa_missed``, ``gospa_false`` (means per frame),
        ``n_frames``; the means are NaN before the first frame."""
        mean = np.asarray(self._sums) / self._frames if self._frames else np.full(4, np.nan)
        return {
            "gospa": float(mean[0]),
            "gospa_localisation": float(mean[1]),
            "gospa_missed": float(mean[2]),
            "gospa_false": float(mean[3]),
            "n_frames": float(self._frames),
        }
