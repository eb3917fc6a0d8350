"""Single-target estimation error and track loss (Jung et al. 2019, Sec. IV).

For one target with true positions ``x_t`` and the tracker's estimates ``x̂_t`` over the frames
``t`` of an episode that have an estimate:

* mean error ``ē = mean_t ||x̂_t − x_t||_2`` of the reported (weighted-mean) estimate. Jung et al.'s (2019)
  Figs. 4, 5 and 7a average the error over the particles instead, which a metric that sees only
  the report cannot compute; the two agree closely once the particle cloud is tight;
* ``rmse = sqrt(mean_t ||x̂_t − x_t||²)``;
* ``lost = 1`` if ``ē > 5`` trajectory units (Jung et al. 2019, Sec. IV-B4 calls such a track lost), else
  0; an episode without any estimate is lost;
* ``occlusion_error``: ``ē`` restricted to the frames of the occlusion interval (NaN if none).

Which row is the estimate: the report's first masked-in row (a single-target tracker reports one
track; further rows are ignored). Frames whose report is empty: the paper's filter has an estimate
at every time step (it predicts when no measurement arrives) and averages over all of them, so an
empty report *holds the last reported position* and the frame still counts. Frames before the first
report have no estimate at all; they are skipped and counted in ``frames_without_estimate``. The
truth is the first real row of ``info["truth"]`` whether or not it is marked visible (an occluded
target is still scored); frames without truth are skipped.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from track_envs.metrics.base import MetricTraits, live_report

#: Mean error above which a track counts as lost (Jung et al. 2019), trajectory units.
LOST_THRESHOLD = 5.0


class SingleTargetError:
    """Streaming mean / RMS estimation error, track loss and occlusion error of one target.

    Track ids play no part (in a report they are unique and non-negative within a frame by the
    report contract, [`track_envs.contracts.report.validate_report`][track_envs.contracts.validate_report]).

    Args:
        occlusion: ``(start, stop)`` half-open frame range of the occlusion interval (frames are
            counted from the first ``update`` after ``reset``); ``None`` for none.
        lost_threshold: Mean error above which the track is lost (default 5).
    """

    traits = MetricTraits(needs_truth=True)

    def __init__(self, occlusion: tuple[int, int] | None = None, lost_threshold: float = LOST_THRESHOLD):
        if occlusion is not None:
            start, stop = occlusion
            if not (0 <= int(start) <= int(stop)):
                raise ValueError(
                    f"occlusion must be a frame range (start, stop), 0 <= start <= stop, got {occlusion!r}"
                )
        if not (np.isfinite(lost_threshold) and lost_threshold > 0):
            raise ValueError(f"lost_threshold must be a finite number > 0, got {lost_threshold!r}")
        self.occlusion = (int(occlusion[0]), int(occlusion[1])) if occlusion is not None else (0, 0)
        self.lost_threshold = float(lost_threshold)
        self.reset()

    def reset(self) -> None:
        """Start a new episode."""
        self._frame = 0
        self._last: NDArray[np.float64] | None = None
        self._sum = 0.0
        self._sum_sq = 0.0
        self._count = 0
        self._occ_sum = 0.0
        self._occ_count = 0
        self._without = 0

    def update(
        self, truth: Mapping[str, NDArray], detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> None:
        """Add one frame (see the module docstring for the estimate of a frame)."""
        frame = self._frame
        self._frame += 1
        _, positions, _ = live_report(report)
        if len(positions):
            self._last = positions[0]
        ids = np.asarray(truth["ids"])
        real = np.flatnonzero(ids >= 0)
        if not len(real):
            return
        if self._last is None:
            self._without += 1
            return
        err = float(np.linalg.norm(self._last - np.asarray(truth["positions"], dtype=np.float64)[real[0]]))
        self._sum += err
        self._sum_sq += err * err
        self._count += 1
        if self.occlusion[0] <= frame < self.occlusion[1]:
            self._occ_sum += err
            self._occ_count += 1

    def compute(self) -> dict[str, float]:
        """``mean_error``, ``rmse``, ``lost`` (0/1), ``occlusion_error``, ``frames_without_estimate``."""
        nan = float("nan")
        mean = self._sum / self._count if self._count else nan
        return {
            "mean_error": mean,
            "rmse": float(np.sqrt(self._sum_sq / self._count)) if self._count else nan,
            "lost": float(not (mean <= self.lost_threshold)),
            "occlusion_error": self._occ_sum / self._occ_count if self._occ_count else nan,
            "frames_without_estimate": float(self._without),
        }
