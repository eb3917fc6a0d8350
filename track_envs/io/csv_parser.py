"""The one CSV parser of the file readers: bytes, line ends, field counts, floats, located errors.

Every reader of [`track_envs.io`][track_envs.io] parses numbers through this module:

* [`read_bytes`][track_envs.io.csv_parser.read_bytes] reads a file (a ``.zip`` holding one ``.csv`` member is
read as that member;
  other members and macOS ``__MACOSX/`` entries are ignored) and
  [`normalise`][track_envs.io.csv_parser.normalise] checks that it is text
  ([`check_text`][track_envs.io.csv_parser.check_text]: no NUL byte, valid UTF-8; UTF-16 with its byte-order
  mark is transcoded), drops a UTF-8 byte-order mark and trailing blank lines and turns CRLF / CR line ends
  into LF;
* [`field_counts`][track_envs.io.csv_parser.field_counts] counts the fields of every line on the raw bytes
(vectorised: the
  delimiters before each line end are counted with ``searchsorted`` on the delimiter offsets,
  about 0.04 s for a 75 MB file) and rejects a blank line;
* [`parse_floats`][track_envs.io.csv_parser.parse_floats] reads every cell as a float64 with pandas' C parser
([`read_float_frame`][track_envs.io.csv_parser.read_float_frame]:
  no quoting, missing values only the [`NA_TOKENS`][track_envs.io.csv_parser.NA_TOKENS], correctly rounded);
  only when that fails is the text scanned again, with [`csv`][track_envs.io.csv_parser.csv], to name the
  first cell that is not a number ([`locate_text`][track_envs.io.csv_parser.locate_text]);
* [`format_rows`][track_envs.io.csv_parser.format_rows] writes the inverse: ``repr`` of every float (the
shortest string that reads
  back as the same double), so a written file reads back bit for bit; the writers format
  [`CHUNK_ROWS`][track_envs.io.csv_parser.CHUNK_ROWS] rows at a time
  ([`chunks`][track_envs.io.csv_parser.chunks]) and write each chunk as it is formatted
  ([`write_chunks`][track_envs.io.csv_parser.write_chunks]), so that writing a file of any length holds one
  chunk's text, not the file's; the file is written atomically
  ([`track_envs.infra.atomic.atomic_write`][track_envs.io.atomic_write]: a temporary file beside it, renamed
  when complete), so a failed write leaves the old file and raises
  [`FileWriteError`][track_envs.io.FileWriteError] naming the file and the cause;
* [`read_table`][track_envs.io.csv_parser.read_table] builds on these a
[`Table`][track_envs.io.csv_parser.Table] of a delimited file with an optional header
  and ragged rows (missing trailing cells read as NaN), parsed
  [`PARSE_CELLS`][track_envs.io.csv_parser.PARSE_CELLS] cells at a time into one float64 array (the parser's
  buffers hold one chunk, not the file; a table wider than
  [`WIDE_COLUMNS`][track_envs.io.csv_parser.WIDE_COLUMNS] as one column of cells, without pandas' per-column
  cost), for the detection, track and crossing readers; the recorded-position format
  ([`track_envs.io.wide_tracks`][track_envs.io.wide_tracks]) checks its stricter layout on the same field
  counts.

Rows in messages are the file's line numbers, from 1, as an editor shows them (a header is line
1); columns are named by their index from 0 (``column index 3``), as the readers' column options
count them. Every problem raises [`TrackFileError`][track_envs.io.TrackFileError] (a ``ValueError``) or, from
the table readers, its subclass [`DetectionFileError`][track_envs.io.DetectionFileError]; the message starts
with the file's path. What a reader accepts but repairs (repeated detections dropped, rows sorted into frame
order) is said by a [`DetectionFileWarning`][track_envs.io.DetectionFileWarning] with the count and the first
rows.
"""

from __future__ import annotations

import codecs
import csv
import io
import itertools
import os
import re
import warnings
import zipfile
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from track_envs.infra.atomic import atomic_write

