"""Truth-free score of predicted line crossings: where the tracks really crossed a line, and the hits.

A sorter recording usually ends at the camera window, before the nozzle bar, so nothing in it
says when a particle reached the bar. A predictor can still be validated on it: put a *virtual*
line ``x = L`` inside the window, let the tracker see only the detections upstream of a cut-off
``x_cut < L`` (its camera window ends there), and compare its predicted crossings of ``L`` with
where the tracks of the whole recording really crossed ``L``. This module holds the two pure
halves (no tracker): the observed crossings of tracks
([`observed_crossings`][track_envs.metrics.crossing_check.observed_crossings]) and the score
([`score_crossings`][track_envs.metrics.score_crossings]);
[`agents.sorting.check.check_sorting`][agents.sorting.check_sorting] runs the tracker.

**Observed crossing** of a track: between two consecutive detections the track was updated with,
at frames ``f_a < f_b`` (coasted frames between them allowed), with positions ``p_a``, ``p_b`` and
``x_a < L <= x_b``,

.. math::

    φ = \\frac{L − x_a}{x_b − x_a}, \\qquad t_c = (f_a + φ\\,(f_b − f_a))\\,dt, \\qquad
    y_c = y_a + φ\\,(y_b − y_a),

the first such pair of the track. The positions are the detections themselves (not the track's
filtered estimates), so ``(t_c, y_c)`` carries the measurement noise but no filter lag.

**Score**, as [`SortingPrediction`][track_envs.metrics.SortingPrediction] scores against simulated
truth: each track is scored on the last prediction made for it; with ``Δt = t̂ − t_c`` and
``Δy = ŷ − y_c``, a hit is ``|Δt| <= w_t`` and ``|Δy| <= w_y``. The tracks scored (*crossings*)
are those that crossed ``L`` and were updated with at least ``min_seen`` detections at
``x <= x_cut`` (a particle first seen past the cut-off cannot be predicted from before it); a
scored track without prediction is a miss, so the hit rate is ``hits / crossings``. Errors are
over the predicted crossings: ``|Δ|`` percentiles 50, 90, 99, the mean ``Δ`` (bias) and the mean
NEES ``(Δt, Δy) Σ⁻¹ (Δt, Δy)ᵀ`` (2 for a consistent predictor). Predictions of tracks that never
crossed ``L`` in the recording (lost, stopped, or past the recording's end) are counted as
``never_crossed`` (and, of them, those predicted to cross after the recording's last frame as
``beyond_end``); predictions reported (frame ``· dt``) after the crossing they predict are
counted as ``late`` (a valve would have fired too late).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from track_envs.io.crossings import PredictedCrossings
from track_envs.values.detections import Detections
from track_envs.values.tracks import Tracks

#: Default lateral half-width ``w_y`` of a nozzle (detection units; 1.5 mm when they are metres)
#: and half-width ``w_t`` of the valve's timing window (s): SortingPrediction's defaults.
LATERAL_TOLERANCE = 1.5e-3
TIME_TOLERANCE = 2e-3
#: Fewest detections upstream of the cut-off for a crossing track to be scored.
MIN_SEEN = 3
#: Percentiles of ``|Δt|`` and ``|Δy|`` reported.
PERCENTILES = (50, 90, 99)


@dataclass(frozen=True)
class ObservedCrossings:
    """First crossing of the line by each track that crossed it (module docstring).

    Attributes:
        ids: (k,) int64 track ids, sorted.
        t: (k,) crossing times ``t_c`` (s, frame ``f`` at ``f·dt``).
        y: (k,) lateral positions ``y_c``.
    """

    ids: NDArray[np.int64]
    t: NDArray[np.float64]
    y: NDArray[np.float64]

    def __len__(self) -> int:
        return len(self.ids)


def updated_detections(
    tracks: Tracks, detections: Detections
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """``(frame, id, detection index into detections.points)`` of every row a track was updated
    with a detection, sorted by id then frame.

    Raises:
        ValueError: tracks without their detection rows, or rows that point past their frame.
    """
    if tracks.detection is None:
        raise ValueError("the tracks carry no detection rows (Tracks.detection); run_agent's tracks do")
    used = tracks.detection >= 0
    frame, ids, row = tracks.frame[used], tracks.ids[used], tracks.detection[used]
    if len(frame) and (frame.max() >= detections.n_frames or np.any(row >= detections.counts[frame])):
        raise ValueError("the tracks' detection rows do not belong to these detections")
    index = detections.offsets[frame] + row
    order = np.lexsort((frame, ids))
    return frame[order], ids[order], index[order]


def observed_crossings(tracks: Tracks, detections: Detections, line: float, dt: float) -> ObservedCrossings:
    """Where and when each track first crossed ``x = line``, from the detections it was updated
    with (module docstring)."""
    frame, ids, index = updated_detections(tracks, detections)
    p = detections.points[index]
    same = ids[1:] == ids[:-1]
    crossing = same & (p[:-1, 0] < line) & (p[1:, 0] >= line)
    a = np.flatnonzero(crossing)
    who, first = np.unique(ids[a], return_index=True)  # rows are by id then frame: the first
    a = a[first]
    b = a + 1
    phi = (line - p[a, 0]) / (p[b, 0] - p[a, 0])
    t = (frame[a] + phi * (frame[b] - frame[a])) * dt
    y = p[a, 1] + phi * (p[b, 1] - p[a, 1])
    return ObservedCrossings(who, t, y)


def seen_upstream(
    tracks: Tracks, detections: Detections, cut: float
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """``(ids sorted, counts)``: how many detections at ``x <= cut`` each track was updated with."""
    _, ids, index = updated_detections(tracks, detections)
    upstream = detections.points[index, 0] <= cut
    unique, counts = np.unique(ids[upstream], return_counts=True)
    return unique, counts.astype(np.int64)


@dataclass(frozen=True)
class CrossingScore:
    """The score of predicted crossings against observed ones (module docstring).

    Attributes:
        crossings: Tracks scored (crossed, seen upstream of the cut-off).
        predicted: Of those, with a prediction.
        hits: Of those, hit.
        predictions: Tracks with a (last) prediction.
        never_crossed: Predictions of tracks that did not cross the line in the recording.
        late: Scored predictions reported after the crossing they predict.
        beyond_end: Of ``never_crossed``, those predicted to cross after the recording's last
            frame (the recording ended too soon to see them cross; 0 without ``end_time``).
        ids: (n,) the scored tracks with a prediction.
        time_error: (n,) ``Δt = t̂ − t_c`` (s).
        lateral_error: (n,) ``Δy = ŷ − y_c`` (detection units).
        nees: (n,) ``(Δt, Δy) Σ⁻¹ (Δt, Δy)ᵀ`` (NaN for a singular Σ).
        hit: (n,) bool.
        lateral_tolerance: ``w_y``.
        time_tolerance: ``w_t``.
    """

    crossings: int
    predicted: int
    hits: int
    predictions: int
    never_crossed: int
    late: int
    beyond_end: int
    ids: NDArray[np.int64]
    time_error: NDArray[np.float64]
    lateral_error: NDArray[np.float64]
    nees: NDArray[np.float64]
    hit: NDArray[np.bool_]
    lateral_tolerance: float
    time_tolerance: float

    @property
    def hit_rate(self) -> float:
        """``hits / crossings`` (NaN without crossings)."""
        return self.hits / self.crossings if self.crossings else float("nan")

    def summary(self, units: str = "unit") -> dict[str, float]:
        """The figures as a flat dict: counts, ``hit_rate``, ``time_pNN_ms`` and ``time_bias_ms``,
        ``lateral_pNN_<units>`` and ``lateral_bias_<units>`` (the detections' units), ``nees``."""
        out = {
            "crossings": float(self.crossings),
            "predicted": float(self.predicted),
            "hits": float(self.hits),
            "hit_rate": self.hit_rate,
            "predictions": float(self.predictions),
            "never_crossed": float(self.never_crossed),
            "late": float(self.late),
            "beyond_end": float(self.beyond_end),
        }
        for name, unit, error in (
            ("time", "ms", 1000.0 * self.time_error),
            ("lateral", units, self.lateral_error),
        ):
            values = np.percentile(np.abs(error), PERCENTILES) if len(error) else [np.nan] * len(PERCENTILES)
            out |= {f"{name}_p{q}_{unit}": float(v) for q, v in zip(PERCENTILES, values, strict=True)}
            out[f"{name}_bias_{unit}"] = float(np.mean(error)) if len(error) else float("nan")
        finite = self.nees[np.isfinite(self.nees)]
        out["nees"] = float(finite.mean()) if len(finite) else float("nan")
        return out


def check_tolerances(lateral_tolerance: float, time_tolerance: float, min_seen: int) -> None:
    """Raise ``ValueError`` naming a tolerance that is not a finite number > 0, or a ``min_seen`` < 1."""
    for name, value in (("lateral_tolerance", lateral_tolerance), ("time_tolerance", time_tolerance)):
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not (np.isfinite(value) and value > 0)
        ):
            raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    if isinstance(min_seen, bool) or not isinstance(min_seen, int | np.integer) or min_seen < 1:
        raise ValueError(f"min_seen must be an integer >= 1, got {min_seen!r}")


