"""Tracks over a whole stream: what a tracker reported (or the truth), one row per (frame, track).

[`Tracks`][track_envs.Tracks] is the long layout every track file maps to: ``frame`` (from 0), ``ids``,
``positions`` and, where a predictor gives one, the covariance of each position, and where the
detections were boxes, the box of each row. It converts from
the per-frame reports of the tracking contract ([`Tracks.from_reports`][track_envs.Tracks.from_reports]) and
to the per-frame padded arrays the streaming metrics take
([`Tracks.padded_frame`][track_envs.Tracks.padded_frame]).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: Reports of at most this many rows are gathered whole (one copy beats a slice per report).
_FEW_ROWS = 64


@dataclass(frozen=True, eq=False)
class Tracks:
    """Rows ``(frame, id, position[, covariance][, detection][, box])``, sorted by frame.

    Attributes:
        frame: (N,) int64 frame index from 0, non-decreasing.
        ids: (N,) int64 track (or truth) id; distinct within a frame.
        positions: (N, D) float64.
        n_frames: Frames of the stream (frames without rows included), >= ``frame.max() + 1``.
        cov: (N, D, D) float64 covariance of each position, or None.
        detection: (N,) int64 index of the detection (within its frame) the track was updated
            with, −1 where it coasted, or None.
        boxes: (N, 4) float64 box of each row, ``(left, top, width, height)`` (MOTChallenge's
            ``bb_left, bb_top, bb_width, bb_height``; NaN: a row without a box), or None. A
            tracker's row carries the box of the detection it was updated with, and while it
            coasts the last box it had ([`carried_boxes`][track_envs.values.carried_boxes]).
    """

    frame: NDArray[np.int64]
    ids: NDArray[np.int64]
    positions: NDArray[np.float64]
    n_frames: int
    cov: NDArray[np.float64] | None = None
    detection: NDArray[np.int64] | None = None
    boxes: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        frame = np.ascontiguousarray(self.frame, dtype=np.int64).reshape(-1)
        ids = np.ascontiguousarray(self.ids, dtype=np.int64).reshape(-1)
        positions = np.ascontiguousarray(self.positions, dtype=np.float64)
        n = len(frame)
        if positions.ndim != 2 or len(positions) != n or ids.shape != (n,):
            raise ValueError(
                f"Tracks need frame (N,), ids (N,) and positions (N, D); got {frame.shape}, {ids.shape}, "
                f"{positions.shape}"
            )
        if n and (np.any(np.diff(frame) < 0) or frame[0] < 0):
            raise ValueError("Tracks.frame must be non-negative and non-decreasing (rows sorted by frame)")
        n_frames = int(self.n_frames)
        if n and n_frames <= frame[-1]:
            raise ValueError(f"Tracks.n_frames={n_frames} must exceed the last frame {frame[-1]}")
        object.__setattr__(self, "frame", frame)
        object.__setattr__(self, "ids", ids)
        object.__setattr__(self, "positions", positions)
        object.__setattr__(self, "n_frames", n_frames)
        if self.cov is not None:
            cov = np.ascontiguousarray(self.cov, dtype=np.float64)
            d = positions.shape[1]
            if cov.shape != (n, d, d):
                raise ValueError(f"Tracks.cov must have shape ({n}, {d}, {d}), got {cov.shape}")
            object.__setattr__(self, "cov", cov)
        if self.detection is not None:
            detection = np.ascontiguousarray(self.detection, dtype=np.int64).reshape(-1)
            if detection.shape != (n,):
                raise ValueError(f"Tracks.detection must have shape ({n},), got {detection.shape}")
            object.__setattr__(self, "detection", detection)
        if self.boxes is not None:
            boxes = np.ascontiguousarray(self.boxes, dtype=np.float64)
            if boxes.shape != (n, 4):
                raise ValueError(f"Tracks.boxes must have shape ({n}, 4), got {boxes.shape}")
            object.__setattr__(self, "boxes", boxes)

    def __len__(self) -> int:
        return len(self.frame)

    @property
    def offsets(self) -> NDArray[np.int64]:
        """(n_frames + 1,): frame ``t`` holds rows ``offsets[t]:offsets[t + 1]``."""
        return np.searchsorted(self.frame, np.arange(self.n_frames + 1)).astype(np.int64)

    @classmethod
    def from_reports(
        cls,
        reports: Sequence[Mapping[str, NDArray]],
        covariances: Sequence[NDArray | None] | None = None,
        first_frame: int = 0,
    ) -> Tracks:
        """Tracks from one report (the action dict: ``ids``, ``positions``, ``detection``, ``mask``)
        per frame, and optionally the (n_live, D, D) covariances of each report's live rows in row
        order (all or none: a None entry drops the covariance). Frame ``t`` of the result is
        ``reports[t - first_frame]``."""
        columns = [[r[key] for r in reports] for key in ("ids", "positions", "detection", "mask")]
        return cls.from_columns(*columns, covariances=covariances, first_frame=first_frame)

    @classmethod
    def from_columns(
        cls,
        ids: Sequence[NDArray],
        positions: Sequence[NDArray],
        detection: Sequence[NDArray],
        mask: Sequence[NDArray],
        *,
        covariances: Sequence[NDArray | None] | None = None,
        first_frame: int = 0,
    ) -> Tracks:
        """[`from_reports`][track_envs.Tracks.from_reports] with the reports' arrays given key by key (one
        list per key, one array per frame), which is how [`agents.files.points.run_agent`][agents.run_agent]
        keeps them: arrays, not dicts, so that the reports of a block hold no objects Python's garbage
        collector scans."""
        if not len(mask):
            return cls(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2)), first_frame)
        n, rows = len(mask), len(mask[0])
        live = np.concatenate(mask) == 1  # (frames * rows,)
        counts = live.reshape(n, rows).sum(axis=1)
        frame_of = np.repeat(np.arange(n), counts)
        keyed = (ids, positions, detection)
        prefix = rows > _FEW_ROWS and np.array_equal(live.reshape(n, rows), np.arange(rows) < counts[:, None])
        if prefix:  # many rows, the live ones first (pack_report): copy those only
            n_live = counts.tolist()
            out = [np.concatenate([a[:k] for a, k in zip(arrays, n_live, strict=True)]) for arrays in keyed]
        else:  # few rows (or live rows anywhere): everything, then the live rows
            out = [np.concatenate(arrays)[live] for arrays in keyed]
        cov = None
        if covariances is not None and all(c is not None for c in covariances):
            cov = np.concatenate([np.asarray(c, dtype=np.float64) for c in covariances if c is not None])
            if len(cov) != len(out[0]):
                cov = None
        return cls(frame_of + first_frame, out[0], out[1], n + first_frame, cov, out[2])

    @classmethod
    def concatenate(cls, parts: Sequence[Tracks], n_frames: int = 0) -> Tracks:
        """The rows of ``parts`` in order (each part's frames after the previous part's), in a
        stream of at least ``n_frames`` frames; covariances, detections and boxes kept if every
        part has them."""
        if not parts:
            return cls(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2)), n_frames)

        def joined(name: str) -> NDArray | None:
            arrays = [getattr(p, name) for p in parts]
            return None if any(a is None for a in arrays) else np.concatenate(arrays)

        return cls(
            np.concatenate([p.frame for p in parts]),
            np.concatenate([p.ids for p in parts]),
            np.concatenate([p.positions for p in parts]),
            max(n_frames, *(p.n_frames for p in parts)),
            joined("cov"),
            joined("detection"),
            joined("boxes"),
        )

    def with_frames(self, n_frames: int) -> Tracks:
        """The same rows in a stream of ``max(n_frames, self.n_frames)`` frames."""
        return Tracks(
            self.frame,
            self.ids,
            self.positions,
            max(n_frames, self.n_frames),
            self.cov,
            self.detection,
            self.boxes,
        )

    def updated_rows(self) -> Tracks:
        """Only the rows of tracks updated with a detection in their frame (``detection >= 0``):
        the coasting rows dropped, as MOTChallenge trackers write their output (a box where the
        object was seen). Tracks without detection rows are returned as they are."""
        if self.detection is None:
            return self
        keep = self.detection >= 0

        def rows(a: NDArray | None) -> NDArray | None:
            return None if a is None else a[keep]

        return Tracks(
            self.frame[keep],
            self.ids[keep],
            self.positions[keep],
            self.n_frames,
            rows(self.cov),
            rows(self.detection),
            rows(self.boxes),
        )

    def with_boxes(self, boxes: NDArray[np.float64] | None) -> Tracks:
        """The same rows with ``boxes`` (N, 4) (None: without boxes)."""
        return Tracks(self.frame, self.ids, self.positions, self.n_frames, self.cov, self.detection, boxes)

    # -- the wide layout (one row per frame, one (x, y) pair per id) ---------------------------
    def to_wide(self) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """``(positions (n_frames, n_ids, D) NaN where an id has no row, ids (n_ids,) sorted)``:
        column pair ``k`` is the ``k``-th smallest id."""
        unique, column = np.unique(self.ids, return_inverse=True)
        grid = np.full((self.n_frames, len(unique), self.positions.shape[1]), np.nan)
        grid[self.frame, column.reshape(-1)] = self.positions
        return grid, unique

    @classmethod
    def from_wide(cls, grid: NDArray[np.floating], ids: NDArray[np.integer] | None = None) -> Tracks:
        """Tracks from (n_frames, n_ids, D) positions, NaN where an id has no row; column ``k`` has
        id ``ids[k]`` (default ``k``)."""
        values = np.asarray(grid, dtype=np.float64)
        frame, column = np.nonzero(np.isfinite(values).all(axis=2))
        names = np.arange(values.shape[1]) if ids is None else np.asarray(ids, dtype=np.int64)
        return cls(frame, names[column], values[frame, column], values.shape[0])

    # -- per frame ----------------------------------------------------------------------------
    def padded_frame(self, lo: int, hi: int, rows: int) -> dict[str, NDArray]:
        """Rows ``lo:hi`` (one frame's) as a report dict padded to ``rows`` rows (also the padded
        truth layout: ``ids`` −1 on padding, ``visible`` True on real rows; ``boxes`` (rows, 4),
        NaN on padding, where the tracks have boxes)."""
        n = hi - lo
        if n > rows:
            raise ValueError(f"a frame holds {n} rows, more than the {rows} rows to pad to")
        d = self.positions.shape[1]
        ids = np.full(rows, -1, dtype=np.int64)
        ids[:n] = self.ids[lo:hi]
        positions = np.zeros((rows, d))
        positions[:n] = self.positions[lo:hi]
        detection = np.full(rows, -1, dtype=np.int64)
        if self.detection is not None:
            detection[:n] = self.detection[lo:hi]
        mask = np.zeros(rows, dtype=np.int8)
        mask[:n] = 1
        frame = {
            "ids": ids,
            "positions": positions,
            "detection": detection,
            "mask": mask,
            "visible": mask == 1,
        }
        if self.boxes is not None:
            boxes = np.full((rows, 4), np.nan)
            boxes[:n] = self.boxes[lo:hi]
            frame["boxes"] = boxes
        return frame

    def equals(self, other: Tracks, *, covariance: bool = True) -> bool:
        """Same rows bit for bit (and the same covariances, when ``covariance`` and both have them;
        the same boxes, NaN equal to NaN, when both have them)."""
        same = (
            self.n_frames == other.n_frames
            and np.array_equal(self.frame, other.frame)
            and np.array_equal(self.ids, other.ids)
            and np.array_equal(self.positions, other.positions)
        )
        if same and covariance and self.cov is not None and other.cov is not None:
            same = np.array_equal(self.cov, other.cov)
        if same and self.boxes is not None and other.boxes is not None:
            same = np.array_equal(self.boxes, other.boxes, equal_nan=True)
        return bool(same)


def carried_boxes(
    tracks: Tracks, boxes: NDArray[np.float64], offsets: NDArray[np.int64]
) -> NDArray[np.float64]:
    """The box of every row of a tracker's ``tracks``: that of the detection the track was updated
    with (``tracks.detection``, a row within its frame of detections whose boxes are
    ``boxes[offsets[t]:offsets[t + 1]]``), and while it coasts (−1) the last box it had; NaN before
    its first update.

    Vectorised: rows sorted by (id, frame), each row takes the box of the latest updated row at or
    before it (a running maximum of updated row positions) if that row belongs to the same id.
    """
    if tracks.detection is None:
        raise ValueError("carried_boxes needs the tracks' detection rows (Tracks.detection)")
    n = len(tracks)
    out = np.full((n, 4), np.nan)
    if not n:
        return out
    order = np.lexsort((tracks.frame, tracks.ids))  # by id, then frame
    ids, frame, det = tracks.ids[order], tracks.frame[order], tracks.detection[order]
    updated = (det >= 0) & (det < offsets[frame + 1] - offsets[frame])
    position = np.where(updated, np.arange(n), -1)
    last = np.maximum.accumulate(position)  # latest updated position at or before each row
    start = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]])
    group_start = np.repeat(start, np.diff(np.r_[start, n]))
    carried = last >= group_start  # the latest update belongs to this id
    source = last[carried]
    out_sorted = np.full((n, 4), np.nan)
    out_sorted[carried] = boxes[offsets[frame[source]] + det[source]]
    out[order] = out_sorted
    return out
