"""A truth-free check of a tracker's sorting predictions on a recording that ends before the nozzle bar.

How a sorting engineer validates a predictor on recordings (Pfaff et al., "TrackSort: Predictive
Tracking for Sorting Uncooperative Bulk Materials", 2015, validate theirs this way): inside the
camera window, put a virtual line ``x = L`` and a cut-off ``x_cut < L``.

1. **Reference run**: the tracker over the whole recording; where each of its tracks crossed
   ``L`` (interpolated between the two detections around it:
   [`track_envs.metrics.crossing_check.observed_crossings`][track_envs.metrics.crossing_check.observed_crossings])
   stands in for the truth.
2. **Cut run**: the same tracker over the detections at ``x <= x_cut`` only, told that its camera
   window ends at ``x_cut`` and that the sorting line is ``L``; it predicts each track's crossing
   when it lets the track go, from the track's state at its last detection before the cut-off
   (the gnn agent's sorting channel, collected by [`agents.files.points.run_agent`][agents.run_agent]).
3. **Matching**: a cut-run track is the reference track that was updated with the same detection
   as the cut-run track's last one (the detection the prediction starts from).
4. **Score** ([`track_envs.metrics.crossing_check.score_crossings`][track_envs.metrics.score_crossings]): hit
rate within ``±w_y`` and
   ``±w_t``, percentiles of the temporal and lateral errors, predictions of tracks that never
   crossed.

The distance from the last detection to the line, ``L − x_seen``, is how far the predictor
extrapolated; [`SortingCheck.distance`][agents.sorting.check.SortingCheck.distance] gives it per scored
prediction (for plots). Everything is vectorised over detections and tracks; the two runs are the tracker's
own time.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.base import make_agent
from track_envs.io.crossings import PredictedCrossings
from track_envs.metrics.crossing_check import (
    LATERAL_TOLERANCE,
    MIN_SEEN,
    TIME_TOLERANCE,
    CrossingScore,
    ObservedCrossings,
    check_tolerances,
    observed_crossings,
    score_crossings,
    seen_upstream,
    updated_detections,
)
from track_envs.values.detections import Detections
from track_envs.values.tracks import Tracks
from track_envs.values.types import SensorSpec


@dataclass(frozen=True)
class SortingCheck:
    """What [`check_sorting`][agents.sorting.check_sorting] found.

    Attributes:
        line, cut: ``L`` and ``x_cut``.
        score: The score.
        predictions: The cut run's last prediction per track, its ``ids`` the cut run's track ids,
            with extra columns ``track`` (the reference track), ``x_seen`` (``x`` of the last
            detection), ``t_true`` and ``y_true`` (the reference track's crossing; NaN if none).
        observed: The reference tracks' crossings of ``L``.
        distance: (n,) ``L − x_seen`` of each scored prediction (the rows of ``score``).
        seen: (k,) index into ``detections.points`` of the last detection each of
            ``predictions`` starts from.
    """

    line: float
    cut: float
    score: CrossingScore
    predictions: PredictedCrossings
    observed: ObservedCrossings
    distance: NDArray[np.float64]
    seen: NDArray[np.int64]


def check_line_and_cut(spec: SensorSpec, line: Any, cut: Any) -> tuple[float, float]:
    """``(line, cut)`` as floats with ``x_low < cut < line < x_high`` of ``spec``'s region.

    Raises:
        ValueError: naming ``line`` or ``cut``, the value and the range it must lie in.
    """
    low, high = float(spec.region_low[0]), float(spec.region_high[0])
    values = {}
    for name, value in (("line", line), ("cut", cut)):
        if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
            raise ValueError(
                f"sorting check: {name} must be a number (an x in the camera window), got {value!r}"
            )
        values[name] = float(value)
        if not (np.isfinite(values[name]) and low < values[name] < high):
            raise ValueError(
                f"sorting check: {name}={value!r} lies outside the camera window: x must be in "
                f"({low:.6g}, {high:.6g}), where the detections are"
            )
    if not values["cut"] < values["line"]:
        raise ValueError(
            f"sorting check: cut={cut!r} must lie upstream of line={line!r} (cut < line): the predictions "
            "are made from the detections before the cut-off"
        )
    return values["line"], values["cut"]


def cut_stream(detections: Detections, cut: float) -> tuple[Detections, NDArray[np.int64]]:
    """The detections at ``x <= cut`` (every frame kept, empty or not) and, for each, its index
    in ``detections.points``."""
    keep = detections.points[:, 0] <= cut
    kept = np.flatnonzero(keep)
    offsets = np.concatenate([[0], np.cumsum(keep)]).astype(np.int64)[detections.offsets]
    stream = Detections(
        detections.points[kept],
        offsets,
        detections.ids[kept],
        first_frame=detections.first_frame,
        times=detections.times,
    )
    return stream, kept


def check_sorting(
    agent: Any,
    detections: Detections,
    spec: SensorSpec,
    line: float,
    cut: float,
    *,
    reference: Tracks | None = None,
    seed: int | None = 0,
    lateral_tolerance: float = LATERAL_TOLERANCE,
    time_tolerance: float = TIME_TOLERANCE,
    min_seen: int = MIN_SEEN,
) -> SortingCheck:
    """Score ``agent``'s predicted crossings of the virtual line ``x = line`` made from the
    detections at ``x <= cut`` against the crossings of its tracks of the whole recording (module
    docstring).

    Args:
        agent: A tracker with a sorting channel (the gnn agent), or its registered name; reset
            before each run.
        detections: The recording.
        spec: Its sensor spec (``run_agent``'s); the line and the cut-off must lie inside its
            region's ``x`` range.
        line: ``L``.
        cut: ``x_cut < L``.
        reference: The agent's tracks of the whole recording when already made with ``spec``
            and ``seed`` (saves the reference run).
        seed: The agent's seed in both runs.
        lateral_tolerance: ``w_y``, the lateral tolerance of a hit (detection units).
        time_tolerance: ``w_t``, the time tolerance of a hit (s).
        min_seen: Fewest detections at ``x <= cut`` for a crossing track to be scored.

    Raises:
        ValueError: a line or cut outside the region or in the wrong order, a bad tolerance (each
            named, with its value), or an agent without a sorting channel.
    """
    line, cut = check_line_and_cut(spec, line, cut)
    check_tolerances(lateral_tolerance, time_tolerance, min_seen)
    if isinstance(agent, str):
        agent = make_agent(agent)
    # (imported here, not at the top: the file engine collects predictions with agents.sorting,
    # whose package imports this module)
    from agents.files.points import run_agent

    if reference is None:
        reference = run_agent(agent, detections, spec, seed=seed)
    observed = observed_crossings(reference, detections, line, spec.dt)
    # the reference track of every detection (−1: none)
    _, ids, index = updated_detections(reference, detections)
    owner = np.full(len(detections), -1, dtype=np.int64)
    owner[index] = ids
    upstream, counts = seen_upstream(reference, detections, cut)
    scored = upstream[counts >= min_seen]

    stream, kept = cut_stream(detections, cut)
    cut_spec = dataclasses.replace(spec, region_high=(cut, *spec.region_high[1:]), sorting_line=None)
    cut_tracks, made = run_agent(agent, stream, cut_spec, seed=seed, sorting_line=line)
    last = made.last()
    # each cut-run track's last detection, and the reference track updated with it
    _, c_ids, c_index = updated_detections(cut_tracks, stream)
    final = np.r_[c_ids[1:] != c_ids[:-1], True] if len(c_ids) else np.zeros(0, dtype=bool)
    track_ids, track_last = c_ids[final], c_index[final]
    at = np.searchsorted(track_ids, last.ids)
    full_index = kept[track_last[at]]
    track = owner[full_index]
    x_seen = detections.points[full_index, 0]

    as_reference = PredictedCrossings(track, last.frame, last.mean, last.cov, line)
    score = score_crossings(
        as_reference,
        observed,
        scored,
        spec.dt,
        lateral_tolerance=lateral_tolerance,
        time_tolerance=time_tolerance,
        end_time=(detections.n_frames - 1) * spec.dt,
    )
    o_at = np.minimum(np.searchsorted(observed.ids, track), max(len(observed) - 1, 0))
    crossed = observed.ids[o_at] == track if len(observed) else np.zeros(len(track), dtype=bool)
    t_true = np.where(crossed, observed.t[o_at] if len(observed) else np.nan, np.nan)
    y_true = np.where(crossed, observed.y[o_at] if len(observed) else np.nan, np.nan)
    predictions = dataclasses.replace(
        last, extra={"track": track.astype(np.float64), "x_seen": x_seen, "t_true": t_true, "y_true": y_true}
    )
    # the distance to the line of each scored prediction (the last per reference track)
    rows = _last_rows(track)
    order = np.argsort(track[rows], kind="stable")
    distance = (line - x_seen[rows])[order][np.searchsorted(track[rows][order], score.ids)]
    return SortingCheck(line, cut, score, predictions, observed, distance, full_index)


def _last_rows(ids: NDArray[np.int64]) -> NDArray[np.int64]:
    """Rows of the last occurrence of each id, in row order (as ``PredictedCrossings.last``)."""
    _, first_reversed = np.unique(ids[::-1], return_index=True)
    return np.sort(len(ids) - 1 - first_reversed)