__all__ = [
    "CHUNK_ROWS",
    "NA_TOKENS",
    "DetectionFileError",
    "DetectionFileWarning",
    "Table",
    "TrackFileError",
    "check_text",
    "chunks",
    "field_counts",
    "first_bad",
    "format_rows",
    "is_number_or_missing",
    "locate_text",
    "normalise",
    "parse_floats",
    "read_bytes",
    "read_float_frame",
    "read_table",
    "write_chunks",
]

#: Rows a writer formats at a time (the text of one chunk is all a writer holds).
CHUNK_ROWS = 1 << 14

#: Cells [`read_table`][track_envs.io.csv_parser.read_table] parses at a time.
PARSE_CELLS = 1 << 20

#: Tables wider than this are parsed as one column of cells
#: ([`_parse_cells`][track_envs.io.csv_parser._parse_cells]).
WIDE_COLUMNS = 64

#: Cell contents read as "not visible" (besides inf, nothing else that is not a number is accepted).
NA_TOKENS: tuple[str, ...] = ("", "NaN", "nan")

# pandas >= 3 parses floats exactly by default (and deprecates ``float_precision``); older pandas
# needs the round-trip converter to give correctly rounded values.
_PANDAS_MAJOR = int(pd.__version__.split(".", 1)[0])
_FLOAT_PRECISION_KW: dict[str, str] = {} if _PANDAS_MAJOR >= 3 else {"float_precision": "round_trip"}

_NUMBER_RE = re.compile(r"\s*[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?\s*")
_INF_RE = re.compile(r"[+-]?inf(?:inity)?", re.IGNORECASE)
_BLANK_RE = re.compile(rb"\s*\Z")
_NEWLINE = 10


class TrackFileError(ValueError):
    """A track file is missing, unreadable or not in the track CSV format.

    The message starts with the file's path and names the problem and, where there is one, the row
    and column.
    """


class DetectionFileError(TrackFileError):
    """A detection or track file is missing, unreadable or not in the expected layout.

    The message starts with the file's path and names the problem and, where there is one, the
    row (the line number, from 1) and the column (its index, from 0, as column options count).
    """


class DetectionFileWarning(UserWarning):
    """A file was read, but something in it was repaired or looks wrong (e.g. repeated detection
    rows were dropped); the message starts with the file's path and gives the count and the first
    rows."""


# --------------------------------------------------------------------------------------------------
# bytes and lines


def read_bytes(path: Path, label: str) -> tuple[bytes, str]:
    """Return the CSV bytes of ``path`` and the label to use in messages about them."""
    try:
        if path.suffix.lower() != ".zip":
            return path.read_bytes(), label
        with zipfile.ZipFile(path) as archive:
            members = [
                info
                for info in archive.infolist()
                if not info.is_dir()
                and info.filename.lower().endswith(".csv")
                and not info.filename.startswith("__MACOSX/")
            ]
            if len(members) != 1:
                names = ", ".join(info.filename for info in members)
                found = "no .csv member" if not members else f"{len(members)} .csv members ({names})"
                raise TrackFileError(f"{label}: zip archive holds {found}; expected exactly one")
            member = members[0].filename
            return archive.read(member), f"{label} (member {member})"
    except FileNotFoundError:
        raise TrackFileError(f"{label}: no such file") from None
    except IsADirectoryError:
        raise TrackFileError(f"{label}: is a directory, not a file") from None
    except PermissionError:
        raise TrackFileError(f"{label}: cannot read the file (permission denied)") from None
    except zipfile.BadZipFile as exc:
        raise TrackFileError(f"{label}: not a valid zip archive ({exc})") from None
    except OSError as exc:
        raise TrackFileError(f"{label}: cannot read the file ({exc.strerror or exc})") from None


