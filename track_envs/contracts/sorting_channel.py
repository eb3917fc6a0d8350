"""The report's optional sorting channel: each track's predicted crossing of the nozzle bar.

An optical belt sorter fires an air valve at a particle as it passes the nozzle bar downstream of
the camera (Pfaff et al., "TrackSort: Predictive Tracking for Sorting Uncooperative Bulk
Materials", 2015). A tracker that knows the bar (``SensorSpec.sorting_line``, the line
``x = L``) reports, for a track seen for the last time, when and where across the belt it
predicts the particle to cross ``x = L``, as a Gaussian over ``(t_c, y_c)``. A report may carry
these four keys besides the four of
[`track_envs.contracts.report.REPORT_KEYS`][track_envs.contracts.report.REPORT_KEYS]; a report without them is
as valid as before. Its rows are independent of the track rows (a predicted track has usually just been
deleted, so it is no longer among them):

============ ====================== ======= ===================================================
key          shape                  dtype   meaning
============ ====================== ======= ===================================================
sorting_ids  (max_tracks,)          int64   the track whose crossing is predicted
sorting_mask (max_tracks,)          int8    1 for a real prediction row
sorting_mean (max_tracks, 2)        float64 predicted crossing time ``t_c`` (s, on the env's
                                            clock: frame ``k`` is at ``k·dt``, frame 0 the
                                            observation of ``reset``) and lateral position
                                            ``y_c`` (sensor units)
sorting_cov  (max_tracks, 2, 2)     float64 covariance of ``(t_c, y_c)`` (s², s·unit, unit²)
============ ====================== ======= ===================================================

Live rows (mask 1) need distinct ids in ``[0, ID_LIMIT]``, a finite mean and a finite,
symmetric covariance with a non-negative diagonal. The channel is not part of the action space
([`ReportSpace`][track_envs.contracts.ReportSpace] samples reports without it, so ``check_env`` is
unchanged), but [`contains`][track_envs.contracts.ReportSpace.contains] accepts a valid one.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

SORTING_KEYS = ("sorting_ids", "sorting_mask", "sorting_mean", "sorting_cov")
SORTING_KEY_SET = frozenset(SORTING_KEYS)


@dataclass(frozen=True)
class SortingPredictions:
    """The live rows of a report's sorting channel.

    Attributes:
        ids: (k,) int64 track ids.
        mean: (k, 2) predicted ``(t_c, y_c)``.
        cov: (k, 2, 2) their covariances.
    """

    ids: NDArray[np.int64]
    mean: NDArray[np.float64]
    cov: NDArray[np.float64]

    def __len__(self) -> int:
        return len(self.ids)


def empty_sorting(max_tracks: int) -> dict[str, NDArray]:
    """A sorting channel with no prediction (all rows padding)."""
    return {
        "sorting_ids": np.zeros(max_tracks, dtype=np.int64),
        "sorting_mask": np.zeros(max_tracks, dtype=np.int8),
        "sorting_mean": np.zeros((max_tracks, 2)),
        "sorting_cov": np.zeros((max_tracks, 2, 2)),
    }


def pack_sorting(
    ids: NDArray[np.integer], mean: NDArray[np.floating], cov: NDArray[np.floating], max_tracks: int
) -> dict[str, NDArray]:
    """Pad ``k`` predictions into a sorting channel of ``max_tracks`` rows.

    Raises:
        ValueError: if ``k > max_tracks`` or the arrays disagree.
    """
    k = len(ids)
    if k > max_tracks:
        raise ValueError(f"{k} sorting predictions do not fit a report of max_tracks={max_tracks}")
    if np.shape(mean) != (k, 2) or np.shape(cov) != (k, 2, 2):
        raise ValueError(
            f"sorting arrays disagree: {k} ids, mean {np.shape(mean)} (want ({k}, 2)), cov "
            f"{np.shape(cov)} (want ({k}, 2, 2))"
        )
    channel = empty_sorting(max_tracks)
    channel["sorting_ids"][:k] = ids
    channel["sorting_mask"][:k] = 1
    channel["sorting_mean"][:k] = mean
    channel["sorting_cov"][:k] = cov
    return channel


def validate_sorting(report: Mapping, max_tracks: int, id_limit: int) -> SortingPredictions:
    """Check a report's sorting channel (see the module docstring) and return its live rows.

    Raises:
        ValueError: naming the key and what is wrong with it (shape, dtype, mask values, rows
            with a bad id, a non-finite mean, a bad covariance).
    """
    mask = _array(report, "sorting_mask", (max_tracks,), "iub", "0/1 integers")
    ids = _array(report, "sorting_ids", (max_tracks,), "iu", "integers")
    mean = _array(report, "sorting_mean", (max_tracks, 2), "f", "floats")
    cov = _array(report, "sorting_cov", (max_tracks, 2, 2), "f", "floats")
    bad = np.flatnonzero((mask != 0) & (mask != 1))
    if len(bad):
        raise ValueError(f"report['sorting_mask'] must be 0 or 1; rows {bad[:10].tolist()} are not")
    live = np.flatnonzero(mask == 1)
    live_ids = ids[live]
    rows = live[(live_ids < 0) | (live_ids > id_limit)]
    if len(rows):
        raise ValueError(
            f"report['sorting_ids'] must be in [0, 2**62] on masked-in rows; rows {rows[:10].tolist()}"
        )
    if len(np.unique(live_ids)) != len(live_ids):
        raise ValueError(
            "report['sorting_ids'] must be distinct among masked-in rows (one prediction per track)"
        )
    m, c = mean[live].astype(np.float64), cov[live].astype(np.float64)
    rows = live[~np.isfinite(m).all(axis=1)]
    if len(rows):
        raise ValueError(
            f"report['sorting_mean'] has non-finite values in masked-in rows {rows[:10].tolist()}"
        )
    diagonal = np.diagonal(c, axis1=1, axis2=2)
    finite = np.isfinite(c).all(axis=(1, 2))
    scale = np.maximum(np.abs(c).max(axis=(1, 2), initial=0.0), 1e-300) if len(c) else np.zeros(0)
    symmetric = np.abs(c[:, 0, 1] - c[:, 1, 0]) <= 1e-9 * scale
    rows = live[~(finite & symmetric & (diagonal >= 0).all(axis=1))]
    if len(rows):
        raise ValueError(
            "report['sorting_cov'] must be finite and symmetric with a non-negative diagonal on "
            f"masked-in rows; rows {rows[:10].tolist()} are not"
        )
    return SortingPredictions(ids=live_ids.astype(np.int64), mean=m, cov=c)


def _array(report: Mapping, key: str, shape: tuple[int, ...], kinds: str, what: str) -> NDArray:
    arr = np.asarray(report[key])
    if arr.shape != shape:
        raise ValueError(f"report[{key!r}] must have shape {shape}, got {arr.shape}")
    if arr.dtype.kind not in kinds:
        raise ValueError(f"report[{key!r}] must hold {what}, got dtype {arr.dtype}")
    return arr
