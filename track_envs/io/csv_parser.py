"""A numeric table from a delimited text file, with errors that name the file, row and column.

The shared core of the detection and track file readers (:mod:`track_envs.io.detections`,
:mod:`track_envs.io.tracks`): the file is read as bytes (a ``.zip`` holding one ``.csv`` member
is read as that member; a UTF-8 byte-order mark, CRLF / CR line ends and trailing blank lines are
handled as in :mod:`track_envs.io.wide_tracks`), an optional header line is split off, the fields per
line are counted on the raw bytes (vectorised, so ragged rows are allowed: missing trailing cells
read as NaN), and pandas' C parser reads every cell as a float. Only on a parse error is the text
scanned again, with :mod:`csv`, to name the first cell that is not a number.

Rows in messages are the file's line numbers, from 1, as an editor shows them (a header is line
1); columns are named by their index from 0 (``column index 3``), as the readers' column options
count them.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from track_envs.io.wide_tracks import (
    TrackFileError,
    _is_number_or_missing,
    _normalise,
    _read_bytes,
    read_float_frame,
)

_NEWLINE = 10


class DetectionFileError(TrackFileError):
    """A detection or track file is missing, unreadable or not in the expected layout.

    The message starts with the file's path and names the problem and, where there is one, the
    row (the line number, from 1) and the column (its index, from 0, as column options count).
    """


@dataclass(frozen=True)
class Table:
    """The cells of a file as floats.

    Attributes:
        values: (n_rows, n_columns) float64, NaN for empty, missing (short rows) and ``NaN`` cells.
        names: Column names from the header, or None without one.
        first_row: File line number of ``values[0]`` (2 after a header, else 1).
        label: The file's name for messages (with the zip member, if any).
    """

    values: NDArray[np.float64]
    names: list[str] | None
    first_row: int
    label: str
    body: bytes = b""
    delimiter: str = ","

    def integers(self, column: int) -> NDArray[np.int64]:
        """Column ``column`` (0-based) as int64, exact beyond 2**53 (where floats round): the
        cells are re-read as integers only when some value is that large. The column must hold
        integers in every row (checked by the caller on :attr:`values`)."""
        values = self.values[:, column]
        if not len(values) or np.abs(values).max() < 2.0**53:
            return values.astype(np.int64)
        frame = pd.read_csv(
            io.BytesIO(self.body),
            header=None,
            names=list(range(self.values.shape[1])),
            usecols=[column],
            index_col=False,
            sep=self.delimiter,
            dtype={column: np.int64},
            engine="c",
            quoting=csv.QUOTE_NONE,
        )
        return np.ascontiguousarray(frame[column].to_numpy(dtype=np.int64))

    def error(self, row: int, column: int, what: str) -> DetectionFileError:
        """An error about cell ``values[row, column]`` (0-based), named as the file shows it."""
        name = f" ({self.names[column]!r})" if self.names and column < len(self.names) else ""
        return DetectionFileError(
            f"{self.label}: row {self.first_row + row}, column index {column}{name} {what}"
        )

    def named_columns(self, required: Sequence[str], kind: str) -> dict[str, int]:
        """Every header name's 0-based index, checked to hold ``required`` (a ``kind`` file, e.g.
        "long track", starts with them).

        Raises:
            DetectionFileError: naming the required columns the header lacks.
        """
        names = self.names or []
        missing = [c for c in required if c not in names]
        if missing:
            raise DetectionFileError(
                f"{self.label}: the header lacks {missing}; a {kind} file starts {','.join(required)}"
            )
        return {name: names.index(name) for name in names}  # a repeated name: its first column

    def column(self, spec: int | str, what: str) -> int:
        """The 0-based index of column ``spec`` (an index from 0, negative from the end, or a header name).

        Raises:
            DetectionFileError: for an index outside the table or a name that is not in the header.
        """
        n = self.values.shape[1]
        if isinstance(spec, str):
            if self.names is None:
                raise DetectionFileError(
                    f"{self.label}: {what} {spec!r} is a column name, but the file has no header; "
                    "give the column's index (from 0)"
                )
            if spec not in self.names:
                raise DetectionFileError(
                    f"{self.label}: {what} {spec!r} is not in the header; its columns are {self.names}"
                )
            return self.names.index(spec)
        if isinstance(spec, bool) or not isinstance(spec, int | np.integer):
            raise ValueError(f"{what} must be a column index (int) or a header name (str), got {spec!r}")
        index = int(spec) + (n if spec < 0 else 0)
        if not 0 <= index < n:
            raise DetectionFileError(
                f"{self.label}: {what} {spec} is outside the file's {n} columns (indices 0..{n - 1})"
            )
        return index


def read_table(path: str | os.PathLike[str], *, header: bool | str = False, delimiter: str = ",") -> Table:
    """Read a delimited numeric file into a :class:`Table`.

    Args:
        path: The file (``.csv``/``.txt``, or ``.zip`` holding one ``.csv``).
        header: ``True``: line 1 names the columns; ``False``: no header; ``"auto"``: line 1 is a
            header when one of its fields is not a number (or empty / NaN).
        delimiter: One character between fields (``","``, ``";"``, ``"\\t"``, ...).

    Raises:
        DetectionFileError: The file is missing, unreadable, empty (no data rows), has a blank line
            between rows, or holds a cell that is not a number (named by row and column).
    """
    if header not in (True, False, "auto"):
        raise ValueError(f"header must be True, False or 'auto', got {header!r}")
    if not (isinstance(delimiter, str) and len(delimiter) == 1 and delimiter not in "\r\n\"'"):
        raise ValueError(f"delimiter must be one character (not a quote or line end), got {delimiter!r}")
    label = os.fspath(path)
    try:
        data, label = _read_bytes(Path(path), label)
        data = _normalise(data, label)
    except TrackFileError as exc:
        raise DetectionFileError(str(exc)) from None
    end = data.find(b"\n")
    line1 = data if end < 0 else data[:end]
    fields = line1.decode("utf-8", errors="replace").split(delimiter)
    has_header = header is True or (
        header == "auto" and any(not _is_number_or_missing(f.strip()) for f in fields)
    )
    names = [f.strip() for f in fields] if has_header else None
    body = (b"" if end < 0 else data[end + 1 :]) if has_header else data
    first_row = 2 if has_header else 1
    if not body:
        raise DetectionFileError(f"{label}: the file has a header but no data rows")
    n_columns = _field_count(body, delimiter, label, first_row)
    if names is not None:
        n_columns = max(n_columns, len(names))
    values = _parse(body, label, first_row, n_columns, delimiter)
    return Table(values, names, first_row, label, body, delimiter)


def _field_count(body: bytes, delimiter: str, label: str, first_row: int) -> int:
    """The most fields on any line (vectorised on the bytes); a blank line is an error."""
    buf = np.frombuffer(body, dtype=np.uint8)
    newlines = np.flatnonzero(buf == _NEWLINE)
    starts = np.concatenate([np.zeros(1, dtype=np.intp), newlines + 1])
    ends = np.concatenate([newlines, np.array([len(body)], dtype=np.intp)])
    blank = ends == starts
    if blank.any():
        raise DetectionFileError(
            f"{label}: row {int(np.argmax(blank)) + first_row} is blank, expected a frame"
        )
    at = np.flatnonzero(buf == ord(delimiter))
    per_line = np.diff(np.searchsorted(at, ends), prepend=0)
    return int(per_line.max()) + 1


def _parse(body: bytes, label: str, first_row: int, n_columns: int, delimiter: str) -> NDArray[np.float64]:
    try:
        frame = read_float_frame(body, names=list(range(n_columns)), sep=delimiter)
    except (ValueError, UnicodeDecodeError) as exc:
        raise _locate_text(body, label, first_row, delimiter, exc) from None
    return np.ascontiguousarray(frame.to_numpy(dtype=np.float64))


def _locate_text(
    body: bytes, label: str, first_row: int, delimiter: str, exc: Exception
) -> DetectionFileError:
    """The first cell that is not a number, as an error (error path only)."""
    text = body.decode("utf-8", errors="replace")
    reader = csv.reader(io.StringIO(text), delimiter=delimiter, quoting=csv.QUOTE_NONE)
    try:
        for row, fields in enumerate(reader, start=first_row):
            for column, field in enumerate(fields):
                if not _is_number_or_missing(field):
                    shown = field if len(field) <= 40 else field[:40] + "..."
                    return DetectionFileError(
                        f"{label}: row {row}, column index {column} holds text {shown!r}, expected a number"
                    )
    except csv.Error as scan_exc:
        return DetectionFileError(f"{label}: row {reader.line_num + first_row - 1}: {scan_exc}")
    reason = str(exc)[:200]
    return DetectionFileError(f"{label}: cannot parse the numbers ({reason})")


def first_bad(bad: NDArray[np.bool_]) -> tuple[int, int]:
    """(row, column) of the first True cell of a 2-d mask, in file order."""
    row, column = np.argwhere(bad)[0]
    return int(row), int(column)
