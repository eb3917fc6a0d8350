"""Load and write recorded belt-sorter track files.

The format is the one published with recorded belt-sorting data sets:

* a plain CSV file, or a ``.zip`` archive that holds exactly one ``.csv`` member (other members and
  macOS ``__MACOSX/`` entries are ignored);
* no header; one row (line) per frame, in time order;
* one ``x, y`` column pair per particle, so a row has ``2 * n_particles`` fields and every row has
  the same number of fields; the index of the pair (0-based) is the particle's truth id;
* a position is written as a decimal number (``1.5``, ``-0.25``, ``3e-05``); a particle that is not
  visible in a frame has both of its cells empty or ``NaN`` (``nan`` is accepted as well);
* ``x`` and ``y`` are either both numbers or both missing, and infinities are not allowed (this
  loader reads any finite double bit for bit; [`track_envs.io.tracks.read_tracks`][track_envs.io.read_tracks],
  which reads ground truth, also refuses positions no sensor produces:
  [`track_envs.io.magnitudes`][track_envs.io.magnitudes]).

Line endings may be LF, CRLF or CR; a UTF-8 byte-order mark and trailing blank lines are ignored, a
blank line inside the file is an error. Rows in error messages are line numbers, from 1, as an
editor shows them; columns are named by their index, from 0 (``column index 3``), as column options
count them.

Every problem with a file raises [`TrackFileError`][track_envs.io.TrackFileError], whose message starts with
the file's path and says what is wrong and where, e.g.
``tracks.csv: row 17 has 9 fields, expected 8 (ragged rows)``.

Loading uses the readers' one parser ([`track_envs.io.csv_parser`][track_envs.io.csv_parser]: pandas' C
parser, after a vectorised check of the field count of every line on the raw bytes), so a 2,000-frame file
with 4,400 particles (about 75 MB) loads in a few seconds. The file is re-scanned with the `csv`
module only when parsing fails, to locate the offending cell.
[`write_track_csv`][track_envs.io.write_track_csv] writes the shortest decimal string that reads back as the
same float (``repr``), so ``load_track_csv(write_track_csv(x))`` reproduces ``x`` bit for bit (NaNs as NaN),
atomically ([`track_envs.infra.atomic`][track_envs.infra.atomic]: a failed write leaves the old file and
raises [`FileWriteError`][track_envs.io.FileWriteError] naming the file and the cause).
"""

from __future__ import annotations

import contextlib
import operator
import os
import zipfile
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from track_envs.infra.atomic import atomic_path, atomic_write
from track_envs.io.csv_parser import (
    CHUNK_ROWS,
    NA_TOKENS,
    TrackFileError,
    chunks,
    field_counts,
    format_rows,
    normalise,
    parse_floats,
    read_bytes,
)

__all__ = ["TrackFileError", "load_track_csv", "write_track_chunks", "write_track_csv"]

_LOW_MEMORY_BYTES = 1 << 30  # parse bigger inputs in chunks


