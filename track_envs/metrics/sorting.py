"""Sorting prediction: how well a tracker predicts when and where each particle passes the nozzle bar.

An optical belt sorter ejects a particle with a burst of air from the nozzle under it as it
passes the nozzle bar downstream of the camera; the tracker has to predict that moment and place
from the last frames the particle was seen in ("predictive tracking", Pfaff et al., "TrackSort:
Predictive Tracking for Sorting Uncooperative Bulk Materials", 2015; Pollithy et al.,
"Estimating Uncertainties of Recurrent Neural Networks in Application to Multitarget Tracking",
2020). Association scores (e1/e2, MOTA) only say whether tracks were kept apart; this metric
scores the prediction itself.

Inputs per frame: the truth's nozzle crossings (``nozzle_ids``, ``nozzle_times``,
``nozzle_lateral``, [`track_envs.envs.nozzle`][track_envs.envs.nozzle]) and the report's optional sorting
channel (``sorting_*``, [`track_envs.contracts.sorting_channel`][track_envs.contracts.sorting_channel]). A
prediction belongs to the particle of the detection its track was last updated with (``detection_ids`` of that
frame; with merged blobs, the blob's primary particle), and each particle is scored on the **last** prediction
made for it. With the true crossing ``(t_c, y_c)`` and the predicted Gaussian ``N((t̂, ŷ), Σ)``:

.. math::

    Δt = t̂ − t_c, \\qquad Δy = ŷ − y_c, \\qquad
    \\text{hit} \\iff |Δy| \\le w_y \\wedge |Δt| \\le w_t, \\qquad
    \\mathrm{NEES} = (Δt, Δy)\\, Σ^{-1} (Δt, Δy)^\\top

(``w_y`` the lateral half-width of a nozzle, ``w_t`` the valve's timing window; a consistent
predictor has mean NEES 2, and 95% of its NEES values below χ²₂(0.95) = 5.99). A particle that
crossed without a prediction is a miss. The particles scored are those that crossed the line
and were in the camera window (``truth["visible"]``) in at least ``min_visible_frames`` frames
of the episode, so particles already past the window when the episode began are not counted.

Keys (prefix ``sorting_``): ``particles`` (scored), ``predicted`` (fraction with a prediction),
``hit_rate``, ``time_rmse_ms``, ``time_bias_ms`` (mean ``Δt``), ``time_p50_ms``,
``time_p90_ms``, ``time_p95_ms``, ``time_p99_ms`` (percentiles of ``|Δt|``: its distribution),
``lateral_rmse_mm``, ``lateral_bias_mm``, ``lateral_p50_mm`` … ``lateral_p99_mm``,
``nees`` (mean), ``nees_in_95`` (fraction below 5.99), ``unmatched_predictions`` (predictions
of tracks that followed clutter or no particle that crossed). Error statistics are over the
predicted particles, NaN when there are none. Lengths are reported in mm assuming the sensor
unit is the metre (``length_to_mm``), times in ms.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from track_envs.metrics.base import MetricTraits

#: χ²₂(0.95), the 95% quantile of the NEES of a consistent 2-D Gaussian.
CHI2_2_95 = 5.991464547107979


class SortingPrediction:
    """Streaming score of the predicted nozzle-bar crossings (see the module docstring).

    Args:
        lateral_tolerance: Lateral half-width ``w_y`` of a nozzle in sensor units (default
            1.5e-3 m).
        time_tolerance: Half-width ``w_t`` of the valve's timing window in seconds (default 2e-3).
        min_visible_frames: Fewest frames in view for a crossing particle to be scored (default 3).
        length_to_mm: Millimetres per sensor unit for the ``_mm`` keys (default 1000: metres).
    """

    traits = MetricTraits(needs_truth=True)

    def __init__(
        self,
        lateral_tolerance: float = 1.5e-3,
        time_tolerance: float = 2e-3,
        min_visible_frames: int = 3,
        length_to_mm: float = 1000.0,
    ):
        for name, value in (
            ("lateral_tolerance", lateral_tolerance),
            ("time_tolerance", time_tolerance),
            ("length_to_mm", length_to_mm),
        ):
            if not (isinstance(value, int | float) and np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        if not (isinstance(min_visible_frames, int) and min_visible_frames >= 1):
            raise ValueError(f"min_visible_frames must be an integer >= 1, got {min_visible_frames!r}")
        self.lateral_tolerance = float(lateral_tolerance)
        self.time_tolerance = float(time_tolerance)
        self.min_visible_frames = min_visible_frames
        self.length_to_mm = float(length_to_mm)
        self.reset()

    def reset(self) -> None:
        """Forget every frame."""
        self._visible: list[NDArray[np.int64]] = []
        self._crossed: list[tuple[NDArray, NDArray, NDArray]] = []
        self._predicted: list[tuple[NDArray, NDArray, NDArray]] = []
        # the tracks of the previous report: ids (sorted) and the particle each last followed
        self._track_ids = np.zeros(0, dtype=np.int64)
        self._track_truth = np.zeros(0, dtype=np.int64)

    def update(
        self, truth: Mapping[str, NDArray], detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> None:
        """Add one frame: remember who was in view, the crossings, and the report's predictions."""
        ids = np.asarray(truth["ids"])
        self._visible.append(ids[(ids >= 0) & np.asarray(truth["visible"], dtype=bool)])
        crossed = np.asarray(truth.get("nozzle_ids", ids[:0]))
        if len(crossed) and crossed[0] >= 0:  # rows are filled from the top
            live = crossed >= 0
            self._crossed.append(
                (
                    crossed[live],
                    np.asarray(truth["nozzle_times"])[live],
                    np.asarray(truth["nozzle_lateral"])[live],
                )
            )
        track_ids, track_truth = self._followed(np.asarray(detection_ids), report)
        if "sorting_mask" in report:
            live = np.asarray(report["sorting_mask"]) == 1
            if live.any():
                who = np.asarray(report["sorting_ids"], dtype=np.int64)[live]
                particle = _lookup(track_ids, track_truth, who)
                earlier = particle < 0
                particle[earlier] = _lookup(self._track_ids, self._track_truth, who[earlier])
                mean = np.asarray(report["sorting_mean"], dtype=np.float64)[live]
                cov = np.asarray(report["sorting_cov"], dtype=np.float64)[live]
                self._predicted.append((particle, mean, cov))
        self._track_ids, self._track_truth = track_ids, track_truth

    def _followed(
        self, detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """The live tracks of ``report`` (ids sorted) and the particle each last followed: the
        source of the detection it was updated with, else what it followed before (−1: none)."""
        live = np.asarray(report["mask"]) == 1
        ids = np.asarray(report["ids"], dtype=np.int64)[live]
        detection = np.asarray(report["detection"], dtype=np.int64)[live]
        source = np.full(len(ids), -1, dtype=np.int64)
        used = (detection >= 0) & (detection < len(detection_ids))
        source[used] = detection_ids[detection[used]]
        carried = ~used
        source[carried] = _lookup(self._track_ids, self._track_truth, ids[carried])
        order = np.argsort(ids, kind="stable")
        return ids[order], source[order]

    def compute(self) -> dict[str, float]:
        """The ``sorting_*`` scores of every frame so far (see the module docstring)."""
        nan = float("nan")
        visible = np.concatenate(self._visible) if self._visible else np.zeros(0, dtype=np.int64)
        seen, counts = np.unique(visible, return_counts=True)
        eligible = seen[counts >= self.min_visible_frames]
        if self._crossed:
            c_ids, c_time, c_lat = (np.concatenate(parts) for parts in zip(*self._crossed, strict=True))
        else:
            c_ids, c_time, c_lat = np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0)
        c_ids, first = np.unique(c_ids, return_index=True)  # a particle's first crossing
        c_time, c_lat = c_time[first], c_lat[first]
        scored = np.isin(c_ids, eligible)
        c_ids, c_time, c_lat = c_ids[scored], c_time[scored], c_lat[scored]
        if self._predicted:
            p_ids, p_mean, p_cov = (np.concatenate(parts) for parts in zip(*self._predicted, strict=True))
        else:
            p_ids, p_mean, p_cov = np.zeros(0, dtype=np.int64), np.zeros((0, 2)), np.zeros((0, 2, 2))
        # the last prediction of each particle: first occurrence in the reversed order
        reversed_ids = p_ids[::-1]
        p_unique, last_reversed = np.unique(reversed_ids, return_index=True)
        last = len(p_ids) - 1 - last_reversed
        p_mean, p_cov = p_mean[last], p_cov[last]
        at = np.searchsorted(p_unique, c_ids)
        at = np.minimum(at, max(len(p_unique) - 1, 0))
        has = (p_unique[at] == c_ids) if len(p_unique) else np.zeros(len(c_ids), dtype=bool)
        unmatched = int(np.count_nonzero(~np.isin(p_unique, c_ids)))
        n = len(c_ids)
        out = {
            "sorting_particles": float(n),
            "sorting_predicted": float(has.mean()) if n else nan,
            "sorting_unmatched_predictions": float(unmatched),
        }
        rows = at[has]
        dt = p_mean[rows, 0] - c_time[has]
        dy = p_mean[rows, 1] - c_lat[has]
        hits = (np.abs(dt) <= self.time_tolerance) & (np.abs(dy) <= self.lateral_tolerance)
        out["sorting_hit_rate"] = float(np.count_nonzero(hits) / n) if n else nan
        out.update(_error_stats("sorting_time", "ms", dt * 1000.0))
        out.update(_error_stats("sorting_lateral", "mm", dy * self.length_to_mm))
        nees = _nees(np.stack([dt, dy], axis=1), p_cov[rows])
        finite = nees[np.isfinite(nees)]
        out["sorting_nees"] = float(finite.mean()) if len(finite) else nan
        out["sorting_nees_in_95"] = float(np.mean(finite <= CHI2_2_95)) if len(finite) else nan
        return out


