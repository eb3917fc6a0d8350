"""How long a track should coast: the gaps after which the tracks' targets are seen again.

A tracker that deletes a track after ``max_misses`` missed frames splits a target that the detector
misses for longer into two tracks, one ending at frame ``t_e`` and one starting at ``t_s``. Such
pairs are found in a run's confident tracks: an end ``(t_e, z_e, v_e)`` — last detection, and the
velocity over its last ``START_SPAN`` frames — and a later start ``z_s`` that lies within the
coasted gate of the end, ``|z_s − (z_e + v_e (t_s − t_e) dt)| <= ρ(t_s − t_e − 1)``, where ``ρ(k)``
is the gate radius of a track after ``k`` missed frames
([`coasting_radii`][agents.sensor_model.coasting.coasting_radii]). Each end takes its earliest such start,
each start once. The gaps ``t_s − t_e − 1`` of these re-appearances are the detector's misses as the data show
them: a track should coast through the usual ones.

Looked for only up to the ambiguity bound (the missed frames after which ``ρ`` exceeds half the
stream's nearest-neighbour distance), so that a start is not another target's.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from agents.tracking.assign import chi2_gate
from predictors.base import KinematicModel


def coasting_radii(
    model: KinematicModel, dt: float, q: float, r: float, p_gate: float, dim: int, frames: int
) -> NDArray[np.float64]:
    """``ρ(k)``, ``k = 0..frames``: the χ² gate radius ``sqrt(γ S_k)`` of a track of the
    predictor's kinematic ``model`` (``Capability.KINEMATIC_MODEL``; ``q``, ``r`` per axis)
    predicted after ``k`` missed frames from its steady state."""
    F, Q, _ = model.kinematic_model(1, dt, q)
    P = np.zeros((model.order, model.order))
    for _ in range(500):  # the Riccati recursion to its steady state
        Pm = F @ P @ F.T + Q
        K = Pm[:, :1] / (Pm[0, 0] + r)
        P = Pm - K @ Pm[:1, :]
    out = np.empty(frames + 1)
    for k in range(frames + 1):
        P = F @ P @ F.T + Q
        out[k] = P[0, 0] + r
    return np.sqrt(chi2_gate(p_gate, dim) * out)


def reappearance_gaps(
    points: NDArray[np.float64],
    frames: NDArray[np.int64],
    labels: NDArray[np.int64],
    dt: float,
    radii: NDArray[np.float64],
    span: int,
) -> tuple[NDArray[np.int64], int]:
    """The gaps of the re-appearances (module docstring) and the number of track ends looked at.

    Args:
        points, frames, labels: The detections, their frames and track labels (−1: none).
        dt: Frame period.
        radii: ``ρ(0..K)``; starts up to ``K`` missed frames after an end are looked at.
        span: Frames the end velocity is taken over.
    """
    idx = np.flatnonzero(labels >= 0)
    idx = idx[np.lexsort((frames[idx], labels[idx]))]
    if not len(idx):
        return np.zeros(0, np.int64), 0
    lab = labels[idx]
    head = np.flatnonzero(np.concatenate([[True], lab[1:] != lab[:-1]]))
    tail = np.concatenate([head[1:], [len(lab)]]) - 1
    long = tail - head >= span
    last, before = idx[tail[long]], idx[tail[long] - span]
    first = idx[head]
    t_end = frames[last]
    v_end = (points[last] - points[before]) / ((frames[last] - frames[before]) * dt)[:, None]
    t_start, z_start = frames[first], points[first]
    horizon = len(radii) - 1
    order = np.argsort(t_start, kind="stable")
    t_start, z_start = t_start[order], z_start[order]
    taken = np.zeros(len(t_start), bool)
    gaps = []
    for e in np.argsort(t_end, kind="stable"):
        lo = np.searchsorted(t_start, t_end[e] + 2)
        hi = np.searchsorted(t_start, t_end[e] + horizon + 2)
        if lo == hi:
            continue
        steps = t_start[lo:hi] - t_end[e]
        predicted = points[last[e]] + v_end[e] * (steps * dt)[:, None]
        near = np.linalg.norm(z_start[lo:hi] - predicted, axis=1) <= radii[steps - 1]
        near &= ~taken[lo:hi]
        if near.any():
            j = lo + int(np.argmax(near))
            taken[j] = True
            gaps.append(int(t_start[j] - t_end[e] - 1))
    return np.asarray(gaps, np.int64), len(last)