def score_crossings(
    predicted: PredictedCrossings,
    observed: ObservedCrossings,
    scored: NDArray[np.int64],
    dt: float,
    *,
    lateral_tolerance: float = LATERAL_TOLERANCE,
    time_tolerance: float = TIME_TOLERANCE,
    end_time: float = float("inf"),
) -> CrossingScore:
    """Score ``predicted`` (its ``ids`` the tracks of ``observed`` each prediction is for; the
    last per id counts) against ``observed``, over the tracks ``scored`` (module docstring).

    Args:
        predicted: The predictions, ``frame`` the frame each was reported in.
        observed: The observed crossings.
        scored: Ids of the tracks eligible for scoring (seen upstream of the cut-off); of them,
            those in ``observed`` are the crossings scored.
        dt: Frame period (s), for ``late``.
        lateral_tolerance: ``w_y``, the lateral tolerance of a hit.
        time_tolerance: ``w_t``, the time tolerance of a hit (s).
        end_time: Time of the recording's last frame (for ``beyond_end``).
    """
    check_tolerances(lateral_tolerance, time_tolerance, 1)
    last = predicted.last()
    crossed = np.isin(observed.ids, scored)
    c_ids, c_t, c_y = observed.ids[crossed], observed.t[crossed], observed.y[crossed]
    at = np.searchsorted(c_ids, last.ids)
    at = np.minimum(at, max(len(c_ids) - 1, 0))
    has = c_ids[at] == last.ids if len(c_ids) else np.zeros(len(last), dtype=bool)
    observed_any = np.isin(last.ids, observed.ids)
    rows, at = np.flatnonzero(has), at[has]
    dt_err = last.mean[rows, 0] - c_t[at]
    dy_err = last.mean[rows, 1] - c_y[at]
    hit = (np.abs(dt_err) <= time_tolerance) & (np.abs(dy_err) <= lateral_tolerance)
    return CrossingScore(
        crossings=len(c_ids),
        predicted=len(rows),
        hits=int(np.count_nonzero(hit)),
        predictions=len(last),
        never_crossed=int(np.count_nonzero(~observed_any)),
        beyond_end=int(np.count_nonzero(~observed_any & (last.mean[:, 0] > end_time))),
        late=int(np.count_nonzero(last.frame[rows] * dt > c_t[at])),
        ids=last.ids[rows],
        time_error=dt_err,
        lateral_error=dy_err,
        nees=_nees(np.stack([dt_err, dy_err], axis=1), last.cov[rows]),
        hit=hit,
        lateral_tolerance=float(lateral_tolerance),
        time_tolerance=float(time_tolerance),
    )


def _nees(error: NDArray[np.float64], cov: NDArray[np.float64]) -> NDArray[np.float64]:
    """``eᵀ Σ⁻¹ e`` per row, by the closed-form 2×2 inverse (NaN where ``det Σ <= 0``)."""
    a, b, d = cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 1]
    det = a * d - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        q = (d * error[:, 0] ** 2 - 2 * b * error[:, 0] * error[:, 1] + a * error[:, 1] ** 2) / det
    return np.where(det > 0, q, np.nan)