#: Percentiles of the absolute errors reported (``_pNN_`` keys): the error distribution.
PERCENTILES = (50, 90, 95, 99)


def _error_stats(prefix: str, unit: str, error: NDArray[np.float64]) -> dict[str, float]:
    """RMSE, mean (bias) and the [`PERCENTILES`][track_envs.metrics.sorting.PERCENTILES] of the absolute
    error; NaN when empty."""
    keys = [f"{prefix}_rmse_{unit}", f"{prefix}_bias_{unit}"] + [f"{prefix}_p{q}_{unit}" for q in PERCENTILES]
    if not len(error):
        return dict.fromkeys(keys, float("nan"))
    values = [float(np.sqrt(np.mean(error**2))), float(np.mean(error))]
    values += [float(v) for v in np.percentile(np.abs(error), PERCENTILES)]
    return dict(zip(keys, values, strict=True))


def _nees(error: NDArray[np.float64], cov: NDArray[np.float64]) -> NDArray[np.float64]:
    """``eᵀ Σ⁻¹ e`` per row of ``error`` (k, 2) with ``cov`` (k, 2, 2) in closed form; NaN where
    ``Σ`` is not positive definite."""
    a, b, c = cov[:, 0, 0], 0.5 * (cov[:, 0, 1] + cov[:, 1, 0]), cov[:, 1, 1]
    det = a * c - b * b
    x, y = error[:, 0], error[:, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        value = (c * x * x - 2 * b * x * y + a * y * y) / det
    return np.where((a > 0) & (det > 0), value, np.nan)


def _lookup(
    keys: NDArray[np.int64], values: NDArray[np.int64], query: NDArray[np.int64]
) -> NDArray[np.int64]:
    """``values`` at ``query`` in the sorted ``keys``, −1 where a query is not a key."""
    if not len(keys) or not len(query):
        return np.full(len(query), -1, dtype=np.int64)
    at = np.minimum(np.searchsorted(keys, query), len(keys) - 1)
    return np.where(keys[at] == query, values[at], -1)
