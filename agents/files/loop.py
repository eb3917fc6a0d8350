"""The loop of [`agents.files.points.run_agent`][agents.run_agent]: any agent over a stream of detections.

[`track_detections`][agents.files.loop.track_detections] is the loop of the tracking contract without an
environment: it packs each frame's detections into an observation
([`track_envs.contracts.observation.pack_observation`][track_envs.contracts.pack_observation], rows in the
recorded order), hands it to ``agent.act`` and keeps the report. Observations are packed a block of frames at
a time into one array (no per-frame allocation; a block holds about ``BLOCK_ROWS`` rows,
[`block_frames`][agents.files.loop.block_frames], so that at 10^5 detections a frame it is one frame and the
loop's memory stays that of a frame or two, not of the stream padded), and the reports' arrays (not the report
dicts: a block of retained dicts made Python's garbage collector scan the heap, 10 µs a frame) are turned into
[`Tracks`][track_envs.Tracks] a block at a time (one vectorised gather), so the loop adds little to the
agent's own time per frame (BENCHMARKS.md).

Where the detections are boxes ([`boxes`][track_envs.values.detections.Detections.boxes]), every row of
the tracks carries the box of the detection its track was updated with that frame, and while it
coasts the last box it had ([`track_envs.values.tracks.carried_boxes`][track_envs.values.carried_boxes], one
vectorised pass after the loop).

An agent whose tracks have covariances declares the ``TRACK_COVARIANCES`` capability
([`agents.base`][agents.base]): ``track_covariances()`` returns the (n, D, D) covariances of the live rows
of its last report, in row order (the GNN tracker: its predictor's estimate); ``covariance=True``
collects them.

This module is the part that the sensor-model estimate
([`agents.sensor_model.estimate`][agents.sensor_model.estimate], which tracks the stream with trial settings)
and [`run_agent`][agents.run_agent] (which can estimate the sensor model first,
``estimate_sensor_model=True``) share: it knows nothing of the estimate.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.base import AgentCapability, agent_capability
from agents.files.kinds import check_file_agent
from agents.sorting.collect import SortingCollector, sorting_spec
from track_envs.contracts.report import ReportOverflowError, fixed_reports, growable_reports
from track_envs.io.crossings import PredictedCrossings
from track_envs.values.detections import Detections
from track_envs.values.tracks import Tracks, carried_boxes
from track_envs.values.types import SensorSpec

#: Report rows (frames × max_tracks) per block of frames packed and gathered at once: the
#: per-block costs are spread over many frames of small reports, and large reports stay in cache.
BLOCK_ROWS = 32768
#: Most frames in a block (small reports).
MAX_BLOCK_FRAMES = 4096


def block_frames(spec: SensorSpec) -> int:
    """Frames per block of [`track_detections`][agents.files.loop.track_detections]' loop: ``BLOCK_ROWS`` rows
    of the larger of an observation and a report, between 1 and ``MAX_BLOCK_FRAMES`` frames — so that the
    block's packed observations and kept reports take ``O(BLOCK_ROWS + max_detections + max_tracks)``
    memory, a frame or two at 10^5 detections a frame, never the whole stream padded."""
    rows = max(spec.max_tracks, spec.max_detections, 1)
    return int(np.clip(BLOCK_ROWS // rows, 1, MAX_BLOCK_FRAMES))


def packed_block(
    detections: Detections, start: int, stop: int, spec: SensorSpec
) -> tuple[NDArray[np.float32], NDArray[np.int8]]:
    """Observations of frames ``start:stop`` as arrays (frames, max_detections, D) float32 and
    (frames, max_detections) int8: frame ``t``'s detections in rows ``0..m_t-1``, in order."""
    lo, hi = detections.offsets[start], detections.offsets[stop]
    counts = np.diff(detections.offsets[start : stop + 1])
    frame = np.repeat(np.arange(stop - start), counts)
    slot = np.arange(hi - lo) - np.repeat(detections.offsets[start:stop] - lo, counts)
    det = np.zeros((stop - start, spec.max_detections, spec.dim), dtype=np.float32)
    mask = np.zeros((stop - start, spec.max_detections), dtype=np.int8)
    det[frame, slot] = detections.points[lo:hi]
    mask[frame, slot] = 1
    return det, mask


