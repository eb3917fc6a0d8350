"""Read and write per-frame point detections without identities: MOTChallenge and wide CSV files.

Two layouts (rows in error messages are the file's line numbers, from 1, as an editor shows them;
columns are named by their index from 0 — ``column index 1 ('count')`` — as the column
*selection* arguments count them, as pandas does, or by header name):

**MOTChallenge** ``det.txt`` (Milan, Leal-Taixé, Reid, Roth, Schindler: "MOT16: A Benchmark for
Multi-Object Tracking", 2016): no header, one detection per line,
``frame, id, bb_left, bb_top, bb_width, bb_height, conf, x, y, z`` (later fields optional, at
least the first six). Frames count from 1; ``id`` is −1 in detection files. A point tracker needs
centres, so every box gives its centre ``(bb_left + bb_width / 2, bb_top + bb_height / 2)`` as
:attr:`Detections.points`, and the box itself is kept as :attr:`Detections.boxes`
``(bb_left, bb_top, bb_width, bb_height)`` — unless every box has width and height 0 (a file of
points: ``boxes`` None). ``swap_xy`` swaps the box's axes with the point's (``(bb_top, bb_left,
bb_height, bb_width)``) and ``scale`` multiplies all four numbers, so the box's centre stays the
point. A confidence of −1 means "not given" (MOTChallenge tracker output and MOT15 detections
write it): ``min_confidence`` drops only rows with a confidence below it that is not −1, and a
filter that drops every row is an error naming the confidences the file holds. Rows may come in
any frame order; a frame without a row is an empty frame. An ``id >= 0`` (a simulated
recording's truth id) is kept as :attr:`Detections.ids`. :func:`write_mot_detections` writes each
detection's box (or, for points, a box of ``box_size``, default 0, about the point), the
confidence, and ``-1, -1, -1`` for the world x, y, z.

**Wide per-frame CSV** (the layout sorter software commonly writes): one row per frame, an
optional header, a frame-number column, a count column, optionally a time column (seconds), and
``x, y`` column pairs padded with NaN (or empty cells, or a short row) up to the widest frame::

    frame,count,x0,y0,x1,y1,x2,y2
    0,2,0.1013,0.0223,0.0871,0.1502,NaN,NaN
    1,3,0.1069,0.0224,0.0925,0.1501,0.0312,0.0920

The pairs start after the last of the frame / count / time columns (or where ``xy_columns`` says).
Frame numbers must increase; a gap is a run of empty frames. The count must equal the number of
pairs that hold numbers. ``swap_xy`` swaps the two coordinates (many sorters write the belt
direction as y), ``scale`` multiplies them (pixels to metres: the pixel size).

Both readers raise :class:`~track_envs.io.csv_parser.DetectionFileError` (a ``ValueError``) naming the
file, row and column of the first bad cell: text, an infinity, a half-empty pair, a frame that is
not an integer or goes backwards, a count that disagrees with the pairs. Writers use ``repr`` of
each float, so a file written and read back gives the same detections bit for bit.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from track_envs.io.csv_parser import (
    CHUNK_ROWS,
    DetectionFileError,
    Table,
    chunks,
    first_bad,
    format_rows,
    read_table,
    write_chunks,
)
from track_envs.values.detections import Detections

__all__ = [
    "CONSIDERED",
    "DetectionFileError",
    "MotRows",
    "read_detections",
    "read_mot_detections",
    "read_mot_rows",
    "read_wide_detections",
    "write_mot_detections",
    "write_mot_rows",
    "write_wide_detections",
]

FORMATS = ("mot", "wide")
_MOT_NAMES = ("frame", "id", "bb_left", "bb_top", "bb_width", "bb_height", "conf")


# --------------------------------------------------------------------------------------------- MOT


@dataclass(frozen=True)
class MotRows:
    """The rows of a MOTChallenge file, sorted by frame (stable: file order within a frame).

    Attributes:
        frame: (N,) int64 frame index from 0 (the file's frame number − 1).
        ids: (N,) int64 the file's id column.
        centres: (N, 2) float64 box centres.
        confidence: (N,) float64 (1 where the file has no confidence column; −1: not given).
        n_frames: The last frame number of the file (frames 1..n_frames).
        boxes: (N, 4) float64 ``bb_left, bb_top, bb_width, bb_height``.
    """

    frame: NDArray[np.int64]
    ids: NDArray[np.int64]
    centres: NDArray[np.float64]
    confidence: NDArray[np.float64]
    n_frames: int
    boxes: NDArray[np.float64]

    @property
    def has_boxes(self) -> bool:
        """Whether any row is a box (width or height > 0); a file of points has none."""
        return bool(np.any(self.boxes[:, 2:] > 0))


def read_mot_rows(
    path: str | os.PathLike[str], *, min_confidence: float | None = None, delimiter: str = ","
) -> MotRows:
    """The rows of a MOTChallenge file (detections, tracks or ground truth): boxes and their centres.

    Args:
        path: The file.
        min_confidence: Drop rows whose confidence (column index 6) is below this, except rows
            with −1 ("not given"). For ground truth, 1 keeps the rows flagged "considered"
            (MOT16 and later write 1 or 0 there, MOT15 writes 1): :data:`CONSIDERED`.
        delimiter: Field separator.

    Raises:
        DetectionFileError: naming the row and column of a missing, non-numeric or non-finite
            field among the first six, a frame number that is not an integer >= 1, an id that is
            not an integer, or a negative width or height; and a ``min_confidence`` that drops
            every row (naming the confidences the file holds).
    """
    table = read_table(path, header=False, delimiter=delimiter)
    values = table.values
    if values.shape[1] < 6:
        raise DetectionFileError(
            f"{table.label}: rows have {values.shape[1]} fields; a MOTChallenge row has at least 6 "
            f"({', '.join(_MOT_NAMES[:6])}, ...)"
        )
    head = values[:, :6]
    bad = ~np.isfinite(head)
    if bad.any():
        row, column = first_bad(bad)
        what = "is empty" if np.isnan(head[row, column]) else f"holds {head[row, column]}"
        raise table.error(row, column, f"({_MOT_NAMES[column]}) {what}; expected a finite number")
    frames, ids = head[:, 0], head[:, 1]
    _check_integers(table, frames, 0, "frame", low=1)
    _check_integers(table, ids, 1, "id", low=None)
    negative = head[:, 4:6] < 0
    if negative.any():
        row, k = first_bad(negative)
        raise table.error(
            row, 4 + k, f"({_MOT_NAMES[4 + k]}) holds {float(head[row, 4 + k])!r}; a box's size must be >= 0"
        )
    confidence = values[:, 6] if values.shape[1] > 6 else np.ones(len(values))
    confidence = np.where(np.isnan(confidence), 1.0, confidence)
    centres = np.stack([head[:, 2] + head[:, 4] / 2, head[:, 3] + head[:, 5] / 2], axis=1)
    n_frames = int(frames.max())
    keep = slice(None) if min_confidence is None else _confident(table.label, confidence, min_confidence)
    frame = frames[keep].astype(np.int64) - 1
    # rows already in frame order (as files are written) are kept as they are, without a copy
    order = slice(None) if np.all(frame[1:] >= frame[:-1]) else np.argsort(frame, kind="stable")
    return MotRows(
        frame=frame[order],
        ids=table.integers(1)[keep][order],
        centres=np.ascontiguousarray(centres[keep][order]),
        confidence=confidence[keep][order],
        n_frames=n_frames,
        boxes=np.ascontiguousarray(head[:, 2:6][keep][order]),
    )


#: The ``min_confidence`` that keeps the ground-truth rows flagged "considered" (column index 6
#: is 1, or −1: not given) and drops the others (0), as motmetrics reads MOTChallenge ground truth.
CONSIDERED = 1.0


def _confident(label: str, confidence: NDArray[np.float64], min_confidence: float) -> NDArray[np.bool_]:
    """Rows whose confidence is at least ``min_confidence`` or −1 ("not given"); an error if none."""
    keep = (confidence >= float(min_confidence)) | (confidence == -1)
    if len(keep) and not keep.any():
        raise DetectionFileError(
            f"{label}: min_confidence={min_confidence!r} (track run: --min-confidence) drops every one of "
            f"the {len(keep)} rows; their confidences (column index 6) range from "
            f"{float(confidence.min())!r} to {float(confidence.max())!r}"
        )
    return keep


def read_mot_detections(
    path: str | os.PathLike[str],
    *,
    min_confidence: float | None = None,
    swap_xy: bool = False,
    scale: float = 1.0,
    n_frames: int | None = None,
    delimiter: str = ",",
) -> Detections:
    """Detections of a MOTChallenge ``det.txt``: box centres as points, and the boxes (module
    docstring; frame 1 is frame 0 of the stream).

    Args:
        path: The file.
        min_confidence: Drop detections whose confidence is below this (−1, "not given", is
            kept); dropping every detection is an error.
        swap_xy: Swap x and y (a box ``(left, top, w, h)`` becomes ``(top, left, h, w)``).
        scale: Multiply positions and boxes by this (e.g. metres per pixel).
        n_frames: Frames of the stream (default: up to the file's last frame number); frames
            after the last detection are empty.
        delimiter: Field separator.
    """
    scale = _check_scale(scale)
    rows = read_mot_rows(path, min_confidence=min_confidence, delimiter=delimiter)
    total = rows.n_frames if n_frames is None else max(int(n_frames), rows.n_frames)
    counts = np.bincount(rows.frame, minlength=total)
    points = rows.centres[:, ::-1] if swap_xy else rows.centres
    boxes = None
    if rows.has_boxes:
        boxes = rows.boxes[:, [1, 0, 3, 2]] if swap_xy else rows.boxes
        boxes = boxes * scale if scale != 1.0 else boxes
    return Detections(
        points=points * scale if scale != 1.0 else np.ascontiguousarray(points),
        offsets=np.concatenate([[0], np.cumsum(counts)]),
        ids=np.where(rows.ids >= 0, rows.ids, -1),
        first_frame=1,
        boxes=boxes,
    )


def write_mot_detections(
    path: str | os.PathLike[str], detections: Detections, *, box_size: float = 0.0, confidence: float = 1.0
) -> None:
    """Write detections as a MOTChallenge ``det.txt`` (frame ``t`` of the stream as frame ``t + 1``).

    Each row is ``frame, id, bb_left, bb_top, bb_width, bb_height, confidence, -1, -1, -1`` with the
    detection's truth id (−1 where it has none): the detection's box where it has one, else
    ``x - box_size/2, y - box_size/2, box_size, box_size``. Boxes, and points with ``box_size`` 0,
    read back bit for bit; any other size rounds the centre (``x - s/2 + s/2``) in the last bit.
    """
    if detections.dim != 2:
        raise ValueError(f"MOTChallenge files hold 2-d points; these detections are {detections.dim}-d")
    frame = detections.frame_index() + 1
    write_mot_rows(
        path,
        frame,
        detections.ids,
        detections.points,
        box_size,
        [repr(float(confidence)), "-1,-1,-1"],
        boxes=detections.boxes,
    )


def write_mot_rows(
    path: str | os.PathLike[str],
    frame: NDArray[np.int64],
    ids: NDArray[np.int64],
    points: NDArray[np.float64],
    box_size: float,
    tail: list[str],
    *,
    boxes: NDArray[np.float64] | None = None,
) -> None:
    """Write MOTChallenge rows ``frame, id, left, top, w, h, *tail`` (``tail`` written as given on
    every row; the detection and the track writers each give theirs): the row's box from ``boxes``
    (N, 4) where it is finite, else a ``box_size`` box about the point (``box_size`` >= 0)."""
    size = float(box_size)
    if not (np.isfinite(size) and size >= 0):
        raise ValueError(f"box_size must be a finite number >= 0, got {box_size!r}")
    end = "," + ",".join(tail) + "\n"

    def text(lo: int, hi: int) -> str:
        columns = _box_columns(points[lo:hi], size, None if boxes is None else boxes[lo:hi])
        return "".join(
            f"{f},{i},{x!r},{y!r},{w!r},{h!r}{end}"
            for f, i, (x, y, w, h) in zip(
                frame[lo:hi].tolist(), ids[lo:hi].tolist(), columns.tolist(), strict=True
            )
        )

    write_chunks(path, (text(lo, hi) for lo, hi in chunks(len(points))))


def _box_columns(
    points: NDArray[np.float64], size: float, boxes: NDArray[np.float64] | None
) -> NDArray[np.float64]:
    """(n, 4) ``left, top, width, height`` of MOTChallenge rows: the row's box where it is finite,
    else a ``size`` box about the point."""
    half = size / 2
    left = points[:, 0] - half if size else points[:, 0]
    top = points[:, 1] - half if size else points[:, 1]
    sized = np.broadcast_to(np.float64(size), left.shape)
    columns = np.stack([left, top, sized, sized], axis=1)
    if boxes is not None:
        given = np.isfinite(boxes).all(axis=1)
        columns[given] = boxes[given]
    return columns


# -------------------------------------------------------------------------------------------- wide


def read_wide_detections(
    path: str | os.PathLike[str],
    *,
    header: bool | str = "auto",
    frame_column: int | str | None = 0,
    count_column: int | str | None = 1,
    time_column: int | str | None = None,
    xy_columns: int | str | Sequence[int | str] | None = None,
    swap_xy: bool = False,
    scale: float = 1.0,
    delimiter: str = ",",
) -> Detections:
    """Detections of a wide per-frame CSV (module docstring).

    Args:
        path: The file (``.csv`` or ``.zip`` holding one).
        header: ``"auto"`` (line 1 is a header when a field is not a number), ``True`` or ``False``.
        frame_column: Column of the frame number (index from 0 or header name); ``None``: the
            row number is the frame (from 0).
        count_column: Column of the number of detections in the row, checked against the pairs;
            ``None``: no count column.
        time_column: Column of the frame's time stamp in seconds (the frame period is inferred
            from it: :meth:`Detections.inferred_dt`); ``None``: none.
        xy_columns: Where the ``x, y`` pairs are: the first x column (index or name; the pairs run
            to the end of the row), or every column of the pairs in order (x0, y0, x1, y1, ...).
            ``None``: from the column after the last of the frame, count and time columns.
        swap_xy: Swap x and y.
        scale: Multiply positions by this.
        delimiter: Field separator.

    Raises:
        DetectionFileError: naming the file and the row and column of the first bad cell.
    """
    scale = _check_scale(scale)
    table = read_table(path, header=header, delimiter=delimiter)
    values = table.values
    n_rows = len(values)
    used = {
        what: table.column(spec, what)
        for what, spec in (
            ("frame_column", frame_column),
            ("count_column", count_column),
            ("time_column", time_column),
        )
        if spec is not None
    }
    pair_columns = _pair_columns(table, xy_columns, used)
    xy = values[:, pair_columns]
    if "frame_column" in used:
        c = used["frame_column"]
        _check_integers(table, values[:, c], c, "frame number", low=None)
        frames = values[:, c].astype(np.int64)
        back = np.flatnonzero(np.diff(frames) <= 0)
        if len(back):
            r = int(back[0]) + 1
            raise table.error(
                r, c, f"holds frame {frames[r]} after frame {frames[r - 1]}; frame numbers must increase"
            )
    else:
        frames = np.arange(n_rows, dtype=np.int64)
    inf = np.isinf(xy)
    if inf.any():
        r, k = first_bad(inf)
        raise table.error(
            r, pair_columns[k], f"holds {xy[r, k]}, an infinity; expected a finite number or NaN"
        )
    nan = np.isnan(xy)
    half = nan[:, 0::2] != nan[:, 1::2]
    if half.any():
        r, p = first_bad(half)
        k = 2 * p + int(not nan[r, 2 * p])  # the empty one of the pair
        other = pair_columns[2 * p + int(nan[r, 2 * p])]
        raise table.error(
            r,
            pair_columns[k],
            f"is empty but column index {other} (its pair) holds a number; x and y must be both "
            "numbers or both empty",
        )
    live = ~nan[:, 0::2]
    row_counts = live.sum(axis=1)
    if "count_column" in used:
        c = used["count_column"]
        _check_integers(table, values[:, c], c, "count", low=0)
        wrong = np.flatnonzero(values[:, c].astype(np.int64) != row_counts)
        if len(wrong):
            r = int(wrong[0])
            raise table.error(
                r, c, f"says {int(values[r, c])} detections but {row_counts[r]} (x, y) pairs hold numbers"
            )
    pairs = xy.reshape(n_rows, -1, 2)[live]
    if swap_xy:
        pairs = pairs[:, ::-1]
    points = pairs * scale if scale != 1.0 else np.ascontiguousarray(pairs)
    first = int(frames[0])
    index = frames - first
    counts = np.zeros(int(index[-1]) + 1, dtype=np.int64)
    counts[index] = row_counts
    times = None
    if "time_column" in used:
        times = np.full(len(counts), np.nan)
        times[index] = values[:, used["time_column"]]
    return Detections(points, np.concatenate([[0], np.cumsum(counts)]), first_frame=first, times=times)


def write_wide_detections(
    path: str | os.PathLike[str], detections: Detections, *, header: bool = True, na_rep: str = "NaN"
) -> None:
    """Write detections as a wide per-frame CSV: ``frame, count[, time], x0, y0, x1, y1, ...``.

    Every frame of the stream is a row (empty frames too), numbered from ``detections.first_frame``;
    rows are padded with ``na_rep`` to the widest frame. The time column is written when the
    stream has time stamps. :func:`read_wide_detections` with ``time_column="time"`` (or index 2)
    reads it back bit for bit; truth ids are not written.
    """
    if detections.dim != 2:
        raise ValueError(f"wide detection files hold 2-d points; these detections are {detections.dim}-d")
    n, width = detections.n_frames, max(detections.max_per_frame, 1)
    counts, offsets = detections.counts, detections.offsets
    names = ["frame", "count"]
    if detections.times is not None:
        names.append("time")
    head = ",".join(names + [f"{a}{k}" for k in range(width) for a in "xy"]) + "\n" if header else ""

    def text(lo: int, hi: int) -> str:  # frames lo:hi, padded to the widest frame
        grid = np.full((hi - lo, width, 2), np.nan)
        frame = np.repeat(np.arange(hi - lo), counts[lo:hi])
        slot = np.arange(offsets[lo], offsets[hi]) - np.repeat(offsets[lo:hi], counts[lo:hi])
        grid[frame, slot] = detections.points[offsets[lo] : offsets[hi]]
        body = format_rows(grid.reshape(hi - lo, -1), na_rep).split("\n")
        frames = (np.arange(lo, hi) + detections.first_frame).tolist()
        times = detections.times[lo:hi].tolist() if detections.times is not None else None
        lines = []
        for t, (f, c) in enumerate(zip(frames, counts[lo:hi].tolist(), strict=True)):
            lead = f"{f},{c}" if times is None else f"{f},{c},{times[t]!r}"
            lines.append(f"{lead},{body[t]}\n")
        return "".join(lines)

    frames_per_chunk = max(CHUNK_ROWS // width, 1)
    write_chunks(path, itertools.chain([head], (text(lo, hi) for lo, hi in chunks(n, frames_per_chunk))))


# -------------------------------------------------------------------------------------- dispatch


def read_detections(path: str | os.PathLike[str], format: str = "auto", **options: object) -> Detections:
    """Read detections in ``format`` (``"mot"``, ``"wide"`` or ``"auto"``: ``mot`` for a ``.txt``
    file, else ``wide``), passing ``options`` to :func:`read_mot_detections` or
    :func:`read_wide_detections`."""
    fmt = detection_format(path, format)
    reader = read_mot_detections if fmt == "mot" else read_wide_detections
    return reader(path, **options)  # type: ignore[arg-type]


def detection_format(path: str | os.PathLike[str], format: str = "auto") -> str:
    """``format``, or for ``"auto"`` the format a file's name suggests (``.txt``: mot, else wide)."""
    if format == "auto":
        return "mot" if Path(path).suffix.lower() == ".txt" else "wide"
    if format not in FORMATS:
        raise ValueError(f"format must be one of {['auto', *FORMATS]}, got {format!r}")
    return format


# ------------------------------------------------------------------------------------------ checks


def _check_scale(scale: float) -> float:
    if isinstance(scale, bool) or not isinstance(scale, int | float | np.floating):
        raise ValueError(f"scale must be a finite number > 0, got {scale!r}")
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"scale must be a finite number > 0, got {scale!r}")
    return float(scale)


