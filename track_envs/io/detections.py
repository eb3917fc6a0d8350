"""Read and write per-frame point detections without identities: MOTChallenge and wide CSV files.

Two layouts (rows in error messages are the file's line numbers, from 1, as an editor shows them;
columns are named by their index from 0 — ``column index 1 ('count')`` — as the column
*selection* arguments count them, as pandas does, or by header name):

**MOTChallenge** ``det.txt`` (Milan, Leal-Taixé, Reid, Roth, Schindler: "MOT16: A Benchmark for
Multi-Object Tracking", 2016): no header, one detection per line,
``frame, id, bb_left, bb_top, bb_width, bb_height, conf, x, y, z`` (later fields optional, at
least the first six). Frames count from 1; ``id`` is −1 in detection files. A point tracker needs
centres, so every box gives its centre ``(bb_left + bb_width / 2, bb_top + bb_height / 2)`` as
[`Detections.points`][track_envs.values.detections.Detections.points], and the box itself is kept as
[`Detections.boxes`][track_envs.values.detections.Detections.boxes] ``(bb_left, bb_top, bb_width, bb_height)``
— unless every box has width and height 0 (a file of points: ``boxes`` None). ``swap_xy`` swaps the box's axes
with the point's (``(bb_top, bb_left, bb_height, bb_width)``) and ``scale`` multiplies all four numbers, so
the box's centre stays the point. A confidence of −1 means "not given" (MOTChallenge tracker output and MOT15
detections write it): ``min_confidence`` drops only rows with a confidence below it that is not −1, and a
filter that drops every row is an error naming the confidences the file holds. Rows may come in
any frame order; a frame without a row is an empty frame. An ``id >= 0`` (a simulated
recording's truth id) is kept as [`Detections.ids`][track_envs.values.detections.Detections.ids].
[`write_mot_detections`][track_envs.io.write_mot_detections] writes each detection's box (or, for points, a
box of ``box_size``, default 0, about the point), the confidence, and ``-1, -1, -1`` for the world x, y, z.

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

Both readers raise [`DetectionFileError`][track_envs.io.DetectionFileError] (a ``ValueError``) naming the
file, row and column of the first bad cell: text, an infinity, a half-empty pair, a frame that is
not an integer or goes backwards, a count that disagrees with the pairs. Writers use ``repr`` of
each float, so a file written and read back gives the same detections bit for bit.
"""

from __future__ import annotations

