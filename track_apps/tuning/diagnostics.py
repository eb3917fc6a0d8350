"""What a running tracker can tell about its own association, without truth, over a window.

Per frame, for the ``n`` tracks that existed before the frame (predicted measurement
``N(ŷ_i, S_i)``) and its ``m`` detections, the tracker knows which detection ``z_{j(i)}`` each
track took. Over a window of frames [`WindowDiagnostics`][track_apps.tuning.diagnostics.WindowDiagnostics]
collects

* the normalised innovation squared of every assigned pair,
  ``ε_i = (z_{j(i)} − ŷ_i)ᵀ S_i^{-1} (z_{j(i)} − ŷ_i)``, which is ``χ²_D`` distributed when the
  tracker's noise model is right (Bar-Shalom, Li, Kirubarajan: Estimation with Applications to
  Tracking and Navigation, 2001, Sec. 5.4): its mean over ``D``, its median over the ``χ²_D``
  median, and the fraction above the 99% quantile;
* the fraction of detections left unassigned (they start tracks), births and deletions per live
  track, the fraction of track-frames that coasted, and the mean number of live tracks.

[`WindowDiagnostics.vector`][track_apps.tuning.diagnostics.WindowDiagnostics.vector] turns them into
[`N_FEATURES`][track_apps.tuning.diagnostics.N_FEATURES] numbers of order one (logs of ratios, fractions),
clipped to ``[-FEATURE_BOUND, FEATURE_BOUND]``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

#: Names of the diagnostics, in the order of
#: [`WindowDiagnostics.vector`][track_apps.tuning.diagnostics.WindowDiagnostics.vector].
FEATURES = (
    "log_mean_nis",  # log(mean ε / D); 0 when the noise model fits
    "log_median_nis",  # log(median ε / median of χ²_D)
    "nis_tail",  # fraction of ε above the χ²_D 99% quantile (0.01 when it fits)
    "unassigned",  # fraction of detections no existing track took
    "births",  # births per live track and frame
    "deletions",  # deletions per live track and frame
    "coasting",  # fraction of existing track-frames without a detection
    "log_tracks",  # log(1 + mean live tracks) / log(1 + TRACK_SCALE)
    "log_detections_per_track",  # log((1 + mean detections) / (1 + mean live tracks))
)
N_FEATURES = len(FEATURES)
#: Track count of the track-count feature's unit (a fixed scale, not the report's size, so that the
#: feature means the same whatever ``max_tracks`` the base env reports).
TRACK_SCALE = 256
#: Every feature is clipped to this bound.
FEATURE_BOUND = 5.0


class WindowDiagnostics:
    """Accumulates a window of frames (module docstring).

    Args:
        dim: Measurement dimension ``D``.
        track_scale: The track count of the track-count feature's unit.
    """

    def __init__(self, dim: int, track_scale: int = TRACK_SCALE):
        self.dim = dim
        self._median = float(chi2.median(dim))
        self._tail = float(chi2.ppf(0.99, dim))
        self._log_cap = math.log1p(track_scale)
        self.clear()

    def clear(self) -> None:
        """Start a new window."""
        self._nis: list[NDArray[np.float64]] = []
        self.frames = 0
        self.detections = 0
        self.unassigned = 0
        self.births = 0
        self.deletions = 0
        self.existing = 0  # track-frames of tracks that existed before their frame
        self.coasting = 0
        self.live = 0  # track-frames after the frame

    def add_frame(
        self,
        obs: Mapping[str, NDArray],
        ids_before: NDArray[np.int64],
        report: Mapping[str, NDArray],
        prediction: tuple[NDArray[np.float64], NDArray[np.float64]] | None,
        rows: NDArray[np.int64] | None,
    ) -> None:
        """Add one frame.

        Args:
            obs: The observation the tracker consumed.
            ids_before: Ids of the tracks that existed before the frame.
            report: The tracker's report of the frame.
            prediction: ``(mean (n, D), cov (n, D, D))`` predicted for the existing tracks, or None
                when there were none.
            rows: (n,) observation row each existing track took, −1 if it coasted (None: none).
        """
        m = int(np.count_nonzero(obs["mask"]))
        ids_after = np.asarray(report["ids"])[np.asarray(report["mask"]) == 1]
        n = len(ids_before)
        survivors = int(np.count_nonzero(np.isin(ids_before, ids_after))) if n else 0
        self.frames += 1
        self.detections += m
        self.births += len(ids_after) - survivors
        self.deletions += n - survivors
        self.live += len(ids_after)
        if n == 0 or prediction is None or rows is None:
            self.unassigned += m
            return
        took = rows >= 0
        self.existing += n
        self.coasting += n - int(np.count_nonzero(took))
        self.unassigned += m - len(np.unique(rows[took]))
        if took.any():
            mean, cov = prediction
            residual = np.asarray(obs["detections"], dtype=np.float64)[rows[took]] - mean[took]
            solved = np.linalg.solve(cov[took], residual[..., None])[..., 0]
            self._nis.append(np.einsum("ij,ij->i", residual, solved))

    def vector(self) -> NDArray[np.float32]:
        """The window's diagnostics as [`N_FEATURES`][track_apps.tuning.diagnostics.N_FEATURES] float32 values
        (see [`FEATURES`][track_apps.tuning.diagnostics.FEATURES])."""
        out = np.zeros(N_FEATURES)
        if self.frames == 0:
            return out.astype(np.float32)
        nis = np.concatenate(self._nis) if self._nis else np.zeros(0)
        tiny = 1e-6
        if len(nis):
            out[0] = math.log(max(float(nis.mean()) / self.dim, tiny))
            out[1] = math.log(max(float(np.median(nis)) / self._median, tiny))
            out[2] = float(np.mean(nis > self._tail))
        out[3] = self.unassigned / self.detections if self.detections else 0.0
        per_track = self.live / self.frames
        out[4] = self.births / self.frames / (1.0 + per_track)
        out[5] = self.deletions / self.frames / (1.0 + per_track)
        out[6] = self.coasting / self.existing if self.existing else 0.0
        out[7] = math.log1p(per_track) / self._log_cap
        out[8] = math.log((1.0 + self.detections / self.frames) / (1.0 + per_track))
        return np.clip(out, -FEATURE_BOUND, FEATURE_BOUND).astype(np.float32)
