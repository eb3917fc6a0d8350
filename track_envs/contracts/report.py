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

A report may also carry the optional sorting channel (``sorting_ids``, ``sorting_mask``,
``sorting_mean``, ``sorting_cov``: predicted nozzle-bar crossings, see
[`track_envs.contracts.sorting_channel`][track_envs.contracts.sorting_channel]); a report without it is valid
as before.

An all-zero mask (the empty report) is valid. The ids of the live rows (mask 1) must be
non-negative, at most [`ID_LIMIT`][track_envs.contracts.report.ID_LIMIT] and distinct within the report: a
repeated id would let one identity claim several targets (and inflate MOTA), so
[`validate_report`][track_envs.contracts.validate_report] rejects it. A ``detection`` index that points at a
padding row (or beyond) is read as -1.

Every sample of [`report_space`][track_envs.contracts.report_space] is a valid report, because
``gymnasium.utils.env_checker.check_env`` steps with random samples: the space
([`ReportSpace`][track_envs.contracts.ReportSpace]) draws distinct ids.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from track_envs.contracts.sorting_channel import (
    SORTING_KEY_SET,
    SORTING_KEYS,
    SortingPredictions,
    validate_sorting,
)
from track_envs.infra.compiled import njit

REPORT_KEYS = ("ids", "positions", "detection", "mask")
_REPORT_KEY_SET = frozenset(REPORT_KEYS)
_WITH_SORTING = _REPORT_KEY_SET | SORTING_KEY_SET
#: Largest track id a report may hold (the bound of the action space's ``"ids"`` box).
ID_LIMIT = 2**62

# what _live_rows found (0: a valid report)
_OK, _BAD_MASK, _NOT_FINITE, _BAD_ID, _REPEATED_ID = range(5)


class ReportSpace(spaces.Dict):
    """The ``Dict`` action space of a report whose samples are valid reports.

    ``spaces.Dict.sample`` samples every key independently, so the ``"ids"`` box would give
    repeated ids; here they are drawn without replacement from ``[0, high]`` (``high`` the
    box's bound) with the space's own ``np_random`` (seeded by `seed`). The other keys are
    sampled by their boxes; ``mask`` and ``probability`` are passed to them as ``spaces.Dict``
    passes them (boxes accept ``None`` per key only).

    [`contains`][track_envs.contracts.ReportSpace.contains] also requires the ids of the live rows (mask 1) to
    be distinct, and accepts a report that carries a valid optional sorting channel
    (`track_envs.contracts.sorting_channel`), which the space does not
    sample.
    """

    def sample(
        self, mask: dict[str, Any] | None = None, probability: dict[str, Any] | None = None
    ) -> dict[str, Any]:
        """A random valid report: every box sampled, then distinct ids drawn."""
        report = super().sample(mask=mask, probability=probability)
        box = self.spaces["ids"]
        assert isinstance(box, spaces.Box)
        high = int(np.min(box.high))
        report["ids"] = self.np_random.choice(high + 1, size=box.shape, replace=False).astype(box.dtype)
        return report

    def contains(self, x: Any) -> bool:
        """Whether ``x`` lies in every box and its live rows carry distinct ids (and its sorting
        channel, when it has one, is valid)."""
        if isinstance(x, dict) and x.keys() == _WITH_SORTING:
            try:
                validate_sorting(x, len(np.asarray(x["mask"])), ID_LIMIT)
            except ValueError:
                return False
            x = {k: x[k] for k in REPORT_KEYS}
        if not super().contains(x):
            return False
        ids = np.asarray(x["ids"])[np.asarray(x["mask"]) != 0]
        return len(np.unique(ids)) == len(ids)