def load_track_csv(
    path: str | os.PathLike[str], frames: tuple[int, int] | None = None
) -> NDArray[np.float64]:
    """Load a track file (``.csv``, or ``.zip`` holding one ``.csv``).

    The field count of every row is checked; the numbers are parsed only in the selected frames.

    Args:
        path: The file. A name ending in ``.zip`` (any case) is read as a zip archive.
        frames: Optional half-open frame range ``(start, stop)`` to load, with
            ``0 <= start < stop <= n_frames``. ``None`` loads every frame.

    Returns:
        Positions of shape ``(n_frames, n_particles, 2)``, float64, with NaN where a particle is not
            visible. Particle ``i`` is the file's ``i``-th column pair.

    Raises:
        TrackFileError: The file is missing, unreadable, empty, ragged, has an odd column count, holds
            text, an infinity or a half-missing ``(x, y)`` pair, or is a zip without exactly one
            ``.csv`` member.
        ValueError: ``frames`` is malformed or outside the file's frame range.
    """
    label = os.fspath(path)
    if frames is not None:
        frames = _check_frames_shape(frames)
    data, label = read_bytes(Path(path), label)
    data = normalise(data, label)

    starts, ends, counts = field_counts(data, label)
    n_rows = len(starts)
    n_fields = _check_ragged(counts, label)
    if n_fields % 2:
        raise TrackFileError(
            f"{label}: {n_fields} columns is an odd count; expected (x, y) pairs, one per particle"
        )

    start, stop = (0, n_rows) if frames is None else _check_frames_range(frames, n_rows)
    chunk = data if (start, stop) == (0, n_rows) else data[starts[start] : ends[stop - 1]]
    # one pass: ~2x faster than pandas' chunked low-memory mode, which only bigger inputs need
    values = parse_floats(chunk, label, first_row=start + 1, low_memory=len(chunk) > _LOW_MEMORY_BYTES)
    if values.shape != (stop - start, n_fields):  # cannot happen after the field-count check
        raise TrackFileError(f"{label}: parsed {values.shape} cells, expected {(stop - start, n_fields)}")
    _check_values(values, label, first_row=start + 1)
    return np.ascontiguousarray(values.reshape(stop - start, n_fields // 2, 2))


def write_track_csv(path: str | os.PathLike[str], positions: ArrayLike, *, na_rep: str = "NaN") -> None:
    """Write positions as a track file that [`load_track_csv`][track_envs.io.load_track_csv] reads back bit
    for bit.

    Args:
        path: Destination. A name ending in ``.zip`` (any case) writes a zip archive holding one
            member named after the file's stem plus ``.csv`` (``run1.zip`` holds ``run1.csv``).
        positions: Array of shape ``(n_frames, n_particles, 2)`` with NaN in both ``x`` and ``y``
            where a particle is not visible; at least one frame and one particle.
        na_rep: What to write for a missing value: ``"NaN"`` (the default), ``"nan"`` or ``""``.

    Raises:
        ValueError: ``positions`` has the wrong shape, holds an infinity or a pair with exactly one
            NaN, or ``na_rep`` is not one of the accepted tokens.
    """
    if na_rep not in NA_TOKENS:
        raise ValueError(f"na_rep must be one of {NA_TOKENS!r}, got {na_rep!r}")
    pos = np.asarray(positions, dtype=np.float64)
    if pos.ndim != 3 or pos.shape[2] != 2 or pos.shape[0] < 1 or pos.shape[1] < 1:
        raise ValueError(f"positions must have shape (n_frames >= 1, n_particles >= 1, 2), got {pos.shape}")
    _check_positions(pos, 0)  # before the file is made
    per_chunk = max(CHUNK_ROWS // pos.shape[1], 1)
    write_track_chunks(path, (pos[lo:hi] for lo, hi in chunks(len(pos), per_chunk)), na_rep=na_rep)


def write_track_chunks(
    path: str | os.PathLike[str], positions: Iterable[NDArray[np.float64]], *, na_rep: str = "NaN"
) -> None:
    """[`write_track_csv`][track_envs.io.write_track_csv] of the frames of ``positions``, given as consecutive
    chunks of frames (each ``(k, n_particles, 2)``, the same ``n_particles``), each chunk checked,
    formatted and written before the next is asked for: a file of any length is written with
    one chunk in memory. Errors name frames from the first chunk's first frame."""
    if na_rep not in NA_TOKENS:
        raise ValueError(f"na_rep must be one of {NA_TOKENS!r}, got {na_rep!r}")
    target = Path(path)
    with contextlib.ExitStack() as stack:
        if target.suffix.lower() == ".zip":
            tmp = stack.enter_context(atomic_path(target))
            archive = stack.enter_context(zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED))
            handle = stack.enter_context(archive.open(target.stem + ".csv", "w", force_zip64=True))
        else:
            handle = stack.enter_context(atomic_write(target, "wb"))
        first, width = 0, None
        for chunk in positions:
            pos = np.asarray(chunk, dtype=np.float64)
            if width is None:
                width = pos.shape[1] if pos.ndim == 3 else -1
            if pos.ndim != 3 or pos.shape[2] != 2 or pos.shape[1] != width or width < 1:
                raise ValueError(
                    f"positions must have shape (n_frames >= 1, n_particles >= 1, 2), got {pos.shape}"
                )
            _check_positions(pos, first)
            handle.write(format_rows(pos.reshape(pos.shape[0], -1), na_rep).encode("ascii"))
            first += len(pos)
        if width is None:
            raise ValueError("positions must have shape (n_frames >= 1, n_particles >= 1, 2), got no frame")


def _check_positions(pos: NDArray[np.float64], first: int) -> None:
    """Raise ``ValueError`` at the first infinity or half-NaN pair (frames counted from ``first``)."""
    nan = np.isnan(pos)
    if np.isinf(pos).any():
        frame, particle, _ = np.argwhere(np.isinf(pos))[0]
        raise ValueError(f"positions hold an infinity (frame {first + frame}, particle {particle})")
    half = nan[..., 0] != nan[..., 1]
    if half.any():
        frame, particle = np.argwhere(half)[0]
        raise ValueError(
            f"positions have a pair with exactly one NaN (frame {first + frame}, particle {particle}); "
            "x and y must be both numbers or both NaN"
        )


# --------------------------------------------------------------------------------------------------
# helpers


def _check_frames_shape(frames: tuple[int, int]) -> tuple[int, int]:
    """Return ``frames`` as two ints, or raise ``ValueError`` if it is not a pair of integers."""
    try:
        start, stop = frames
        return operator.index(start), operator.index(stop)
    except (TypeError, ValueError):
        raise ValueError(f"frames must be a (start, stop) pair of ints, got {frames!r}") from None


def _check_frames_range(frames: tuple[int, int], n_rows: int) -> tuple[int, int]:
    """Return ``frames`` if ``0 <= start < stop <= n_rows``, else raise ``ValueError``."""
    start, stop = frames
    if not 0 <= start < stop <= n_rows:
        raise ValueError(
            f"frames must satisfy 0 <= start < stop <= {n_rows} (the file has {n_rows} frames), "
            f"got {frames!r}"
        )
    return start, stop


def _check_ragged(counts: NDArray[np.intp], label: str) -> int:
    """The number of fields per line; raise ``TrackFileError`` at the first line with another count
    than line 1."""
    ragged = counts != counts[0]
    if ragged.any():
        row = int(np.argmax(ragged))
        raise TrackFileError(
            f"{label}: row {row + 1} has {counts[row]} fields, expected {counts[0]} "
            "(as in row 1; ragged rows)"
        )
    return int(counts[0])


def _check_values(values: NDArray[np.float64], label: str, *, first_row: int) -> None:
    """Raise ``TrackFileError`` at the first infinity or half-missing (x, y) pair."""
    inf = np.isinf(values)
    if inf.any():
        row, column = np.argwhere(inf)[0]
        raise TrackFileError(
            f"{label}: row {first_row + row}, column index {column} holds {values[row, column]}, "
            "an infinity; expected a finite number or NaN"
        )

    nan = np.isnan(values)
    half = nan[:, 0::2] != nan[:, 1::2]
    if half.any():
        row, pair = np.argwhere(half)[0]
        missing, present = ("x", "y") if nan[row, 2 * pair] else ("y", "x")
        raise TrackFileError(
            f"{label}: row {first_row + row}, pair {pair} (column indices {2 * pair}-{2 * pair + 1}) has "
            f"{missing} missing but {present} set; x and y must be both numbers or both NaN"
        )