def check_text(data: bytes, label: str) -> bytes:
    """``data`` as UTF-8 text bytes: UTF-16 with a byte-order mark is transcoded to UTF-8; a NUL
    byte or bytes that are not UTF-8 raise, naming the first bad byte's value, offset and row.

    ASCII (the usual case) is recognised in one C pass (``bytes.isascii``); only other text is
    decoded to validate it.

    Raises:
        TrackFileError: ``FILE: not a text file (byte 0x00 at offset 1234, row 51: a NUL byte)``
            or ``(byte 0xb5 at offset 12, row 1: not UTF-8; save the file as UTF-8)``.
    """
    if data.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        try:
            text = data.decode("utf-16").encode("utf-8")
        except UnicodeDecodeError as exc:
            raise TrackFileError(
                f"{label}: not a text file (UTF-16 byte-order mark, but bytes {exc.start}-{exc.end - 1} "
                "are not UTF-16)"
            ) from None
        return check_text(text, label)
    nul = data.find(b"\x00")
    if nul >= 0:
        raise TrackFileError(
            f"{label}: not a text file (byte 0x00 at offset {nul}, row {_row_of(data, nul)}: "
            "a NUL byte; UTF-16 text needs its byte-order mark)"
        )
    if not data.isascii():
        try:
            data.decode("utf-8")
        except UnicodeDecodeError as exc:
            at = exc.start
            raise TrackFileError(
                f"{label}: not a text file (byte 0x{data[at]:02x} at offset {at}, row "
                f"{_row_of(data, at)}: not UTF-8; save the file as UTF-8 or ASCII)"
            ) from None
    return data


def _row_of(data: bytes, offset: int) -> int:
    """The line number (from 1) of byte ``offset`` (LF, CRLF or CR line ends)."""
    head = data[:offset]
    return head.count(b"\n") + head.count(b"\r") - head.count(b"\r\n") + 1


def normalise(data: bytes, label: str) -> bytes:
    """Check that ``data`` is text ([`check_text`][track_envs.io.csv_parser.check_text]), drop a BOM and
    trailing blank lines, turn CRLF and CR into LF; raise if nothing is left."""
    data = check_text(data, label)
    while data.startswith(codecs.BOM_UTF8):  # a file saved twice with a BOM has two
        data = data[len(codecs.BOM_UTF8) :]
    if b"\r" in data:
        data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    end = len(data)
    while end and data[end - 1] == _NEWLINE:
        end -= 1
    if end == 0 or _BLANK_RE.match(data):
        raise TrackFileError(f"{label}: file is empty")
    return data if end == len(data) else data[:end]


def field_counts(
    body: bytes,
    label: str,
    *,
    delimiter: str = ",",
    first_row: int = 1,
    error: type[TrackFileError] = TrackFileError,
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]]:
    """The fields of every line of ``body`` (LF line ends), counted on the bytes.

    Args:
        body: The lines, without a header.
        label: The file's name for messages.
        delimiter: One character between fields.
        first_row: The file line number of ``body``'s first line (2 after a header).
        error: The exception class to raise.

    Returns:
        ``(starts, ends, counts)``: line ``i`` is ``body[starts[i]:ends[i]]`` and has ``counts[i]``
            fields.

    Raises:
        error: naming the first blank line.
    """
    buf = np.frombuffer(body, dtype=np.uint8)
    newlines = np.flatnonzero(buf == _NEWLINE)
    starts = np.concatenate([np.zeros(1, dtype=np.intp), newlines + 1])  # line i is starts[i]:ends[i]
    ends = np.concatenate([newlines, np.array([len(body)], dtype=np.intp)])
    blank = ends == starts
    if blank.any():
        raise error(f"{label}: row {int(np.argmax(blank)) + first_row} is blank, expected a frame")
    at = np.flatnonzero(buf == ord(delimiter))
    counts = np.diff(np.searchsorted(at, ends), prepend=0) + 1
    return starts, ends, counts


# --------------------------------------------------------------------------------------------------
# numbers


def read_float_frame(data: bytes, **options: Any) -> pd.DataFrame:
    """``data`` (CSV text without header, already validated field by field) as a float64 frame:
    pandas' C parser, no quoting, blank lines kept (so row numbers stay the file's), missing
    values only the [`NA_TOKENS`][track_envs.io.csv_parser.NA_TOKENS], round-trip float precision; ``options``
    go to ``pandas.read_csv`` (e.g. ``names``, ``sep``, ``low_memory``). Raises what pandas raises
    (``ValueError`` or ``UnicodeDecodeError``) for the caller to locate."""
    return pd.read_csv(  # type: ignore[call-overload]
        io.BytesIO(data),
        header=None,
        index_col=False,
        dtype=np.float64,
        engine="c",
        quoting=csv.QUOTE_NONE,
        skip_blank_lines=False,
        keep_default_na=False,
        na_values=list(NA_TOKENS),
        encoding="utf-8",
        **_FLOAT_PRECISION_KW,
        **options,
    )


