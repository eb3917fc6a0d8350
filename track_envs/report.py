"""The report: the action every tracking environment takes.

A report is a dict of fixed-shape arrays (``max_tracks`` rows, padded, with a mask):

========== ===================== ======= ==========================================================
key        shape                 dtype   meaning
========== ===================== ======= ==========================================================
ids        (max_tracks,)         int64   the agent's track identities
positions  (max_tracks, *P)      float32 reported position of each track (P = (D,) for points)
detection  (max_tracks,)         int64   detection row the track was updated with, -1 if it coasted
mask       (max_tracks,)         int8    1 for a real track row
========== ===================== ======= ==========================================================

An all-zero mask (the empty report) is valid. Every sample of :func:`report_space` is a valid
report, because ``gymnasium.utils.env_checker.check_env`` steps with random samples: a
``detection`` index that points at a padding row (or beyond) is read as -1, and duplicate ids
are scored as distinct hypotheses by the environment rewards.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces
from numba import njit
from numpy.typing import NDArray

REPORT_KEYS = ("ids", "positions", "detection", "mask")
_REPORT_KEY_SET = frozenset(REPORT_KEYS)
ID_LIMIT = 2**62


def report_space(
    max_tracks: int, position_shape: tuple[int, ...], low: NDArray, high: NDArray, max_detections: int
) -> spaces.Dict:
    """The action space of a report with ``max_tracks`` rows.

    Args:
        max_tracks: Rows of the report.
        position_shape: Shape of one track's position, ``(D,)`` or ``(17, 2)``.
        low: Lower bound of a position, broadcastable to ``position_shape``.
        high: Upper bound of a position, broadcastable to ``position_shape``.
        max_detections: Rows of the detection observation (bounds the ``detection`` entry).
    """
    shape = (max_tracks, *position_shape)
    return spaces.Dict(
        {
            "ids": spaces.Box(0, ID_LIMIT, shape=(max_tracks,), dtype=np.int64),
            "positions": spaces.Box(
                np.broadcast_to(np.asarray(low, dtype=np.float32), shape),
                np.broadcast_to(np.asarray(high, dtype=np.float32), shape),
                dtype=np.float32,
            ),
            "detection": spaces.Box(-1, max_detections - 1, shape=(max_tracks,), dtype=np.int64),
            "mask": spaces.Box(0, 1, shape=(max_tracks,), dtype=np.int8),
        }
    )


def empty_report(max_tracks: int, position_shape: tuple[int, ...]) -> dict[str, NDArray]:
    """A report with no tracks (all rows padding)."""
    return {
        "ids": np.zeros(max_tracks, dtype=np.int64),
        "positions": np.zeros((max_tracks, *position_shape), dtype=np.float32),
        "detection": np.full(max_tracks, -1, dtype=np.int64),
        "mask": np.zeros(max_tracks, dtype=np.int8),
    }


def pack_report(
    ids: NDArray[np.integer],
    positions: NDArray[np.floating],
    detection: NDArray[np.integer],
    max_tracks: int,
) -> dict[str, NDArray]:
    """Pad ``n`` live tracks into a report of ``max_tracks`` rows.

    Raises:
        ValueError: if ``n > max_tracks`` (no track is dropped silently) or the arrays disagree.
    """
    n = len(ids)
    if n > max_tracks:
        raise ValueError(
            f"{n} live tracks do not fit a report of max_tracks={max_tracks}; raise max_tracks "
            "in the environment (or delete tracks sooner)"
        )
    positions = np.asarray(positions)
    if positions.shape[0] != n or len(detection) != n:
        raise ValueError(
            f"report arrays disagree: {n} ids, {positions.shape[0]} positions, {len(detection)} detections"
        )
    report = empty_report(max_tracks, positions.shape[1:])
    report["ids"][:n] = ids
    report["positions"][:n] = positions
    report["detection"][:n] = detection
    report["mask"][:n] = 1
    return report


@dataclass(frozen=True)
class Report:
    """A validated report, trimmed to its live rows.

    Attributes:
        ids: (n,) int64 track ids.
        positions: (n, *P) float64 positions.
        detection: (n,) int64 detection rows, -1 where the track coasted or the index pointed
            at padding.
    """

    ids: NDArray[np.int64]
    positions: NDArray[np.float64]
    detection: NDArray[np.int64]

    def __len__(self) -> int:
        return len(self.ids)


def _require(report: Mapping, key: str, shape: tuple[int, ...], kinds: str, what: str) -> NDArray:
    value = report[key]
    arr = value if type(value) is np.ndarray else np.asarray(value)
    if arr.shape != shape:
        raise ValueError(f"report[{key!r}] must have shape {shape}, got {arr.shape}")
    if arr.dtype.kind not in kinds:
        raise ValueError(f"report[{key!r}] must hold {what}, got dtype {arr.dtype}")
    return arr


def validate_report(
    report: object,
    max_tracks: int,
    position_shape: tuple[int, ...],
    detection_mask: NDArray[np.int8],
) -> Report:
    """Check a report against the contract and return its live rows.

    Args:
        report: The action passed to ``env.step``.
        max_tracks: Expected rows.
        position_shape: Shape of one position.
        detection_mask: The ``"mask"`` of the observation the report answers; a ``detection``
            index that is out of range or points at a padding row is read as -1.

    Raises:
        ValueError: naming the key, the expected shape or dtype, or the offending rows.
    """
    if type(report) is not dict and not isinstance(report, Mapping):
        raise ValueError(
            f"the action must be a report dict with keys {REPORT_KEYS}, got {type(report).__name__}"
        )
    if report.keys() != _REPORT_KEY_SET:
        missing = [k for k in REPORT_KEYS if k not in report]
        extra = [k for k in report if k not in REPORT_KEYS]
        raise ValueError(f"report keys must be {REPORT_KEYS}; missing {missing}, unexpected {extra}")
    mask = _require(report, "mask", (max_tracks,), "iub", "0/1 integers")
    ids = _require(report, "ids", (max_tracks,), "iu", "integers")
    positions = _require(report, "positions", (max_tracks, *position_shape), "f", "floats")
    detection = _require(report, "detection", (max_tracks,), "iu", "integers")
    flat = positions.reshape(max_tracks, -1)
    ok, live_ids, live_positions, live_detection = _live_rows(
        mask, ids, flat, detection, np.asarray(detection_mask)
    )
    if not ok:
        _raise_bad_rows(mask, flat)
    return Report(
        ids=live_ids,
        positions=live_positions.reshape(len(live_ids), *position_shape),
        detection=live_detection,
    )


@njit(cache=True)
def _live_rows(
    mask: NDArray, ids: NDArray, positions: NDArray, detection: NDArray, detection_mask: NDArray
) -> tuple[bool, NDArray[np.int64], NDArray[np.float64], NDArray[np.int64]]:
    """The masked-in rows of a report (positions flattened to (max_tracks, F)) in one pass.

    Returns ``ok = False`` (and empty arrays) if a mask value is not 0/1 or a live position is not
    finite. A ``detection`` index outside ``[0, len(detection_mask))`` or on a padding row reads as -1.
    """
    n_rows, n_cols = positions.shape
    n = 0
    for r in range(n_rows):
        if mask[r] != 0:
            if mask[r] != 1:
                return False, np.empty(0, np.int64), np.empty((0, n_cols)), np.empty(0, np.int64)
            for c in range(n_cols):
                if not np.isfinite(positions[r, c]):
                    return False, np.empty(0, np.int64), np.empty((0, n_cols)), np.empty(0, np.int64)
            n += 1
    out_ids = np.empty(n, np.int64)
    out_positions = np.empty((n, n_cols), np.float64)
    out_detection = np.empty(n, np.int64)
    k = 0
    n_detections = len(detection_mask)
    for r in range(n_rows):
        if mask[r] != 0:
            out_ids[k] = ids[r]
            for c in range(n_cols):
                out_positions[k, c] = positions[r, c]
            d = detection[r]
            out_detection[k] = d if 0 <= d < n_detections and detection_mask[d] == 1 else -1
            k += 1
    return True, out_ids, out_positions, out_detection


def _raise_bad_rows(mask: NDArray, positions: NDArray) -> None:
    """Name the rows :func:`_live_rows` refused: mask values other than 0/1, or non-finite positions."""
    live = mask != 0
    bad = np.flatnonzero(live & (mask != 1))
    if mask.dtype.kind != "b" and len(bad):
        raise ValueError(f"report['mask'] must be 0 or 1; rows {bad[:10].tolist()} are not")
    finite = np.isfinite(positions).all(axis=1)
    rows = np.flatnonzero(live & ~finite)
    raise ValueError(f"report['positions'] has non-finite values in masked-in rows {rows[:10].tolist()}")
