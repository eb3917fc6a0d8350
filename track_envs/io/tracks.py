"""Write and read tracks (a tracker's output, or ground truth) as MOTChallenge, wide or long CSV.

* ``mot``: MOTChallenge rows (Milan et al., "MOT16: A Benchmark for Multi-Object Tracking", 2016),
  frame ``t`` of the stream written as frame ``t + 1``. Tracker output is
  ``frame, id, bb_left, bb_top, bb_width, bb_height, conf, -1, -1, -1``; ground truth
  (``truth=True``) is ``frame, id, bb_left, bb_top, bb_width, bb_height, 1, 1, 1`` (considered,
  class 1, visibility 1), so that py-motmetrics (``motmetrics.io.loadtxt(path, fmt="mot15-2D")``,
  ground truth with ``min_confidence=1``) and TrackEval read both unchanged. Tracks with boxes
  ([`Tracks.boxes`][track_envs.values.tracks.Tracks.boxes], from box detections) write each row's box, so IoU
  scoring works (``compare_to_groundtruth(gt, ts, "iou", distth=0.5)``); a row without a box, and tracks of
  points, are written as a box of ``box_size`` (default 0) about the point: motmetrics' Euclidean
  distance on the ``X, Y`` fields (``compare_to_groundtruth(gt, ts, "euc", distfields=["X", "Y"],
  distth=c)``) then scores the points themselves — only against truth written the same way: the
  ``X, Y`` of a real MOTChallenge gt are box corners, not centres. Read back, a file whose boxes
  all have width and height 0 is points (``boxes`` None); every other file keeps its boxes.
* ``wide``: the recorded-track layout of BeltReplay-v0
([`track_envs.io.wide_tracks`][track_envs.io.wide_tracks]): no header,
  one row per frame, one ``(x, y)`` column pair per id, NaN where the id has no track; column pair
  ``k`` holds the ``k``-th smallest id (for ids numbered 0, 1, 2, ... the id itself).
* ``long``: a header ``frame,id,x,y`` then one row per track and frame, plus ``var_x,cov_xy,var_y``
  where the tracks have covariances, ``detection`` (the detection index within the frame the
  track was updated with, −1: coasted) where they have it, and
  ``bb_left,bb_top,bb_width,bb_height`` (empty cells where a row has none) where they have boxes.

Every float is written as its ``repr``, so each format reads back bit for bit (the wide format
keeps no ids other than the column order, and no covariance).

**The suffix says the format** ([`SUFFIX_FORMATS`][track_envs.io.tracks.SUFFIX_FORMATS]), so that a file
written by [`write_tracks`][track_envs.io.write_tracks] is read back by
[`read_tracks`][track_envs.io.read_tracks] with ``format="auto"`` in the layout it was written in: ``.txt`` is
MOT, ``.zip`` wide, ``.csv`` long (its header ``frame,id,...`` says so) or wide (no header); any other name is
long when its first line starts ``frame,id``, else MOT. [`output_format`][track_envs.io.output_format] gives
the format a name implies (``.csv``: long) and refuses a format its suffix contradicts (MOT rows in a ``.csv``
would be read back as the wide layout). A ``.csv`` without a header whose first two columns hold integers in
every row (a MOT file's frame and id, e.g. written under a ``.csv`` name by an older version) is refused by
``auto``, not read as wide.

Every writer is atomic ([`track_envs.infra.atomic`][track_envs.infra.atomic]): a failed write leaves the old
file (or none) and raises [`FileWriteError`][track_envs.io.FileWriteError] naming the file and the cause.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from track_envs.io import magnitudes
from track_envs.io.csv_parser import (
    CHUNK_ROWS,
    DetectionFileError,
    Table,
    chunks,
    first_bad,
    read_table,
    write_chunks,
)
from track_envs.io.detections import MAX_FRAME, check_frame_span, read_mot_rows, write_mot_rows
from track_envs.io.wide_tracks import load_track_csv, write_track_chunks
from track_envs.values.tracks import Tracks

TRACK_FORMATS = ("mot", "wide", "long")
#: The formats a track file's suffix allows (the first: the one written by default).
SUFFIX_FORMATS: dict[str, tuple[str, ...]] = {".txt": ("mot",), ".csv": ("long", "wide"), ".zip": ("wide",)}
LONG_COLUMNS = ("frame", "id", "x", "y")
COV_COLUMNS = ("var_x", "cov_xy", "var_y")
BOX_COLUMNS = ("bb_left", "bb_top", "bb_width", "bb_height")


def write_tracks(
    path: str | os.PathLike[str],
    tracks: Tracks,
    format: str | None = None,
    *,
    truth: bool = False,
    box_size: float = 0.0,
) -> None:
    """Write ``tracks`` in ``format`` (``"mot"``, ``"wide"`` or ``"long"``; module docstring),
    atomically.

    Args:
        path: Output file.
        tracks: 2-d tracks.
        format: The layout; None: the one ``path``'s suffix implies
            ([`output_format`][track_envs.io.output_format]).
        truth: MOT only: write ground-truth rows (``1, 1, 1`` flags) instead of tracker rows.
        box_size: MOT only: width and height of the box written about each point (rows
            without a box; tracks with boxes write their own).

    Raises:
        ValueError: an unknown format, one the suffix contradicts
            ([`output_format`][track_envs.io.output_format]), tracks that are not 2-d, or (wide) no track at
            all.
        FileWriteError: the file could not be written (named, with the cause); the old file is
            left as it was.
    """
    format = output_format(path, format)
    if tracks.positions.shape[1] != 2:
        raise ValueError(f"track files hold 2-d points; these tracks are {tracks.positions.shape[1]}-d")
    if format == "mot":
        tail = ["1", "1", "1"] if truth else ["1.0", "-1,-1,-1"]
        frame = tracks.frame + 1
        write_mot_rows(path, frame, tracks.ids, tracks.positions, box_size, tail, boxes=tracks.boxes)
    elif format == "wide":
        if not len(tracks):
            raise ValueError("the wide track layout needs at least one track (one column pair)")
        _write_wide(path, tracks)
    else:
        _write_long(path, tracks)


def read_tracks(
    path: str | os.PathLike[str],
    format: str = "auto",
    *,
    n_frames: int | None = None,
    min_confidence: float | None = None,
) -> Tracks:
    """Read tracks (or ground truth) written in ``format``.

    Args:
        path: The file.
        format: ``"mot"``, ``"wide"``, ``"long"`` or ``"auto"``
            ([`track_format`][track_envs.io.track_format]).
        n_frames: Frames of the stream, when longer than the file's last frame.
        min_confidence: MOT only: drop rows whose confidence (the "considered" flag of ground
            truth) is below this, except −1 ("not given");
            `CONSIDERED` keeps ground truth's considered rows.

    Raises:
        DetectionFileError: naming the file and the row and column of the first bad cell, or
            (MOT, long) an id that appears twice in one frame.
    """
    fmt = track_format(path, format)
    lines: NDArray[np.int64] | None = None
    if fmt == "mot":
        rows = read_mot_rows(path, min_confidence=min_confidence)
        boxes = rows.boxes if rows.has_boxes else None
        tracks = Tracks(rows.frame, rows.ids, rows.centres, rows.n_frames, boxes=boxes)
        lines = rows.line
    elif fmt == "wide":
        positions = load_track_csv(path)
        if format == "auto":
            _refuse_mot_as_wide(path, positions)
        _check_wide_magnitudes(path, positions)
        tracks = Tracks.from_wide(positions)
    else:
        tracks, lines = _read_long(path)
    _check_unique(tracks, path, lines)
    return tracks if n_frames is None else tracks.with_frames(n_frames)


def _check_wide_magnitudes(path: str | os.PathLike[str], positions: NDArray[np.float64]) -> None:
    """Raise naming the first position of the wide layout no sensor produces
    ([`.magnitudes`][track_envs.io.magnitudes])."""
    flat = positions.reshape(len(positions), -1)
    ref = magnitudes.reference(flat)
    far = magnitudes.extreme(flat, ref)
    if far.any():
        row, column = first_bad(far)
        value = float(flat[row, column])
        label = os.fspath(path)
        raise DetectionFileError(
            f"{label}: row {row + 1}, column index {column} holds {value!r}{magnitudes.message(value, ref)}"
        )


def _refuse_mot_as_wide(path: str | os.PathLike[str], positions: NDArray[np.float64]) -> None:
    """Raise where a headerless ``.csv`` read as the wide layout looks like MOT rows: at least 6
    columns, and the first two (particle 0's x and y) integers >= 0 in every one of >= 2 rows —
    a MOT file's frame and id, which no recording of positions holds."""
    first = positions[:, 0, :] if positions.shape[1] else np.zeros((0, 2))
    if positions.shape[0] < 2 or positions.shape[1] < 3:
        return
    if np.isfinite(first).all() and np.all(first == np.round(first)) and np.all(first >= 0):
        raise DetectionFileError(
            f"{os.fspath(path)}: a .csv without a header is read as the wide track layout, but its first two "
            "columns hold integers in every row, as a MOTChallenge file's frame and id: name it .txt "
            "(or give the format: track run --gt-format mot, read_tracks(..., format='mot'); "
            "format='wide' reads it as wide)"
        )


def track_format(path: str | os.PathLike[str], format: str = "auto") -> str:
    """``format``, or for ``"auto"``: ``mot`` for ``.txt``, ``wide`` for ``.zip`` and for a ``.csv``
    without a header, ``long`` for a file whose first line starts with ``frame,id``, else ``mot``
    (module docstring)."""
    if format != "auto":
        if format not in TRACK_FORMATS:
            raise ValueError(f"format must be one of {['auto', *TRACK_FORMATS]}, got {format!r}")
        return format
    suffix = Path(path).suffix.lower()
    if suffix == ".txt":
        return "mot"
    if suffix == ".zip":
        return "wide"
    try:
        with open(path, "rb") as handle:
            start = handle.read(64).lstrip(b"\xef\xbb\xbf").replace(b" ", b"")
    except OSError:
        start = b""  # the reader names the problem
    if start.startswith(b"frame,id"):
        return "long"
    return "wide" if suffix == ".csv" else "mot"


def output_format(path: str | os.PathLike[str], format: str | None = None) -> str:
    """The format to write ``path`` in: ``format``, or where None the one its suffix implies
    (`SUFFIX_FORMATS`: ``.txt`` mot, ``.csv`` long, ``.zip`` wide; any
    other name mot).

    Raises:
        ValueError: ``format`` is not one the suffix allows (a file [`read_tracks`][track_envs.io.read_tracks]
            would read back in another layout), naming both and what to do.
    """
    if format is not None and format not in TRACK_FORMATS:
        raise ValueError(f"format must be one of {list(TRACK_FORMATS)}, got {format!r}")
    suffix = Path(path).suffix.lower()
    allowed = SUFFIX_FORMATS.get(suffix)
    if format is None:
        return allowed[0] if allowed else "mot"
    if allowed is not None and format not in allowed:
        fits = [s for s, formats in SUFFIX_FORMATS.items() if format in formats]
        raise ValueError(
            f"{os.fspath(path)}: a {suffix} track file is read back as {' or '.join(allowed)}, not {format}; "
            f"name it *{' or *'.join(fits)} for {format}, or write {allowed[0]}"
        )
    return format


def _write_long(path: str | os.PathLike[str], tracks: Tracks) -> None:
    columns: dict[str, NDArray[Any]] = {
        "frame": tracks.frame,
        "id": tracks.ids,
        "x": tracks.positions[:, 0],
        "y": tracks.positions[:, 1],
    }
    if tracks.cov is not None:
        columns |= {"var_x": tracks.cov[:, 0, 0], "cov_xy": tracks.cov[:, 0, 1], "var_y": tracks.cov[:, 1, 1]}
    if tracks.detection is not None:
        columns["detection"] = tracks.detection
    if tracks.boxes is not None:
        columns |= dict(zip(BOX_COLUMNS, tracks.boxes.T, strict=True))
    integers = ("frame", "id", "detection")
    boxes = set(BOX_COLUMNS) if tracks.boxes is not None else set()

    def text(lo: int, hi: int) -> str:
        cells = []
        for name, v in columns.items():
            values = np.asarray(v[lo:hi]).tolist()
            cell = list(map(str if name in integers else repr, values))
            if name in boxes:  # a row without a box: empty cells
                cell = ["" if c == "nan" else c for c in cell]
            cells.append(cell)
        return "".join(line + "\n" for line in map(",".join, zip(*cells, strict=True)))

    head = ",".join(columns) + "\n"
    write_chunks(path, itertools.chain([head], (text(lo, hi) for lo, hi in chunks(len(tracks)))))


def _write_wide(path: str | os.PathLike[str], tracks: Tracks) -> None:
    """The wide layout (``tracks.to_wide()`` written by [`write_track_csv`][track_envs.io.write_track_csv]),
    built and written a chunk of frames at a time: one frame's row is as wide as the ids are many, so a
    chunk holds at most ``CHUNK_ROWS`` cells or one frame."""
    unique, column = np.unique(tracks.ids, return_inverse=True)
    column = column.reshape(-1)
    bounds = np.searchsorted(tracks.frame, np.arange(tracks.n_frames + 1))  # rows are by frame
    d = tracks.positions.shape[1]
    per_chunk = max(CHUNK_ROWS // len(unique), 1)

    def grids() -> Iterator[NDArray[np.float64]]:
        for lo, hi in chunks(tracks.n_frames, per_chunk):
            rows = slice(bounds[lo], bounds[hi])
            grid = np.full((hi - lo, len(unique), d), np.nan)
            grid[tracks.frame[rows] - lo, column[rows]] = tracks.positions[rows]
            yield grid

    write_track_chunks(path, grids())


def _read_long(path: str | os.PathLike[str]) -> tuple[Tracks, NDArray[np.int64]]:
    """The tracks of a long file and each row's line number."""
    table = read_table(path, header=True)
    col = table.named_columns(LONG_COLUMNS, "long track")
    assert table.names is not None
    table.check_field_counts(len(table.names), why="as the header names")
    v = table.values
    for name in ("frame", "id", "x", "y"):
        bad = ~np.isfinite(v[:, col[name]])
        expected = "a finite number"
        if name in ("frame", "id"):
            bad |= v[:, col[name]] != np.round(v[:, col[name]])
            bad |= (v[:, col[name]] > MAX_FRAME) if name == "frame" else (np.abs(v[:, col[name]]) >= 2.0**63)
            expected = (
                f"an integer from 0 to {MAX_FRAME:g}" if name == "frame" else "an integer within +-2**63"
            )
        if bad.any():
            r = int(np.argmax(bad))
            raise table.error(
                r,
                col[name],
                f"holds {float(v[r, col[name]])!r}; expected {expected}",
            )
    check_frame_span(table, v[:, col["frame"]] + 1, col["frame"])
    frame = v[:, col["frame"]].astype(np.int64)
    if np.any(np.diff(frame) < 0) or (len(frame) and frame[0] < 0):
        r = int(np.argmax(np.diff(frame) < 0)) + 1 if len(frame) > 1 and frame[0] >= 0 else 0
        raise table.error(r, col["frame"], "goes back in time; rows must be sorted by frame (from 0)")
    positions = np.stack([v[:, col["x"]], v[:, col["y"]]], axis=1)
    boxes = (
        np.stack([v[:, col[c]] for c in BOX_COLUMNS], axis=1) if all(c in col for c in BOX_COLUMNS) else None
    )
    _check_long_magnitudes(table, positions, boxes, col)
    cov = None
    if all(c in col for c in COV_COLUMNS):
        vx, cxy, vy = (v[:, col[c]] for c in COV_COLUMNS)
        cov = np.stack([np.stack([vx, cxy], -1), np.stack([cxy, vy], -1)], axis=1)
    detection = None
    if "detection" in col:
        c = col["detection"]
        bad = ~np.isfinite(v[:, c]) | (v[:, c] != np.round(v[:, c])) | (np.abs(v[:, c]) >= 2.0**62)
        if bad.any():
            r = int(np.argmax(bad))
            raise table.error(
                r, c, f"holds {float(v[r, c])!r}; expected an integer (a detection's index, -1: none)"
            )
        detection = v[:, c].astype(np.int64)
    n_frames = int(frame[-1]) + 1 if len(frame) else 0
    tracks = Tracks(frame, table.integers(col["id"]), positions, n_frames, cov, detection, boxes)
    return tracks, np.arange(table.first_row, table.first_row + len(v), dtype=np.int64)


def _check_long_magnitudes(
    table: Table, positions: NDArray[np.float64], boxes: NDArray[np.float64] | None, col: dict[str, int]
) -> None:
    """Raise naming the first position or box cell no sensor produces
    ([`.magnitudes`][track_envs.io.magnitudes])."""
    ref = magnitudes.reference(positions)
    columns = [col["x"], col["y"]]
    bad = magnitudes.extreme(positions, ref)
    if boxes is not None:
        inf = np.isinf(boxes)
        if inf.any():
            r, k = first_bad(inf)
            raise table.error(
                r, col[BOX_COLUMNS[k]], f"holds {boxes[r, k]}; expected a finite number or empty"
            )
        columns += [col[c] for c in BOX_COLUMNS]
        far = [magnitudes.extreme(boxes[:, :2], ref), magnitudes.extreme(boxes[:, 2:], ref, size=True)]
        bad = np.concatenate([bad, *far], axis=1)
    if bad.any():
        r, k = first_bad(bad)
        value = float(table.values[r, columns[k]])
        raise table.error(r, columns[k], f"holds {value!r}{magnitudes.message(value, ref, size=k >= 4)}")


def _check_unique(
    tracks: Tracks, path: str | os.PathLike[str], lines: NDArray[np.int64] | None = None
) -> None:
    """Raise if an id appears twice in a frame (metrics need one row per id and frame), naming
    the count and, with ``lines`` (each row's line number), the first two rows."""
    if len(tracks) < 2:
        return
    order = np.lexsort((tracks.ids, tracks.frame))
    f, i = tracks.frame[order], tracks.ids[order]
    same = (f[1:] == f[:-1]) & (i[1:] == i[:-1])
    twice = np.flatnonzero(same)
    if len(twice):
        k, k2 = order[twice[0]], order[twice[0] + 1]
        rows = (
            f" (rows {min(lines[k], lines[k2])} and {max(lines[k], lines[k2])})" if lines is not None else ""
        )
        count = f"; {len(twice)} rows repeat an id of their frame" if len(twice) > 1 else ""
        raise DetectionFileError(
            f"{os.fspath(path)}: id {tracks.ids[k]} appears twice in frame {tracks.frame[k]} (from 0){rows}; "
            f"a track has one position per frame{count}"
        )
