"""Compiled (numba) per-frame bookkeeping of the GNN tracker: one pass over tracks and detections.

After the association of a frame, track ``i`` holds the detection ``det_i`` it was assigned
(−1: none). Then, per track,

.. math::

    \\text{seen}_i = [det_i \\ge 0], \\qquad
    \\text{misses}_i \\leftarrow \\begin{cases} 0 & \\text{seen}_i \\\\
        \\text{misses}_i + 1 & \\text{else} \\end{cases}, \\qquad
    \\text{streak}_i \\leftarrow \\begin{cases} \\text{streak}_i + 1 & \\text{seen}_i \\\\
        0 & \\text{else} \\end{cases},

    \\text{keep}_i = [\\text{misses}_i \\le M] \\wedge
        (\\text{seen}_i \\vee \\text{low} \\le ŷ_i \\le \\text{high}),

    \\text{young}_i = \\text{seen}_i \\wedge [s_{lo} \\le \\text{streak}_i \\le s_{hi}],

and the detections no track took start new tracks.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from track_envs.types import FloatArray

IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]


@njit(cache=True)
def frame_upkeep(
    det_of_track: IntArray,
    misses: IntArray,
    streak: IntArray,
    predicted: FloatArray,
    low: FloatArray,
    high: FloatArray,
    max_misses: int,
    young_streak: tuple[int, int],
    n_detections: int,
) -> tuple[BoolArray, IntArray, IntArray, BoolArray, int, BoolArray, int, IntArray]:
    """The per-track counters and masks of a frame (see the module docstring for the equations).

    Args:
        det_of_track: (n,) detection index of each track, −1 when it coasted.
        misses: (n,) consecutive misses before this frame.
        streak: (n,) consecutive updates before this frame.
        predicted: (n, D) predicted measurement ``ŷ`` of each track.
        low: (D,) lower corner of the region where coasting tracks are kept.
        high: (D,) upper corner of that region.
        max_misses: ``M``, the most consecutive misses a kept track may have.
        young_streak: ``(s_lo, s_hi)``, the update streaks of the young tracks.
        n_detections: ``m``, detections in the frame.

    Returns:
        ``(seen, misses, streak, keep, n_keep, young, n_young, unused)``: new arrays (the inputs
        are not written), and ``unused``, the detections (ascending) that no track took.
    """
    n = det_of_track.shape[0]
    D = predicted.shape[1]
    seen = np.empty(n, dtype=np.bool_)
    misses_out = np.empty(n, dtype=np.int64)
    streak_out = np.empty(n, dtype=np.int64)
    keep = np.empty(n, dtype=np.bool_)
    young = np.empty(n, dtype=np.bool_)
    used = np.zeros(n_detections, dtype=np.bool_)
    n_keep = 0
    n_young = 0
    n_used = 0
    for i in range(n):
        det = det_of_track[i]
        hit = det >= 0
        seen[i] = hit
        if hit:
            used[det] = True
            n_used += 1
            misses_out[i] = 0
            streak_out[i] = streak[i] + 1
        else:
            misses_out[i] = misses[i] + 1
            streak_out[i] = 0
        inside = True
        for d in range(D):
            if not (predicted[i, d] >= low[d] and predicted[i, d] <= high[d]):
                inside = False
        keep[i] = misses_out[i] <= max_misses and (inside or hit)
        n_keep += keep[i]
        young[i] = hit and young_streak[0] <= streak_out[i] <= young_streak[1]
        n_young += young[i]
    unused = np.empty(n_detections - n_used, dtype=np.int64)
    k = 0
    for j in range(n_detections):
        if not used[j]:
            unused[k] = j
            k += 1
    return seen, misses_out, streak_out, keep, n_keep, young, n_young, unused


@njit(cache=True)
def median_and_mad_variance(v: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Per column of ``v`` (n, D), n >= 1: the median ``m_j`` and the robust variance
    ``(1.4826 · median_i |v_ij − m_j|)²`` (the MAD scaled to a normal's standard deviation)."""
    n, dim = v.shape
    median = np.empty(dim)
    variance = np.empty(dim)
    column = np.empty(n)
    for j in range(dim):
        for i in range(n):
            column[i] = v[i, j]
        median[j] = np.median(column)
        for i in range(n):
            column[i] = abs(v[i, j] - median[j])
        variance[j] = (1.4826 * np.median(column)) ** 2
    return median, variance