import itertools
import os
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from track_envs.io import magnitudes
from track_envs.io.csv_parser import (
    CHUNK_ROWS,
    DetectionFileError,
    DetectionFileWarning,
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
        line: (N,) int64 each row's line number in the file (from 1), for messages.
        unsorted: How many rows of the file came after a row of a later frame (0: the file is in
            frame order); the rows are sorted all the same.
        unsorted_line: The line number of the first such row (0: none).
    """

    frame: NDArray[np.int64]
    ids: NDArray[np.int64]
    centres: NDArray[np.float64]
    confidence: NDArray[np.float64]
    n_frames: int
    boxes: NDArray[np.float64]
    line: NDArray[np.int64] | None = None
    unsorted: int = 0
    unsorted_line: int = 0

    @property
    def has_boxes(self) -> bool:
        """Whether any row is a box (width or height > 0); a file of points has none."""
        return bool(np.any(self.boxes[:, 2:] > 0))


#: The largest frame number a file may hold: a stream of at most 10^8 frames (its per-frame
#: arrays stay below a gigabyte).
MAX_FRAME = 10**8
#: A file of ``n`` rows spans at most ``max(MIN_SPAN, SPAN_PER_ROW · n)`` frames: a frame number
#: beyond that (a typo, a corrupt row) would make a stream of nearly only empty frames, which
#: takes the tracker minutes to hours to step through.
MIN_SPAN = 10**6
SPAN_PER_ROW = 1000


def check_frame_span(table: Table, span: NDArray[np.float64], column: int) -> None:
    """Raise naming the first row whose frame would make the stream span more than
    ``max(MIN_SPAN, SPAN_PER_ROW · rows)`` frames (``span``: each row's frame counted from the
    stream's first frame, 1 for the first)."""
    n = len(span)
    limit = min(MAX_FRAME, max(MIN_SPAN, SPAN_PER_ROW * n))
    far = span > limit
    if far.any():
        r = int(np.argmax(far))
        raise table.error(
            r,
            column,
            f"holds frame {table.values[r, column]:.0f}: the file's {n} rows would span "
            f"{span[r]:.0f} frames, nearly all empty (at most max({MIN_SPAN:g}, {SPAN_PER_ROW} per row) "
            f"= {limit:g}); a typo or "
            "a corrupt row?",
        )


def read_mot_rows(
    path: str | os.PathLike[str], *, min_confidence: float | None = None, delimiter: str = ","
) -> MotRows:
    """The rows of a MOTChallenge file (detections, tracks or ground truth): boxes and their centres.

    Args:
        path: The file.
        min_confidence: Drop rows whose confidence (column index 6) is below this, except rows
            with −1 ("not given"). For ground truth, 1 keeps the rows flagged "considered"
            (MOT16 and later write 1 or 0 there, MOT15 writes 1):
            `CONSIDERED`.
        delimiter: Field separator.

    Raises:
        DetectionFileError: naming the row (and column, and value) of: a row with another number
            of columns than the file's other rows (a missing or extra column, or a file cut off
            mid-row); a missing, non-numeric or non-finite field among the first six; a frame
            number that is not an integer from 1 to `MAX_FRAME` or spans
            more frames than `check_frame_span` allows for the
            file's rows; an id that is not an integer within ±2**63; a negative width or height; a coordinate
            no sensor produces (`track_envs.io.magnitudes`); and a
            ``min_confidence`` that drops every row (naming the confidences the file holds).
    """
    table = read_table(path, header=False, delimiter=delimiter)
    values = table.values
    n_columns = table.check_field_counts(why="as the file's other rows have")
    if n_columns < 6:
        raise DetectionFileError(
            f"{table.label}: rows have {n_columns} fields; a MOTChallenge row has at least 6 "
            f"({', '.join(_MOT_NAMES[:6])}, ...)"
        )
    columns = np.ascontiguousarray(values[:, :6].T)  # one contiguous array a column: fast checks
    head = columns.T  # (n, 6), the same cells
    bad = ~np.isfinite(head)
    if bad.any():
        row, column = first_bad(bad)
        what = "is empty" if np.isnan(head[row, column]) else f"holds {head[row, column]}"
        raise table.error(row, column, f"({_MOT_NAMES[column]}) {what}; expected a finite number")
    frames, ids = columns[0], columns[1]
    _check_integers(table, frames, 0, "frame", low=1, high=MAX_FRAME)
    check_frame_span(table, frames, 0)
    _check_integers(table, ids, 1, "id", low=None)
    negative = head[:, 4:6] < 0
    if negative.any():
        row, k = first_bad(negative)
        raise table.error(
            row, 4 + k, f"({_MOT_NAMES[4 + k]}) holds {float(head[row, 4 + k])!r}; a box's size must be >= 0"
        )
    _check_boxes(table, columns[2:6], 2)
    confidence = values[:, 6] if values.shape[1] > 6 else np.ones(len(values))
    confidence = np.where(np.isnan(confidence), 1.0, confidence)
    centres = np.stack([columns[2] + columns[4] / 2, columns[3] + columns[5] / 2], axis=1)
    n_frames = int(frames.max())
    keep = slice(None) if min_confidence is None else _confident(table.label, confidence, min_confidence)
    frame = frames[keep].astype(np.int64) - 1
    line = np.arange(table.first_row, table.first_row + len(values), dtype=np.int64)[keep]
    # rows already in frame order (as files are written) are kept as they are, without a copy
    back = frame[1:] < frame[:-1]
    unsorted = int(back.sum())
    unsorted_line = int(line[int(np.argmax(back)) + 1]) if unsorted else 0
    order = slice(None) if not unsorted else np.argsort(frame, kind="stable")
    return MotRows(
        frame=frame[order],
        ids=table.integers(1)[keep][order],
        centres=np.ascontiguousarray(centres[keep][order]),
        confidence=confidence[keep][order],
        n_frames=n_frames,
        boxes=np.ascontiguousarray(head[:, 2:6][keep][order]),
        line=line[order],
        unsorted=unsorted,
        unsorted_line=unsorted_line,
    )


def _check_boxes(table: Table, columns: NDArray[np.float64], first_column: int) -> None:
    """Raise naming the first cell of the (4, n) ``left, top, width, height`` columns (from
    ``first_column``) whose value no sensor produces
    ([`track_envs.io.magnitudes`][track_envs.io.magnitudes])."""
    ref = magnitudes.reference(columns[:2])
    far = magnitudes.extreme(columns[:2], ref)
    large = magnitudes.extreme(columns[2:], ref, size=True)
    if far.any() or large.any():
        row, k = first_bad(np.concatenate([far, large]).T)
        value = float(columns[k, row])
        name = f"({_MOT_NAMES[first_column + k]}) " if table.names is None else ""
        raise table.error(
            row, first_column + k, f"{name}holds {value!r}{magnitudes.message(value, ref, size=k >= 2)}"
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
    duplicates: str = "drop",
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
        duplicates: What to do with a row that repeats an earlier row of its frame exactly (the
            same frame, box, centre and id: the tracker would see one object twice and start a
            second track for it): ``"drop"`` (default) keeps the first and warns
            ([`DetectionFileWarning`][track_envs.io.DetectionFileWarning], with the count and the first rows),
            ``"error"`` raises naming them.

    Rows out of frame order are sorted (stably) and warned about with their count and the first
    one ([`DetectionFileWarning`][track_envs.io.DetectionFileWarning]).

    Raises:
        DetectionFileError: as [`read_mot_rows`][track_envs.io.read_mot_rows]; repeated rows with
            ``duplicates="error"``; a coordinate that ``scale`` makes infinite.
    """
    scale = _check_scale(scale)
    _check_duplicates_option(duplicates)
    rows = read_mot_rows(path, min_confidence=min_confidence, delimiter=delimiter)
    label = os.fspath(path)
    assert rows.line is not None
    if rows.unsorted:
        warnings.warn(
            DetectionFileWarning(
                f"{label}: {_rows(rows.unsorted)} after a row of a later frame (the first: row "
                f"{rows.unsorted_line}); the rows are read in frame order (rows of one frame keep "
                "their file order)"
            ),
            stacklevel=2,
        )
    boxes_given = rows.boxes if rows.has_boxes else None
    keep = _repeats(label, rows.frame, rows.centres, boxes_given, rows.ids, rows.line, duplicates)
    frame, centres, ids, line = rows.frame, rows.centres, rows.ids, rows.line
    if keep is not None:
        frame, centres, ids, line = frame[keep], centres[keep], ids[keep], line[keep]
    total = rows.n_frames if n_frames is None else max(int(n_frames), rows.n_frames)
    counts = np.bincount(frame, minlength=total)
    points = centres[:, ::-1] if swap_xy else centres
    boxes = None
    if rows.has_boxes:
        boxes = rows.boxes if keep is None else rows.boxes[keep]
        boxes = boxes[:, [1, 0, 3, 2]] if swap_xy else boxes
        with np.errstate(over="ignore"):
            boxes = boxes * scale if scale != 1.0 else boxes
    with np.errstate(over="ignore"):  # named just below
        points = points * scale if scale != 1.0 else np.ascontiguousarray(points)
    if scale != 1.0:
        _check_scaled(label, points if boxes is None else boxes, scale, lambda k: f"row {line[k]}")
    return Detections(
        points=points,
        offsets=np.concatenate([[0], np.cumsum(counts)]),
        ids=np.where(ids >= 0, ids, -1),
        first_frame=1,
        boxes=boxes,
    )


def _rows(n: int) -> str:
    return "1 row comes" if n == 1 else f"{n} rows come"


#: What the readers do with repeated detections (``duplicates=``).
DUPLICATES = ("drop", "error")


def _check_duplicates_option(duplicates: str) -> None:
    if duplicates not in DUPLICATES:
        raise ValueError(f"duplicates must be one of {list(DUPLICATES)}, got {duplicates!r}")


def _repeats(
    label: str,
    frame: NDArray[np.int64],
    points: NDArray[np.float64],
    boxes: NDArray[np.float64] | None,
    ids: NDArray[np.int64] | None,
    line: NDArray[np.int64],
    duplicates: str,
    where: Callable[[int], str] | None = None,
) -> NDArray[np.bool_] | None:
    """The detections to keep where some repeat an earlier one of their frame exactly (frame,
    point, box and id equal; -0.0 equals 0.0), else None; warns (``"drop"``) or raises
    (``"error"``) naming the count and the first repeats (``where(k)``: how detection ``k`` is
    named, by default ``row line[k]``).

    A hash of each detection's frame and point (multiplied bit patterns, wrapping uint64) finds
    the candidates in one pass (pandas' hash table, about 40 ms for 10^6 detections); only those
    are compared in full, so a file without repeats costs a few vector passes."""
    n = len(frame)
    if n < 2:
        return None
    bits = (np.ascontiguousarray(points, dtype=np.float64) + 0.0).view(np.uint64)
    with np.errstate(over="ignore"):
        h = frame.astype(np.uint64) * np.uint64(0x9E3779B97F4A7C15)
        h ^= bits[:, 0] * np.uint64(0xC2B2AE3D27D4EB4F)
        h ^= bits[:, 1] * np.uint64(0x165667B19E3779F9)
    later = pd.Series(h).duplicated().to_numpy()  # a hash table: no sort
    if not later.any():
        return None
    candidates = np.flatnonzero(np.isin(h, h[later]))  # the repeats and what they repeat
    parts = [frame[candidates, None].astype(np.float64), points[candidates]]
    if boxes is not None:
        parts.append(boxes[candidates])
    if ids is not None:
        parts.append(ids[candidates, None].astype(np.float64))
    key = np.ascontiguousarray(np.concatenate(parts, axis=1) + 0.0)
    _, first, inverse = np.unique(key.view(np.uint64), axis=0, return_index=True, return_inverse=True)
    origin = candidates[first[inverse.reshape(-1)]]  # each candidate's first equal detection
    repeat = origin != candidates
    if not repeat.any():
        return None
    rep, orig = candidates[repeat], origin[repeat]
    order = np.argsort(rep, kind="stable")
    rep, orig = rep[order], orig[order]
    name = where or (lambda k: f"row {line[k]}")
    shown = ", ".join(
        f"{name(int(r))} repeats {name(int(o))}" for r, o in zip(rep[:3], orig[:3], strict=True)
    )
    more = ", ..." if len(rep) > 3 else ""
    what = (
        "same frame, position"
        + (", box" if boxes is not None else "")
        + (" and id" if ids is not None else "")
    )
    many = "s" if len(rep) > 1 else ""
    text = (
        f"{label}: {len(rep)} detection{many} repeat an earlier one of their frame exactly ({what}): "
        f"{shown}{more}"
    )
    if duplicates == "error":
        raise DetectionFileError(text)
    warnings.warn(
        DetectionFileWarning(f"{text}; each is tracked once (the repeats are dropped)"), stacklevel=3
    )
    keep = np.ones(n, dtype=bool)
    keep[rep] = False
    return keep


def _check_scaled(label: str, values: NDArray[np.float64], scale: float, where: Callable[[int], str]) -> None:
    """Raise naming the first detection whose (scaled) ``values`` are not finite."""
    bad = ~np.isfinite(values).all(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise DetectionFileError(
            f"{label}: {where(k)}: scale={scale!r} (track run: --scale) makes its coordinates "
            f"{values[k].tolist()}; they must stay finite"
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
    duplicates: str = "drop",
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
            from it: [`Detections.inferred_dt`][track_envs.Detections.inferred_dt]); ``None``: none.
        xy_columns: Where the ``x, y`` pairs are: the first x column (index or name; the pairs run
            to the end of the row), or every column of the pairs in order (x0, y0, x1, y1, ...).
            ``None``: from the column after the last of the frame, count and time columns.
        swap_xy: Swap x and y.
        scale: Multiply positions by this.
        delimiter: Field separator.
        duplicates: A pair that repeats an earlier pair of its row exactly: ``"drop"`` (default:
            kept once, with a [`DetectionFileWarning`][track_envs.io.DetectionFileWarning] giving the count
            and the first ones) or ``"error"`` ([`read_mot_detections`][track_envs.io.read_mot_detections]).

    Raises:
        DetectionFileError: naming the file and the row and column of the first bad cell: text,
            an infinity, a half-empty pair, a frame number that is not an integer or does not
            increase (or spans more frames than
            `check_frame_span` allows), a count that disagrees
            with the pairs, an infinite time, a coordinate no sensor produces
            (`track_envs.io.magnitudes`) or one that ``scale`` makes infinite.
    """
    scale = _check_scale(scale)
    _check_duplicates_option(duplicates)
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
        check_frame_span(table, (frames - frames[0] + 1).astype(np.float64), c)
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
    ref = magnitudes.reference(xy)
    far = magnitudes.extreme(xy, ref)
    if far.any():
        r, k = first_bad(far)
        raise table.error(
            r, pair_columns[k], f"holds {float(xy[r, k])!r}{magnitudes.message(float(xy[r, k]), ref)}"
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
    row_of = np.repeat(np.arange(n_rows), row_counts)  # each detection's row

    def pair_of(k: int) -> int:  # messages only
        return int(np.flatnonzero(live[row_of[k]])[k - int(np.searchsorted(row_of, row_of[k]))])

    keep = _repeats(
        table.label,
        row_of.astype(np.int64),
        pairs,
        None,
        None,
        row_of + table.first_row,
        duplicates,
        where=lambda k: (
            f"row {row_of[k] + table.first_row} pair {pair_of(k)} (column indices "
            f"{pair_columns[2 * pair_of(k)]}-{pair_columns[2 * pair_of(k) + 1]})"
        ),
    )
    if keep is not None:
        pairs, row_of = pairs[keep], row_of[keep]
        row_counts = np.bincount(row_of, minlength=n_rows)
    with np.errstate(over="ignore"):  # named just below
        points = pairs * scale if scale != 1.0 else np.ascontiguousarray(pairs)
    if scale != 1.0:
        _check_scaled(table.label, points, scale, lambda k: f"row {row_of[k] + table.first_row}")
    first = int(frames[0])
    index = frames - first
    counts = np.zeros(int(index[-1]) + 1, dtype=np.int64)
    counts[index] = row_counts
    times = None
    if "time_column" in used:
        c = used["time_column"]
        inf = np.isinf(values[:, c])
        if inf.any():
            r = int(np.argmax(inf))
            raise table.error(
                r, c, f"holds {values[r, c]}; a time must be a finite number of seconds (or empty)"
            )
        times = np.full(len(counts), np.nan)
        times[index] = values[:, c]
    return Detections(points, np.concatenate([[0], np.cumsum(counts)]), first_frame=first, times=times)


def write_wide_detections(
    path: str | os.PathLike[str], detections: Detections, *, header: bool = True, na_rep: str = "NaN"
) -> None:
    """Write detections as a wide per-frame CSV: ``frame, count[, time], x0, y0, x1, y1, ...``.

    Every frame of the stream is a row (empty frames too), numbered from ``detections.first_frame``;
    rows are padded with ``na_rep`` to the widest frame. The time column is written when the
    stream has time stamps. [`read_wide_detections`][track_envs.io.read_wide_detections] with
    ``time_column="time"`` (or index 2) reads it back bit for bit; truth ids are not written.
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
    file, else ``wide``), passing ``options`` to [`read_mot_detections`][track_envs.io.read_mot_detections] or
    [`read_wide_detections`][track_envs.io.read_wide_detections]."""
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


def _check_integers(
    table: Table,
    column: NDArray[np.float64],
    c: int,
    what: str,
    *,
    low: int | None,
    high: float | None = None,
) -> None:
    """Raise naming the first cell of ``column`` that is not an integer from ``low`` to ``high``
    (no bound: within ±2**63, the int64 range)."""
    lowest = -(2.0**63) if low is None else low
    fractional = column != np.round(column)  # NaN too
    if not len(column) or (
        not fractional.any()
        and column.min() >= lowest
        and (column.max() < 2.0**63 if high is None else column.max() <= high)
    ):
        return  # infinities fail the bounds
    bad = fractional | ~np.isfinite(column) | (column < lowest)
    bad |= column >= 2.0**63 if high is None else column > high
    if bad.any():
        r = int(np.argmax(bad))
        if low is None and high is None:
            valid = "an integer within +-2**63"
        elif high is None:
            valid = f"an integer >= {low}"
        else:
            valid = f"an integer >= {low} and <= {high:g}" if low is not None else f"an integer <= {high:g}"
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