def report_space(
    max_tracks: int, position_shape: tuple[int, ...], low: NDArray, high: NDArray, max_detections: int
) -> ReportSpace:
    """The action space of a report with ``max_tracks`` rows (ids in ``[0, ID_LIMIT]``).

    Args:
        max_tracks: Rows of the report.
        position_shape: Shape of one track's position, ``(D,)`` or ``(17, 2)``.
        low: Lower bound of a position, broadcastable to ``position_shape``.
        high: Upper bound of a position, broadcastable to ``position_shape``.
        max_detections: Rows of the detection observation (bounds the ``detection`` entry).
    """
    shape = (max_tracks, *position_shape)
    return ReportSpace(
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


class ReportOverflowError(ValueError):
    """More live tracks than a report has rows: ``n_tracks`` tracks, ``max_tracks`` rows.

    A ``ValueError``, so callers that catch those still do;
    [`agents.files.points.run_agent`][agents.run_agent] catches this one and runs again with a larger report.
    """

    def __init__(self, n_tracks: int, max_tracks: int) -> None:
        super().__init__(
            f"{n_tracks} live tracks do not fit a report of max_tracks={max_tracks}; raise max_tracks "
            "in the environment (or delete tracks sooner)"
        )
        self.n_tracks = int(n_tracks)
        self.max_tracks = int(max_tracks)


#: True inside [`growable_reports`][track_envs.contracts.report.growable_reports], False inside
#: [`fixed_reports`][track_envs.contracts.report.fixed_reports], None elsewhere.
_GROWABLE: ContextVar[bool | None] = ContextVar("growable_reports", default=None)


@contextmanager
def growable_reports() -> Iterator[None]:
    """Within this context [`pack_report`][track_envs.contracts.pack_report] grows a report to its ``n`` live
    tracks where they exceed ``max_tracks``, instead of raising
    [`ReportOverflowError`][track_envs.contracts.ReportOverflowError].

    For loops that gather the reports themselves, frame by frame, whatever their size
    ([`agents.files.points.run_agent`][agents.run_agent]): a tracker then goes on with every track and a
    recorded file never has to be tracked again with a larger report. An environment's action
    space has ``max_tracks`` rows; outside this context a report never has more.
    """
    token = _GROWABLE.set(True)
    try:
        yield
    finally:
        _GROWABLE.reset(token)


@contextmanager
def fixed_reports() -> Iterator[None]:
    """Within this context a report keeps ``max_tracks`` rows: a tracker that would grow its report
    ([`PointTracker`][agents.PointTracker]) lets [`pack_report`][track_envs.contracts.pack_report] raise
    [`ReportOverflowError`][track_envs.contracts.ReportOverflowError] instead (``run_agent(grow=False)``, a
    run that collects a fixed-size sorting channel)."""
    token = _GROWABLE.set(False)
    try:
        yield
    finally:
        _GROWABLE.reset(token)


def report_growth() -> str:
    """How a tracker's report grows here: ``"exact"`` (to its live tracks, inside
    [`growable_reports`][track_envs.contracts.report.growable_reports]), ``"fixed"`` (never, inside
    [`fixed_reports`][track_envs.contracts.report.fixed_reports]) or ``"double"`` (elsewhere: a point tracker
    doubles its rows until its tracks fit, and warns)."""
    state = _GROWABLE.get()
    return "double" if state is None else ("exact" if state else "fixed")


def pack_report(
    ids: NDArray[np.integer],
    positions: NDArray[np.floating],
    detection: NDArray[np.integer],
    max_tracks: int,
) -> dict[str, NDArray]:
    """Pad ``n`` live tracks into a report of ``max_tracks`` rows (``n`` rows where ``n >
    max_tracks`` within `growable_reports`).

    Raises:
        ReportOverflowError: if ``n > max_tracks`` (no track is dropped silently; a ValueError),
            outside `growable_reports`.
        ValueError: if the arrays disagree.
    """
    n = len(ids)
    if n > max_tracks:
        if not _GROWABLE.get():
            raise ReportOverflowError(n, max_tracks)
        max_tracks = n
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
        ids: (n,) int64 track ids, distinct and in ``[0, ID_LIMIT]``.
        positions: (n, *P) float64 positions.
        detection: (n,) int64 detection rows, -1 where the track coasted or the index pointed
            at padding.
        sorting: The live rows of the optional sorting channel, or ``None`` when the report has
            none.
    """

    ids: NDArray[np.int64]
    positions: NDArray[np.float64]
    detection: NDArray[np.int64]
    sorting: SortingPredictions | None = None

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
        ValueError: naming the key, the expected shape or dtype, or the offending rows: a mask
            value other than 0/1; a live row (mask 1) with a non-finite position, an id outside
            ``[0, ID_LIMIT]``, or an id another live row also carries; a bad optional sorting
            channel
            ([`track_envs.contracts.sorting_channel.validate_sorting`][track_envs.contracts.validate_sorting]).
    """
    if type(report) is not dict and not isinstance(report, Mapping):
        raise ValueError(
            f"the action must be a report dict with keys {REPORT_KEYS}, got {type(report).__name__}"
        )
    keys = report.keys()
    sorting = None
    if keys != _REPORT_KEY_SET:
        if keys != _WITH_SORTING:
            missing = [k for k in REPORT_KEYS if k not in report]
            present = [k for k in SORTING_KEYS if k in report]
            if present and len(present) < len(SORTING_KEYS):
                missing += [k for k in SORTING_KEYS if k not in report]
            extra = [k for k in report if k not in _WITH_SORTING]
            raise ValueError(
                f"report keys must be {REPORT_KEYS}, optionally with the sorting channel {SORTING_KEYS}; "
                f"missing {missing}, unexpected {extra}"
            )
        sorting = validate_sorting(report, max_tracks, ID_LIMIT)
    mask = _require(report, "mask", (max_tracks,), "iub", "0/1 integers")
    ids = _require(report, "ids", (max_tracks,), "iu", "integers")
    positions = _require(report, "positions", (max_tracks, *position_shape), "f", "floats")
    detection = _require(report, "detection", (max_tracks,), "iu", "integers")
    flat = positions.reshape(max_tracks, -1)
    # uint64 ids above ID_LIMIT stay above it as int64 (the kernel compares in int64)
    kernel_ids = np.minimum(ids, ID_LIMIT + 1).astype(np.int64) if ids.dtype == np.uint64 else ids
    status, live_ids, live_positions, live_detection = _live_rows(
        mask, kernel_ids, flat, detection, np.asarray(detection_mask), ID_LIMIT
    )
    if status != _OK:
        _raise_bad_rows(mask, ids, flat)
    return Report(
        ids=live_ids,
        positions=live_positions.reshape(len(live_ids), *position_shape),
        detection=live_detection,
        sorting=sorting,
    )


@njit(cache=True)
def _live_rows(
    mask: NDArray,
    ids: NDArray,
    positions: NDArray,
    detection: NDArray,
    detection_mask: NDArray,
    id_high: int,
) -> tuple[int, NDArray[np.int64], NDArray[np.float64], NDArray[np.int64]]:
    """The masked-in rows of a report (positions flattened to (max_tracks, F)) in one pass.

    Returns a status (``_OK``, or the first problem met: a mask value not 0/1, a live position
    not finite, a live id outside ``[0, id_high]``, a live id repeated) and the live rows (empty
    arrays unless ``_OK``). Repeats are found on the sorted live ids (``O(n log n)``). A
    ``detection`` index outside ``[0, len(detection_mask))`` or on a padding row reads as -1.
    """
    n_rows, n_cols = positions.shape
    n = 0
    status = _OK
    for r in range(n_rows):
        if mask[r] != 0:
            if mask[r] != 1:
                status = _BAD_MASK
                break
            for c in range(n_cols):
                if not np.isfinite(positions[r, c]):
                    status = _NOT_FINITE
            if status != _OK:
                break
            if ids[r] < 0 or ids[r] > id_high:
                status = _BAD_ID
                break
            n += 1
    if status != _OK:
        return status, np.empty(0, np.int64), np.empty((0, n_cols)), np.empty(0, np.int64)
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
    if n > 1:
        ordered = np.sort(out_ids)
        for k in range(1, n):
            if ordered[k] == ordered[k - 1]:
                return _REPEATED_ID, np.empty(0, np.int64), np.empty((0, n_cols)), np.empty(0, np.int64)
    return _OK, out_ids, out_positions, out_detection


def _raise_bad_rows(mask: NDArray, ids: NDArray, positions: NDArray) -> None:
    """Name the rows [`_live_rows`][track_envs.contracts.report._live_rows] refused: mask values other than
    0/1, non-finite positions, ids out of range or repeated (live rows only, the first 10 of each)."""
    live = mask != 0
    bad = np.flatnonzero(live & (mask != 1))
    if mask.dtype.kind != "b" and len(bad):
        raise ValueError(f"report['mask'] must be 0 or 1; rows {bad[:10].tolist()} are not")
    finite = np.isfinite(positions).all(axis=1)
    rows = np.flatnonzero(live & ~finite)
    if len(rows):
        raise ValueError(f"report['positions'] has non-finite values in masked-in rows {rows[:10].tolist()}")
    rows = np.flatnonzero(live & ((ids < 0) | (ids > ID_LIMIT)))
    if len(rows):
        raise ValueError(
            f"report['ids'] must be in [0, 2**62] on masked-in rows; rows {rows[:10].tolist()} hold "
            f"{ids[rows[:10]].tolist()}"
        )
    live_rows = np.flatnonzero(live)
    values, inverse, counts = np.unique(ids[live_rows], return_inverse=True, return_counts=True)
    rows = live_rows[counts[inverse] > 1]
    raise ValueError(
        f"report['ids'] must be distinct among masked-in rows (one id per track); rows "
        f"{rows[:10].tolist()} repeat ids {values[counts > 1][:10].tolist()}"
    )
