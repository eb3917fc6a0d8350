"""The nozzle bar of an optical belt sorter: where and when each particle crosses it (truth).

A belt sorter's camera sees a window of the belt; a bar of air nozzles sits a distance
``nozzle_offset`` downstream of the window's end, at ``x = L = window end + nozzle_offset``, and
fires at the particles to be ejected as they pass it (Pfaff et al., "TrackSort: Predictive
Tracking for Sorting Uncooperative Bulk Materials", 2015). The truth of that moment is, per
particle, the time ``t_c`` at which its centroid reaches ``x = L`` and its lateral position
``y_c`` there. The belt envs put the crossings of each frame into ``info["truth"]``, in fixed
shapes (``max_targets`` rows, a particle per row, −1 / 0 padded):

============== ============= ======= ==========================================================
key            shape         dtype   meaning
============== ============= ======= ==========================================================
nozzle_ids     (max_targets,) int64  truth id of a particle that crossed the line since the
                                     previous frame, −1 on padding rows
nozzle_times   (max_targets,) float64 its crossing time ``t_c`` in seconds, on the clock of
                                     ``info["t"]`` (so ``t − dt < t_c <= t``)
nozzle_lateral (max_targets,) float64 its lateral position ``y_c`` at the crossing
============== ============= ======= ==========================================================

A particle pushed back over the line and crossing it again is listed again; a scorer takes the
first crossing ([`SortingPrediction`][track_envs.metrics.SortingPrediction] does).
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
from numpy.typing import NDArray

NOZZLE_KEYS = ("nozzle_ids", "nozzle_times", "nozzle_lateral")
#: The default distance (m) from the end of the camera window to the nozzle bar.
DEFAULT_NOZZLE_OFFSET = 0.05
#: The farthest nozzle bar BeltSorter-v0 simulates (m downstream of the window's end).
MAX_NOZZLE_OFFSET = 0.25


def check_nozzle_offset(value: Any, high: float = MAX_NOZZLE_OFFSET) -> float | None:
    """``value`` as a float in ``(0, high]`` (sensor units, metres on the belt), ``None`` (no
    nozzle bar) as ``None``.

    Raises:
        ValueError: naming ``nozzle_offset``, its valid range and the value given.
    """
    if value is None:
        return None
    span = "> 0" if math.isinf(high) else f"in (0, {high}]"
    valid = f"a distance {span} downstream of the camera window (m on the belt), or None for no nozzle bar"
    if isinstance(value, bool | np.bool_) or not isinstance(value, int | float | np.integer | np.floating):
        raise ValueError(f"nozzle_offset must be a number ({valid}), got {value!r} ({type(value).__name__})")
    out = float(value)
    if not (math.isfinite(out) and 0.0 < out <= high):
        raise ValueError(f"nozzle_offset must be {valid}, got {value!r}")
    return out


def pack_crossings(
    ids: NDArray[np.int64], times: NDArray[np.float64], lateral: NDArray[np.float64], rows: int
) -> tuple[dict[str, NDArray], int]:
    """The crossings of one frame padded to ``rows`` (see the module docstring), and how many did
    not fit (dropped, warned once by the caller)."""
    k = min(len(ids), rows)
    out_ids = np.full(rows, -1, dtype=np.int64)
    out_times = np.zeros(rows)
    out_lateral = np.zeros(rows)
    out_ids[:k] = ids[:k]
    out_times[:k] = times[:k]
    out_lateral[:k] = lateral[:k]
    return {"nozzle_ids": out_ids, "nozzle_times": out_times, "nozzle_lateral": out_lateral}, len(ids) - k


def warn_dropped_crossings(dropped: int, frame: int, rows: int) -> None:
    """Warn that ``dropped`` crossings of frame ``frame`` did not fit ``rows`` truth rows."""
    warnings.warn(
        f"{dropped} nozzle crossings in frame {frame} do not fit max_targets={rows}; the surplus is "
        "left out of info['truth']",
        RuntimeWarning,
        stacklevel=4,
    )


def recorded_crossings(
    tracks: NDArray[np.float64], line_x: float, dt: float
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """Line crossings of recorded tracks, interpolated linearly between the two frames around each.

    Args:
        tracks: (frames, particles, 2) positions, NaN where a particle was not recorded.
        line_x: The line ``x = L``.
        dt: Frame period (s).

    Returns:
        frame (k,) — the frame whose ``info`` reports the crossing (the later of the two), truth
            ids (k,), times ``t_c = (f₀ + φ) dt`` (k,) with ``φ = (L − x₀) / (x₁ − x₀)`` between
            frames ``f₀`` and ``f₀ + 1``, and lateral positions ``y₀ + φ (y₁ − y₀)`` (k,), ordered by
            frame then id. Only consecutive recorded frames (both finite) are used.
    """
    x0, x1 = tracks[:-1, :, 0], tracks[1:, :, 0]
    with np.errstate(invalid="ignore"):
        crossing = (x0 < line_x) & (x1 >= line_x)
    f0, ids = np.nonzero(crossing)
    a, b = tracks[f0, ids], tracks[f0 + 1, ids]
    phi = (line_x - a[:, 0]) / (b[:, 0] - a[:, 0])
    return (
        (f0 + 1).astype(np.int64),
        ids.astype(np.int64),
        (f0 + phi) * dt,
        a[:, 1] + phi * (b[:, 1] - a[:, 1]),
    )