def parse_floats(
    body: bytes,
    label: str,
    *,
    first_row: int = 1,
    delimiter: str = ",",
    error: type[TrackFileError] = TrackFileError,
    expected: str = "a number or NaN",
    **options: Any,
) -> NDArray[np.float64]:
    """The cells of ``body`` (lines already checked by
    [`field_counts`][track_envs.io.csv_parser.field_counts]) as a C-contiguous float64 array; ``options`` go
    to [`read_float_frame`][track_envs.io.csv_parser.read_float_frame] (e.g. ``names``, ``low_memory``).

    Raises:
        error: naming the first cell that is not a number or missing
            ([`locate_text`][track_envs.io.csv_parser.locate_text]).
    """
    try:
        frame = read_float_frame(body, sep=delimiter, **options)
    except (ValueError, UnicodeDecodeError) as exc:  # pandas' ParserError is a ValueError
        located = locate_text(
            body, label, exc, first_row=first_row, delimiter=delimiter, error=error, expected=expected
        )
        raise located from None
    return np.ascontiguousarray(frame.to_numpy(dtype=np.float64))


def locate_text(
    body: bytes,
    label: str,
    exc: Exception,
    *,
    first_row: int = 1,
    delimiter: str = ",",
    error: type[TrackFileError] = TrackFileError,
    expected: str = "a number or NaN",
) -> TrackFileError:
    """Re-scan ``body`` (error path only) and return an ``error`` naming the first cell that is not
    a number, or else the parser's reason ``exc``."""
    reason = str(exc) if len(str(exc)) <= 200 else str(exc)[:200] + "..."
    text = body.decode("utf-8", errors="replace")
    reader = csv.reader(io.StringIO(text), delimiter=delimiter, quoting=csv.QUOTE_NONE)
    try:
        for row, fields in enumerate(reader, start=first_row):
            for column, field in enumerate(fields):
                if not is_number_or_missing(field):
                    shown = field if len(field) <= 40 else field[:40] + "..."
                    return error(
                        f"{label}: row {row}, column index {column} holds text {shown!r}, expected {expected}"
                    )
    except csv.Error as scan_exc:  # e.g. a field over csv's size limit: that is not a number either
        return error(f"{label}: row {reader.line_num + first_row - 1}: {scan_exc} ({reason})")
    return error(f"{label}: cannot parse the numbers ({reason})")


def is_number_or_missing(field: str) -> bool:
    """Whether pandas' parser accepts ``field`` as a float or a missing value (inf included)."""
    return field in NA_TOKENS or bool(_NUMBER_RE.fullmatch(field) or _INF_RE.fullmatch(field))


def format_rows(flat: NDArray[np.float64], na_rep: str) -> str:
    """Format (n_rows, n_fields) values as CSV text, ``repr`` for numbers and ``na_rep`` for NaN.

    Only the visible cells are formatted (``repr`` is the shortest string that reads back as the same
    double); each row starts as a list of ``na_rep`` tokens that the visible cells are written into,
    which is about 10x faster than formatting a full object array when most cells are missing.
    """
    rows, cols = np.nonzero(~np.isnan(flat))
    texts = list(map(repr, flat[rows, cols].tolist()))
    bounds = np.searchsorted(rows, np.arange(flat.shape[0] + 1)).tolist()
    col_list = cols.tolist()
    blank = [na_rep] * flat.shape[1]
    lines = []
    for lo, hi in itertools.pairwise(bounds):
        cells = blank.copy()
        for col, text in zip(col_list[lo:hi], texts[lo:hi], strict=True):
            cells[col] = text
        lines.append(",".join(cells))
    lines.append("")  # final newline
    return "\n".join(lines)


