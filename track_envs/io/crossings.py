"""Predicted crossings of a sorting line over a whole stream, and their CSV file.

A tracker that knows the sorting line ``x = L`` (``SensorSpec.sorting_line``: the nozzle bar of
an optical belt sorter) reports, in the frame it lets a track go, the crossing it predicts for
it: time ``t_c`` and lateral position ``y_c`` with their covariance (the report's sorting
channel, [`track_envs.contracts.sorting_channel`][track_envs.contracts.sorting_channel]).
[`PredictedCrossings`][track_envs.io.PredictedCrossings] gathers those rows over a stream, with the frame each
was reported in; [`PredictedCrossings.last`][track_envs.io.PredictedCrossings.last] keeps the one that counts
for each track: the last prediction made for it (the gnn agent makes exactly one, when it deletes the track,
from the state of the track's last update).

**File** (``write_crossings`` / ``read_crossings``): a CSV with the header

``id,frame,t_cross,y_cross,var_t,cov_ty,var_y``

one row per prediction, in the order made: the track id, the frame (from 0) whose report carried
it, the predicted crossing ``t_cross`` in seconds on the stream's clock (frame ``k`` at ``k·dt``,
frame 0 the first frame of the stream) and ``y_cross`` in the detections' units, and the
covariance of ``(t_cross, y_cross)`` (s², s·unit, unit²). Further columns (a scorer's true
crossings, ``t_true,y_true``) are kept by the reader as
[`PredictedCrossings.extra`][track_envs.io.crossings.PredictedCrossings.extra].
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.atomic import write_text

#: The columns every crossing file starts with.
CROSSING_COLUMNS = ("id", "frame", "t_cross", "y_cross", "var_t", "cov_ty", "var_y")
#: Columns written as integers (``track``: an extra column of track ids, where present).
INTEGER_COLUMNS = ("id", "frame", "track")


@dataclass(frozen=True, eq=False)
class PredictedCrossings:
    """Predicted crossings ``N((t_c, y_c), Σ)`` of the line ``x = line``, one row per prediction.

    Attributes:
        ids: (k,) int64 track ids.
        frame: (k,) int64 the frame whose report made the prediction (non-decreasing).
        mean: (k, 2) float64 predicted ``(t_c, y_c)``: seconds (frame ``f`` at ``f·dt``) and the
            detections' units.
        cov: (k, 2, 2) float64 covariance of ``(t_c, y_c)``.
        line: The line's ``x`` (NaN when unknown, e.g. read from a file).
        extra: Further per-row columns by name, (k,) float64 each (e.g. ``t_true``, ``y_true``).
    """

    ids: NDArray[np.int64]
    frame: NDArray[np.int64]
    mean: NDArray[np.float64]
    cov: NDArray[np.float64]
    line: float = float("nan")
    extra: dict[str, NDArray[np.float64]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        ids = np.ascontiguousarray(self.ids, dtype=np.int64).reshape(-1)
        frame = np.ascontiguousarray(self.frame, dtype=np.int64).reshape(-1)
        mean = np.ascontiguousarray(self.mean, dtype=np.float64).reshape(-1, 2)
        cov = np.ascontiguousarray(self.cov, dtype=np.float64).reshape(-1, 2, 2)
        k = len(ids)
        if frame.shape != (k,) or mean.shape != (k, 2) or cov.shape != (k, 2, 2):
            raise ValueError(
                f"PredictedCrossings need ids (k,), frame (k,), mean (k, 2) and cov (k, 2, 2); got "
                f"{ids.shape}, {frame.shape}, {mean.shape}, {cov.shape}"
            )
        extra = {name: np.asarray(v, dtype=np.float64).reshape(-1) for name, v in self.extra.items()}
        bad = [name for name, v in extra.items() if v.shape != (k,)]
        if bad:
            raise ValueError(f"PredictedCrossings.extra columns {bad} must have shape ({k},)")
        object.__setattr__(self, "ids", ids)
        object.__setattr__(self, "frame", frame)
        object.__setattr__(self, "mean", mean)
        object.__setattr__(self, "cov", cov)
        object.__setattr__(self, "line", float(self.line))
        object.__setattr__(self, "extra", extra)

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def t(self) -> NDArray[np.float64]:
        """(k,) predicted crossing times."""
        return self.mean[:, 0]

    @property
    def y(self) -> NDArray[np.float64]:
        """(k,) predicted lateral positions."""
        return self.mean[:, 1]

    @classmethod
    def empty(cls, line: float = float("nan")) -> PredictedCrossings:
        """No prediction."""
        return cls(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros((0, 2, 2)), line)

    def take(self, rows: NDArray) -> PredictedCrossings:
        """The rows ``rows`` (indices or a boolean mask)."""
        return PredictedCrossings(
            self.ids[rows],
            self.frame[rows],
            self.mean[rows],
            self.cov[rows],
            self.line,
            {name: v[rows] for name, v in self.extra.items()},
        )

    def last(self) -> PredictedCrossings:
        """The last prediction of each track (the one that counts), in the order made."""
        if not len(self):
            return self
        reversed_ids = self.ids[::-1]
        _, first_reversed = np.unique(reversed_ids, return_index=True)
        return self.take(np.sort(len(self) - 1 - first_reversed))

    def equals(self, other: PredictedCrossings) -> bool:
        """Same rows and values (NaN equal to NaN; ``line`` is not compared)."""
        return (
            np.array_equal(self.ids, other.ids)
            and np.array_equal(self.frame, other.frame)
            and np.array_equal(self.mean, other.mean, equal_nan=True)
            and np.array_equal(self.cov, other.cov, equal_nan=True)
            and self.extra.keys() == other.extra.keys()
            and all(np.array_equal(v, other.extra[n], equal_nan=True) for n, v in self.extra.items())
        )


def write_crossings(path: str | os.PathLike[str], crossings: PredictedCrossings) -> None:
    """Write ``crossings`` as CSV (module docstring): integers as integers, floats with ``repr``
    (read back exactly), NaN as ``nan``; atomically (a failed write leaves the old file and raises
    [`FileWriteError`][track_envs.io.FileWriteError] naming the file and the cause)."""
    c = crossings
    columns: dict[str, NDArray] = {
        "id": c.ids,
        "frame": c.frame,
        "t_cross": c.mean[:, 0],
        "y_cross": c.mean[:, 1],
        "var_t": c.cov[:, 0, 0],
        "cov_ty": c.cov[:, 0, 1],
        "var_y": c.cov[:, 1, 1],
    } | c.extra
    text = [
        list(map(str, v.astype(np.int64).tolist()))
        if name in INTEGER_COLUMNS
        else list(map(repr, v.tolist()))
        for name, v in columns.items()
    ]
    lines = [",".join(columns), *map(",".join, zip(*text, strict=True)), ""]
    write_text(path, "\n".join(lines), encoding="ascii")


def read_crossings(path: str | os.PathLike[str]) -> PredictedCrossings:
    """Read a crossing file written by [`write_crossings`][track_envs.io.write_crossings] (columns by header
    name).

    Raises:
        DetectionFileError: a missing file, a header without the columns of
            `CROSSING_COLUMNS` (named), or a non-integer id /
            frame (row and column named).
    """
    from track_envs.io.csv_parser import read_table

    header = ",".join(CROSSING_COLUMNS)
    small = Path(path).is_file() and Path(path).stat().st_size < 2 * len(header)
    if small and Path(path).read_bytes().strip() == header.encode():  # no prediction
        return PredictedCrossings.empty()
    table = read_table(path, header=True)
    col = table.named_columns(CROSSING_COLUMNS, "crossing")
    v = table.values
    for name in ("id", "frame"):
        values = v[:, col[name]]
        bad = ~np.isfinite(values) | (values != np.round(values))
        if bad.any():
            r = int(np.argmax(bad))
            raise table.error(r, col[name], f"holds {float(values[r])!r}; expected an integer")
    cov = np.empty((len(v), 2, 2))
    cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 1] = v[:, col["var_t"]], v[:, col["cov_ty"]], v[:, col["var_y"]]
    cov[:, 1, 0] = cov[:, 0, 1]
    return PredictedCrossings(
        table.integers(col["id"]),
        v[:, col["frame"]].astype(np.int64),
        np.stack([v[:, col["t_cross"]], v[:, col["y_cross"]]], axis=1),
        cov,
        extra={name: v[:, i] for name, i in col.items() if name not in CROSSING_COLUMNS},
    )
