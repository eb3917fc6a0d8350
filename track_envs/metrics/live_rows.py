"""The live rows of a padded frame (real visible targets, report rows with mask 1), for numba kernels."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.compiled import njit


@njit(cache=True)
def select_rows(
    keep: NDArray[np.bool_], ids: NDArray[np.int64], positions: NDArray[np.float64]
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """``ids[keep]`` and ``positions[keep]`` (C-contiguous copies) in one pass."""
    n = 0
    for k in range(len(keep)):
        n += keep[k]
    out_ids = np.empty(n, dtype=np.int64)
    out_positions = np.empty((n, positions.shape[1]), dtype=np.float64)
    t = 0
    for k in range(len(keep)):
        if keep[k]:
            out_ids[t] = ids[k]
            out_positions[t] = positions[k]
            t += 1
    return out_ids, out_positions


@njit(cache=True)
def live_truth_rows(
    ids: NDArray[np.int64], positions: NDArray[np.float64], visible: NDArray[np.bool_]
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Ids and positions of the truth rows that are real (id >= 0) and visible."""
    return select_rows((ids >= 0) & visible, ids, positions)


@njit(cache=True)
def live_report_rows(
    ids: NDArray[np.int64], positions: NDArray[np.float64], mask: NDArray[np.int8]
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Ids and positions of the report rows with mask 1."""
    return select_rows(mask == 1, ids, positions)