def chunks(n: int, size: int = CHUNK_ROWS) -> Iterator[tuple[int, int]]:
    """``(lo, hi)`` ranges of at most ``size`` (>= 1) rows covering ``0..n`` in order."""
    size = max(int(size), 1)
    for lo in range(0, n, size):
        yield lo, min(lo + size, n)


def write_chunks(path: str | os.PathLike[str], texts: Iterable[str]) -> None:
    """Write ``texts`` one after the other as an ASCII file (as ``Path.write_text`` writes one
    string: the file holds their concatenation), each written as soon as it is made, atomically:
    into a temporary file beside ``path``, renamed onto it when the last text is written.

    Raises:
        FileWriteError: naming ``path`` and the cause (disk full, no permission, ...); the old
            file, if any, is left as it was. An exception raised while making the texts
            propagates unchanged, also leaving the old file.
    """
    with atomic_write(path, "w", encoding="ascii", newline="\n") as handle:
        for text in texts:
            handle.write(text)


# --------------------------------------------------------------------------------------------------
# tables


@dataclass(frozen=True)
class Table:
    """The cells of a file as floats.

    Attributes:
        values: (n_rows, n_columns) float64, NaN for empty, missing (short rows) and ``NaN`` cells.
        names: Column names from the header, or None without one.
        first_row: File line number of ``values[0]`` (2 after a header, else 1).
        label: The file's name for messages (with the zip member, if any).
        body: The data rows' bytes (LF line ends), for [`integers`][track_envs.io.csv_parser.Table.integers].
        delimiter: The field separator.
        counts: (n_rows,) the number of fields of every row (None: not counted).
        line_end: Whether the file ends with a line end (a file cut off mid-row does not).
    """

    values: NDArray[np.float64]
    names: list[str] | None
    first_row: int
    label: str
    body: bytes = b""
    delimiter: str = ","
    counts: NDArray[np.intp] | None = None
    line_end: bool = True

    def check_field_counts(self, expected: int | None = None, why: str = "as most rows have") -> int:
        """Check that every row has ``expected`` fields (None: as many as most rows have); return
        that number.

        Raises:
            DetectionFileError: naming the first row with another count, its count and the
                expected one, and, where it is the last row and the file does not end with a line
                end, that the file looks cut off mid-row.
        """
        counts = self.counts
        if counts is None or not len(counts):
            return int(self.values.shape[1])
        if expected is None:  # the commonest count (a tie: the first row's)
            tally = np.bincount(counts)
            expected = int(counts[0]) if tally[counts[0]] == tally.max() else int(np.argmax(tally))
        wrong = counts != expected
        if not wrong.any():
            return expected
        r = int(np.argmax(wrong))
        n_wrong = int(wrong.sum())
        others = f"; {n_wrong} of the {len(counts)} rows differ" if n_wrong > 1 else ""
        if r == len(counts) - 1 and not self.line_end:
            others += "; it is the last row and the file does not end with a line end: cut off mid-row?"
        plural = "s" if counts[r] != 1 else ""
        raise DetectionFileError(
            f"{self.label}: row {self.first_row + r} has {counts[r]} column{plural} where {expected} are "
            f"expected ({why}){others}"
        )

    def integers(self, column: int) -> NDArray[np.int64]:
        """Column ``column`` (0-based) as int64, exact beyond 2**53 (where floats round): the
        cells are re-read as integers only when some value is that large. The column must hold
        integers in every row (checked by the caller on [`values`][track_envs.io.csv_parser.Table.values])."""
        values = self.values[:, column]
        if not len(values) or np.abs(values).max() < 2.0**53:
            return values.astype(np.int64)
        big = np.abs(values) >= 2.0**63
        if big.any():
            r = int(np.argmax(big))
            raise self.error(
                r, column, f"holds {float(values[r])!r}; an integer here must lie within +-2**63"
            )
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
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
            exact = np.ascontiguousarray(frame[column].to_numpy(dtype=np.int64))
        except (ValueError, OverflowError):
            exact = None
        if (
            exact is None
            or exact.shape != values.shape
            or np.any(np.abs(exact.astype(np.float64) - values) > 2.0**11)
        ):
            r = int(np.argmax(np.abs(values) >= 2.0**53))
            raise self.error(
                r,
                column,
                f"holds {float(values[r])!r}, an integer too large for a float: write it in digits "
                "(no exponent) and within +-2**63",
            )
        return exact

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
    """Read a delimited numeric file into a [`Table`][track_envs.io.csv_parser.Table].

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
        data, label = read_bytes(Path(path), label)
        line_end = data.endswith((b"\n", b"\r"))
        data = normalise(data, label)
    except TrackFileError as exc:
        raise DetectionFileError(str(exc)) from None
    end = data.find(b"\n")
    line1 = data if end < 0 else data[:end]
    fields = line1.decode("utf-8", errors="replace").split(delimiter)
    has_header = header is True or (
        header == "auto" and any(not is_number_or_missing(f.strip()) for f in fields)
    )
    names = [f.strip() for f in fields] if has_header else None
    body = (b"" if end < 0 else data[end + 1 :]) if has_header else data
    first_row = 2 if has_header else 1
    if not body:
        raise DetectionFileError(f"{label}: the file has a header but no data rows")
    starts, ends, counts = field_counts(
        body, label, delimiter=delimiter, first_row=first_row, error=DetectionFileError
    )
    n_columns = int(counts.max())
    if names is not None:
        n_columns = max(n_columns, len(names))
    values = np.empty((len(starts), n_columns))
    # a chunk of lines at a time into the one array: the parser's own buffers hold one chunk
    for lo, hi in chunks(len(starts), max(PARSE_CELLS // n_columns, 1)):
        chunk = body[starts[lo] : ends[hi - 1]]
        if n_columns > WIDE_COLUMNS and _parse_cells(chunk, counts[lo:hi], delimiter, values[lo:hi]):
            continue
        parsed = parse_floats(
            chunk,
            label,
            first_row=first_row + lo,
            delimiter=delimiter,
            error=DetectionFileError,
            expected="a number",
            names=list(range(n_columns)),
        )
        if parsed.shape != (hi - lo, n_columns):  # e.g. a byte-order mark inside the file
            raise DetectionFileError(
                f"{label}: rows {first_row + lo}-{first_row + hi - 1} parse into {parsed.shape[0]} rows of "
                f"{parsed.shape[1]} cells, expected {hi - lo} of {n_columns}: a stray byte-order mark or "
                "line end?"
            )
        values[lo:hi] = parsed
    return Table(values, names, first_row, label, body, delimiter, counts, line_end)


def _parse_cells(chunk: bytes, counts: NDArray[np.intp], delimiter: str, out: NDArray[np.float64]) -> bool:
    """Parse the lines of ``chunk`` (``counts`` fields each) into ``out`` (rows, columns; cells
    past a line's end NaN) as one column: each cell a line of its own, so that pandas' parser
    keeps no per-column state (a frame of 10^5 x, y pairs is 2·10^5 columns: the per-column
    parse takes kilobytes a column). The same parser reads each cell, so the values are those
    of [`parse_floats`][track_envs.io.csv_parser.parse_floats]. False (``out`` unspecified) when the cells are
    not all numbers or missing: the caller parses the chunk again by columns, which locates the bad cell."""
    text = chunk.replace(delimiter.encode("ascii", errors="replace"), b"\n")
    if text.endswith(b"\n"):  # the last cell is empty: a line of its own, not the file's end
        text += b"\n"
    try:
        cells = read_float_frame(text, names=[0], sep=delimiter)[0].to_numpy(dtype=np.float64)
    except (ValueError, UnicodeDecodeError):
        return False
    if len(cells) != int(counts.sum()):
        return False
    row = np.repeat(np.arange(len(counts)), counts)
    column = np.arange(len(cells)) - np.repeat(np.cumsum(counts) - counts, counts)
    out[:] = np.nan
    out[row, column] = cells
    return True


def first_bad(bad: NDArray[np.bool_]) -> tuple[int, int]:
    """(row, column) of the first True cell of a 2-d mask, in file order."""
    row, column = np.argwhere(bad)[0]
    return int(row), int(column)