def _check_integers(table: Table, column: NDArray[np.float64], c: int, what: str, *, low: int | None) -> None:
    """Raise naming the first cell of ``column`` that is not an integer (>= ``low``)."""
    bad = ~np.isfinite(column) | (column != np.round(column))
    if low is not None:
        bad |= column < low
    if bad.any():
        r = int(np.argmax(bad))
        valid = "an integer" if low is None else f"an integer >= {low}"
        shown = "nothing" if np.isnan(column[r]) else repr(float(column[r]))
        raise table.error(r, c, f"holds {shown}; the {what} must be {valid}")


def _pair_columns(
    table: Table, xy_columns: int | str | Sequence[int | str] | None, used: dict[str, int]
) -> list[int]:
    """The 0-based columns of the x, y pairs (an even number of them)."""
    n = table.values.shape[1]
    if xy_columns is None or isinstance(xy_columns, int | str):
        start = (
            max(used.values(), default=-1) + 1
            if xy_columns is None
            else table.column(xy_columns, "xy_columns")
        )
        columns = list(range(start, n))
        if len(columns) % 2 and np.isnan(table.values[:, -1]).all():
            columns = columns[:-1]  # a trailing delimiter on every row
    else:
        columns = [table.column(c, "xy_columns") for c in xy_columns]
    if not columns:
        raise DetectionFileError(f"{table.label}: no x, y columns (the file has {n} columns)")
    if len(columns) % 2:
        raise DetectionFileError(
            f"{table.label}: {len(columns)} x, y columns (column indices {columns[0]}-{columns[-1]}) is an "
            "odd count; expected (x, y) pairs"
        )
    clash = sorted(set(columns) & set(used.values()))
    if clash:
        raise DetectionFileError(
            f"{table.label}: column index {clash[0]} is both an x, y column and {_name_of(used, clash[0])}"
        )
    return columns


def _name_of(used: dict[str, int], column: int) -> str:
    return next(what for what, c in used.items() if c == column)
