"""A recorded stream of point detections without identities, frame by frame.

[`Detections`][track_envs.Detections] holds every frame's detections in one flat array (CSR layout: frame
``t`` owns rows ``offsets[t]:offsets[t + 1]`` of ``points``), so that a stream of 50,000 frames is a
few arrays, not 50,000 small ones. The file readers of [`track_envs.io.detections`][track_envs.io.detections]
return it; [`DetectionReplayEnv`][track_envs.envs.DetectionReplayEnv] replays it and
``agents.files.points.run_agent`` tracks it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from track_envs.values.types import SensorSpec


@dataclass(frozen=True, eq=False)
class Detections:
    """Per-frame point detections (frame ``t`` = the ``t``-th frame of the stream, from 0).

    Attributes:
        points: (N, D) float64 positions of every detection, frame by frame.
        offsets: (n_frames + 1,) int64, non-decreasing, ``offsets[0] = 0``, ``offsets[-1] = N``:
            frame ``t`` holds ``points[offsets[t]:offsets[t + 1]]`` (an empty frame has none).
        ids: (N,) int64 truth id behind each detection where the file gives one (a simulated
            recording's MOT ``id`` column), −1 for clutter or unknown.
        first_frame: The file's frame number of frame 0 (1 for MOTChallenge files).
        times: (n_frames,) float64 time stamps in seconds where the file has a time column, else None.
        boxes: (N, 4) float64 box of every detection, ``(left, top, width, height)`` in the units
            of ``points`` (a MOTChallenge file's ``bb_left, bb_top, bb_width, bb_height``), or None
            for point detections. A box's centre is its point: ``points = (left + width / 2,
            top + height / 2)`` as the reader computes it.
    """

    points: NDArray[np.float64]
    offsets: NDArray[np.int64]
    ids: NDArray[np.int64] = None  # type: ignore[assignment]
    first_frame: int = 0
    times: NDArray[np.float64] | None = None
    boxes: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        points = np.ascontiguousarray(self.points, dtype=np.float64)
        offsets = np.ascontiguousarray(self.offsets, dtype=np.int64)
        if points.ndim != 2 or points.shape[1] < 1:
            raise ValueError(f"Detections.points must have shape (N, D), got {points.shape}")
        if offsets.ndim != 1 or len(offsets) < 1 or offsets[0] != 0 or offsets[-1] != len(points):
            raise ValueError(
                f"Detections.offsets must run from 0 to N={len(points)} (n_frames + 1 entries), got "
                f"{offsets[:3].tolist()}...{offsets[-3:].tolist()}"
            )
        if np.any(np.diff(offsets) < 0):
            raise ValueError("Detections.offsets must be non-decreasing")
        if not np.isfinite(points).all():
            raise ValueError("Detections.points must be finite")
        ids = np.full(len(points), -1, np.int64) if self.ids is None else np.asarray(self.ids, np.int64)
        if ids.shape != (len(points),):
            raise ValueError(f"Detections.ids must have shape ({len(points)},), got {ids.shape}")
        times = self.times
        if times is not None:
            times = np.asarray(times, dtype=np.float64)
            if times.shape != (len(offsets) - 1,):
                raise ValueError(f"Detections.times must have shape ({len(offsets) - 1},), got {times.shape}")
        boxes = self.boxes
        if boxes is not None:
            boxes = np.ascontiguousarray(boxes, dtype=np.float64)
            if boxes.shape != (len(points), 4):
                raise ValueError(f"Detections.boxes must have shape ({len(points)}, 4), got {boxes.shape}")
            if not np.isfinite(boxes).all() or np.any(boxes[:, 2:] < 0):
                raise ValueError("Detections.boxes must be finite with width and height >= 0")
        object.__setattr__(self, "boxes", boxes)
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "offsets", offsets)
        object.__setattr__(self, "ids", ids)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "first_frame", int(self.first_frame))

    # -- construction -------------------------------------------------------------------------
    @classmethod
    def from_frames(
        cls,
        frames: Sequence[ArrayLike],
        ids: Sequence[ArrayLike] | None = None,
        *,
        first_frame: int = 0,
        times: ArrayLike | None = None,
    ) -> Detections:
        """Detections from one (m_t, D) array per frame (and optionally one (m_t,) id array per frame)."""
        arrays = [np.asarray(f, dtype=np.float64) for f in frames]
        dim = next((a.shape[1] for a in arrays if a.ndim == 2), 2)
        arrays = [a.reshape(-1, dim) for a in arrays]
        counts = np.array([len(a) for a in arrays], dtype=np.int64)
        offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        points = np.concatenate(arrays) if arrays else np.zeros((0, dim))
        flat_ids = (
            np.full(len(points), -1, np.int64)
            if ids is None
            else np.concatenate([np.asarray(i, np.int64).reshape(-1) for i in ids] or [np.zeros(0, np.int64)])
        )
        return cls(points, offsets, flat_ids, first_frame, None if times is None else np.asarray(times))

    # -- access -------------------------------------------------------------------------------
    @property
    def n_frames(self) -> int:
        """Frames in the stream (empty frames included)."""
        return len(self.offsets) - 1

    @property
    def dim(self) -> int:
        """Dimension ``D`` of a detection."""
        return int(self.points.shape[1])

    @property
    def counts(self) -> NDArray[np.int64]:
        """(n_frames,) detections per frame."""
        return np.diff(self.offsets)

    @property
    def max_per_frame(self) -> int:
        """The most detections in any frame (0 for a stream without any)."""
        return int(self.counts.max()) if self.n_frames else 0

    @property
    def has_ids(self) -> bool:
        """Whether any detection carries a truth id (>= 0)."""
        return bool(np.any(self.ids >= 0))

    def __len__(self) -> int:
        return int(self.points.shape[0])

    def frame(self, t: int) -> NDArray[np.float64]:
        """The (m_t, D) detections of frame ``t``."""
        return self.points[self.offsets[t] : self.offsets[t + 1]]

    def frame_boxes(self, t: int) -> NDArray[np.float64] | None:
        """The (m_t, 4) boxes of frame ``t``'s detections, or None for point detections."""
        return None if self.boxes is None else self.boxes[self.offsets[t] : self.offsets[t + 1]]

    def frame_ids(self, t: int) -> NDArray[np.int64]:
        """The (m_t,) truth ids of frame ``t``'s detections (−1: none)."""
        return self.ids[self.offsets[t] : self.offsets[t + 1]]

    def frame_index(self) -> NDArray[np.int64]:
        """(N,) the frame of every detection."""
        return np.repeat(np.arange(self.n_frames, dtype=np.int64), self.counts)

    def bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Lower and upper corner (D,) of every detection (ValueError for a stream without any)."""
        if not len(self):
            raise ValueError("the stream holds no detection: its bounding box is undefined")
        return self.points.min(axis=0), self.points.max(axis=0)

    def inferred_dt(self) -> float | None:
        """The median frame period of the time stamps, ``median((t_j − t_i) / (j − i))`` over
        consecutive frames ``i < j`` that have one, or None without (or with too few) times."""
        if self.times is None:
            return None
        known = np.flatnonzero(np.isfinite(self.times))  # frames missing from a file have no time
        if len(known) < 2:
            return None
        dt = float(np.median(np.diff(self.times[known]) / np.diff(known)))
        return dt if np.isfinite(dt) and dt > 0 else None

    def equals(self, other: Detections) -> bool:
        """Whether both streams hold the same frames, points, ids, first frame, times and boxes, bit
        for bit."""
        same_times = (self.times is None and other.times is None) or (
            self.times is not None
            and other.times is not None
            and np.array_equal(self.times, other.times, equal_nan=True)
        )
        same_boxes = (self.boxes is None and other.boxes is None) or (
            self.boxes is not None and other.boxes is not None and np.array_equal(self.boxes, other.boxes)
        )
        return (
            np.array_equal(self.offsets, other.offsets)
            and np.array_equal(self.points, other.points)
            and np.array_equal(self.ids, other.ids)
            and self.first_frame == other.first_frame
            and same_times
            and same_boxes
        )


def detection_sensor_spec(
    detections: Detections,
    *,
    dt: float | None = None,
    region: tuple[tuple[float, float], tuple[float, float]] | None = None,
    measurement_noise_std: float = 0.0,
    p_detect: float = 1.0,
    clutter_rate: float = 0.0,
    max_detections: int | None = None,
    max_tracks: int | None = None,
    units: str = "m",
) -> SensorSpec:
    """The sensor spec of a recorded stream: what is given, the rest inferred from the detections.

    Args:
        detections: The stream.
        dt: Frame period in seconds; ``None``: inferred from the stream's time stamps
            ([`Detections.inferred_dt`][track_envs.Detections.inferred_dt]), an error without them.
        region: ``((x_low, y_low), (x_high, y_high))``; ``None``: the bounding box of every
            detection grown by 2% of its size on each side.
        measurement_noise_std: The declared measurement noise std per axis (the tracker's ``R``),
            in the detections' units (after ``scale``); a recording adds none, it *has* noise.
        p_detect: Declared detection probability.
        clutter_rate: Declared clutter rate per frame.
        max_detections: Rows of an observation; default the most detections in a frame (at
            least 16). Smaller than that most is an error.
        max_tracks: Rows of a report; default twice the most detections in a frame (at least 16).
        units: Name of the unit, for tables.

    Raises:
        ValueError: naming the argument that is missing or out of range.
    """
    from track_envs.infra.arguments import (
        check_int,
        check_non_negative,
        check_positive,
        check_probability,
        check_vector,
    )

    most = detections.max_per_frame
    if dt is None:
        dt = detections.inferred_dt()
        if dt is None:
            raise ValueError(
                "dt (the frame period in seconds) is not given and the stream has no time stamps to infer it "
                "from; pass dt (track run: --dt) or read a time column (time_column=...)"
            )
    dt = check_positive("dt", dt)
    if region is None:
        low, high = detections.bounds() if len(detections) else (np.zeros(2), np.ones(2))
        pad = 0.02 * np.maximum(high - low, 1e-9)
        low, high = low - pad, high + pad
    else:
        corners = region if isinstance(region, tuple | list) and len(region) == 2 else (None, None)
        low = check_vector("region[0]", corners[0], detections.dim)
        high = check_vector("region[1]", corners[1], detections.dim)
        if np.any(low >= high):
            raise ValueError(
                f"region must be ((x_low, y_low), (x_high, y_high)) with low < high, got {region!r}"
            )
    max_detections = (
        max(most, 16) if max_detections is None else check_int("max_detections", max_detections, 1)
    )
    if max_detections < most:
        raise ValueError(
            f"max_detections={max_detections} is below the {most} detections of the fullest frame; "
            f"give at least {most}"
        )
    max_tracks = max(2 * most, 16) if max_tracks is None else check_int("max_tracks", max_tracks, 1)
    return SensorSpec(
        dt=dt,
        dim=detections.dim,
        noise_std=check_non_negative("measurement_noise_std", measurement_noise_std),
        p_detect=check_probability("p_detect", p_detect),
        clutter_rate=check_non_negative("clutter_rate", clutter_rate),
        region_low=tuple(float(v) for v in low),
        region_high=tuple(float(v) for v in high),
        max_detections=int(max_detections),
        max_tracks=int(max_tracks),
        units=units,
    )