def track_detections(
    agent: Any,
    stream: Detections,
    spec: SensorSpec,
    *,
    seed: int | None = 0,
    covariance: bool = False,
    progress: bool = False,
    reset: bool = True,
    grow: bool = True,
    sorting_line: float | None = None,
) -> Tracks | tuple[Tracks, PredictedCrossings]:
    """Track ``stream`` with ``agent`` (an Agent object): [`agents.files.points.run_agent`][agents.run_agent]
    without its conveniences (an agent by name, ``estimate_sensor_model``); the arguments, the result and the
    errors are run_agent's (its docstring). Its warnings name the line that called run_agent.
    """
    check_file_agent(agent, "point", flag="")
    if stream.dim != spec.dim:
        raise ValueError(f"the detections are {stream.dim}-d but the sensor spec is {spec.dim}-d")
    counts = stream.counts
    if stream.n_frames and counts.max() > spec.max_detections:
        t = int(np.argmax(counts > spec.max_detections))
        raise ValueError(
            f"frame {t} holds {counts[t]} detections, more than max_detections={spec.max_detections}; "
            f"the fullest frame holds {counts.max()}"
        )
    spec = sorting_spec(spec, sorting_line)
    while True:
        sorting = None if sorting_line is None else SortingCollector(agent, spec.sorting_line)  # type: ignore[arg-type]
        if reset:
            agent.reset(spec, seed=seed)
        try:
            # a sorting channel has max_tracks rows: a run that collects one grows by running again
            growable = grow and sorting_line is None
            with growable_reports() if growable else fixed_reports():
                return _run(agent, stream, spec, sorting, covariance=covariance, progress=progress)
        except ReportOverflowError as exc:
            if not (grow and reset):
                raise
            rows = max(2 * spec.max_tracks, 2 * exc.n_tracks)
            warnings.warn(
                f"{exc.n_tracks} live tracks did not fit a report of max_tracks={spec.max_tracks}; "
                f"tracking again with max_tracks={rows}",
                RuntimeWarning,
                stacklevel=3,
            )
            spec = dataclasses.replace(spec, max_tracks=rows)


def _run(
    agent: Any,
    stream: Detections,
    spec: SensorSpec,
    sorting: SortingCollector | None,
    *,
    covariance: bool,
    progress: bool,
) -> Tracks | tuple[Tracks, PredictedCrossings]:
    """The loop of [`run_agent`][agents.run_agent] over a reset agent (with ``sorting``: its crossings
    too)."""
    declared = agent_capability(agent, AgentCapability.TRACK_COVARIANCES) if covariance else None
    covariances = declared.track_covariances if declared is not None else None
    bar = _progress(stream.n_frames, progress)
    act = agent.act
    block = block_frames(spec)
    parts: list[Tracks] = []
    most = spec.max_tracks  # the most rows a report had (more than max_tracks: grown)
    try:
        for start in range(0, stream.n_frames, block):
            stop = min(start + block, stream.n_frames)
            det, mask = packed_block(stream, start, stop, spec)
            kept = _Kept(covariances is not None, start)
            for t, (frame_detections, frame_mask) in enumerate(zip(det, mask, strict=True)):
                report = act({"detections": frame_detections, "mask": frame_mask})
                rows = len(report["mask"])
                if rows != kept.rows and kept.frames:  # a grown report: the frames before are gathered
                    parts.append(kept.tracks())
                    kept = _Kept(covariances is not None, start + t)
                kept.add(report, covariances)
                most = max(most, rows)
                if sorting is not None:
                    sorting.add(report)
            if sorting is not None:
                sorting.gather()
            parts.append(kept.tracks())
            if bar is not None:
                bar.update(stop - start)
    finally:
        if bar is not None:
            bar.close()
    if most > spec.max_tracks:
        warnings.warn(
            f"{most} live tracks did not fit a report of max_tracks={spec.max_tracks}; the reports grew "
            f"to hold them (as a run with max_tracks={most} reports them)",
            RuntimeWarning,
            stacklevel=4,
        )
    tracks = Tracks.concatenate(parts, stream.n_frames)
    if stream.boxes is not None and tracks.detection is not None:
        tracks = tracks.with_boxes(carried_boxes(tracks, stream.boxes, stream.offsets))
    return tracks if sorting is None else (tracks, sorting.result())


class _Kept:
    """The reports' arrays of consecutive frames of one report size, from frame ``first`` on,
    kept by reference until [`tracks`][agents.files.loop._Kept.tracks] gathers them (one vectorised
    gather)."""

    def __init__(self, covariance: bool, first: int) -> None:
        self.first, self.rows, self.frames = first, -1, 0
        self.ids: list[NDArray] = []
        self.positions: list[NDArray] = []
        self.detection: list[NDArray] = []
        self.live: list[NDArray] = []
        self.covs: list[NDArray | None] | None = [] if covariance else None

    def add(self, report: Mapping[str, NDArray], covariances: Any) -> None:
        self.ids.append(report["ids"])
        self.positions.append(report["positions"])
        self.detection.append(report["detection"])
        self.live.append(report["mask"])
        if self.covs is not None:
            self.covs.append(covariances())
        self.rows = len(report["mask"])
        self.frames += 1

    def tracks(self) -> Tracks:
        return Tracks.from_columns(
            self.ids, self.positions, self.detection, self.live, covariances=self.covs, first_frame=self.first
        )


def _progress(total: int, enabled: bool) -> Any:
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit="frame", desc="track run", dynamic_ncols=True)
