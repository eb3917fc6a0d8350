"""Relative displacement data (rotation, speed) of a trajectory and its inverse (Jung et al. 2019).

Jung, Schlangen and Charlish, "Sequential Monte Carlo Filtering with Long Short-Term Memory
Prediction" (FUSION 2019), Sec. II-B, eq. (3): from positions ``x_0 … x_n`` (2-D),

    v_t = x_t − x_{t−1},    s_t = ‖v_t‖,    c_t = atan2(v_t², v_t¹),    r_t = wrap(c_t − c_{t−1}),

with ``r_0 = s_0 = 0`` and ``wrap`` onto ``(−π, π]``. The pair ``(r_t, s_t)`` (the turn since the
last heading and the step length) is invariant to rotating and shifting the trajectory, which is
what lets a model learnt on one curve track it rotated by 45°.

**Where the course is undefined** (a zero-length step, ``v_t = 0``), the paper leaves ``r``
undefined. The choice made here: such a step has ``r_t = 0`` and leaves the *heading* — the course
of the last non-zero step — unchanged; the next non-zero step turns relative to that kept heading,
``r_t = wrap(c_t − c_last)``. Before the first non-zero step there is no heading, and the first
non-zero step gets ``r = 0`` (its course becomes the heading). With this choice the map is
invertible given ``x_0`` and that first course
([`positions_from_displacements`][predictors.displacement.geometry.positions_from_displacements]), also across
stops; wherever ``v_{t−1} ≠ 0`` it is the paper's ``r_t`` exactly.

The inverse of one step ([`apply_displacement`][predictors.displacement.geometry.apply_displacement]) turns a
heading by ``r̂`` and moves a position ``ŝ`` along the new heading, ``c' = c + r̂``,
``x' = x + ŝ (cos c', sin c')`` — the prediction step of the LSTM particle filter. Every function is batched
over leading axes (targets).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


def wrap_angle(angle: ArrayLike) -> FloatArray:
    """``angle`` wrapped onto ``(−π, π]`` (``π ↦ π``, ``−π ↦ π``)."""
    a = np.asarray(angle, dtype=np.float64)
    return np.pi - np.mod(np.pi - a, 2.0 * np.pi)


class Displacements(NamedTuple):
    """The relative form of trajectories ``(..., n, 2)``.

    Attributes:
        rotation: ``r`` (..., n), ``r_0 = 0``, in ``(−π, π]``.
        speed: ``s`` (..., n), ``s_0 = 0``.
        first_heading: (...,) the course of the first non-zero step (0 where there is none); with
            ``x_0`` it makes the inverse exact.
    """

    rotation: FloatArray
    speed: FloatArray
    first_heading: FloatArray


def _check_positions(positions: ArrayLike, name: str = "positions") -> FloatArray:
    x = np.asarray(positions, dtype=np.float64)
    if x.ndim < 2 or x.shape[-1] != 2 or x.shape[-2] < 1:
        raise ValueError(f"{name} must have shape (..., n >= 1, 2), got {x.shape}")
    bad = ~np.isfinite(x).all(axis=-1)
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(f"{name} must be finite; {name}[{where}] is {x[where].tolist()}")
    return x


def displacements_of(positions: ArrayLike) -> Displacements:
    """``(r, s)`` of trajectories ``positions`` (..., n, 2) (module docstring, eq. (3)).

    Raises:
        ValueError: for a wrong shape or a non-finite position (naming its index and value).
    """
    x = _check_positions(positions)
    if x.shape[-2] == 1:
        zero = np.zeros(x.shape[:-1])
        return Displacements(zero, zero.copy(), np.zeros(x.shape[:-2]))
    v = np.diff(x, axis=-2)  # (..., n−1, 2): v[k] is the step into x[k+1]
    s = np.hypot(v[..., 0], v[..., 1])
    moving = s > 0
    course = np.arctan2(v[..., 1], v[..., 0])
    k = np.arange(v.shape[-2])
    last = np.maximum.accumulate(np.where(moving, k, -1), axis=-1)  # last moving step at or before k
    before = np.concatenate([np.full((*last.shape[:-1], 1), -1), last[..., :-1]], axis=-1)
    previous = np.take_along_axis(course, np.maximum(before, 0), axis=-1)
    r = np.where(moving & (before >= 0), wrap_angle(course - previous), 0.0)
    first = np.take_along_axis(course, np.argmax(moving, axis=-1)[..., None], axis=-1)[..., 0]
    first = np.where(moving.any(axis=-1), first, 0.0)
    zero = np.zeros((*x.shape[:-2], 1))
    return Displacements(
        np.concatenate([zero, r], axis=-1), np.concatenate([zero, s], axis=-1), np.asarray(first)
    )


def observe_step(
    step: ArrayLike, heading: ArrayLike, has_heading: ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray]:
    """Streaming form of [`displacements_of`][predictors.displacement.geometry.displacements_of]: the
    ``(r, s)`` of one new step per target.

    Args:
        step: ``v_t`` (T, 2), finite.
        heading: The current heading (T,) (the course of the last non-zero step).
        has_heading: (T,) whether a heading is defined yet.

    Returns:
        ``(r, s, heading', has_heading')``: ``r = wrap(c_t − heading)`` where ``v_t ≠ 0`` and a
            heading exists, else 0; the heading becomes ``c_t`` where ``v_t ≠ 0`` and is kept otherwise.
    """
    v = np.asarray(step, dtype=np.float64)
    h = np.asarray(heading, dtype=np.float64)
    has = np.asarray(has_heading, dtype=bool)
    s = np.hypot(v[..., 0], v[..., 1])
    moving = s > 0
    course = np.arctan2(v[..., 1], v[..., 0])
    r = np.where(moving & has, wrap_angle(course - h), 0.0)
    return r, s, np.where(moving, course, h), has | moving


def apply_displacement(
    heading: ArrayLike, position: ArrayLike, rotation: ArrayLike, speed: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """One step of the inverse: ``c' = wrap(c + r)``, ``x' = x + s (cos c', sin c')``.

    Args:
        heading: ``c`` (...,).
        position: ``x`` (..., 2).
        rotation: ``r`` (...,).
        speed: ``s`` (...,).

    Returns:
        ``(c', x')``.
    """
    c = wrap_angle(np.asarray(heading, dtype=np.float64) + np.asarray(rotation, dtype=np.float64))
    s = np.asarray(speed, dtype=np.float64)
    move = np.stack([s * np.cos(c), s * np.sin(c)], axis=-1)
    return c, np.asarray(position, dtype=np.float64) + move


def positions_from_displacements(
    rotation: ArrayLike, speed: ArrayLike, start: ArrayLike, first_heading: ArrayLike
) -> FloatArray:
    """The trajectories (..., n, 2) of ``(r, s)`` (..., n) from ``x_0 = start`` (..., 2).

    ``first_heading`` (...,) is the heading before step 1
    ([`Displacements.first_heading`][predictors.displacement.geometry.Displacements.first_heading]), so
    ``positions_from_displacements(*displacements_of(x), x[..., 0, :]...)`` returns ``x`` to float rounding:
    ``c_t = c_first + Σ_{k≤t} r_k``, ``x_t = x_0 + Σ_{k≤t} s_k (cos c_k, sin c_k)``.
    """
    r = np.asarray(rotation, dtype=np.float64)
    s = np.asarray(speed, dtype=np.float64)
    if r.shape != s.shape or r.ndim < 1:
        raise ValueError(f"rotation and speed must have the same shape (..., n), got {r.shape} and {s.shape}")
    c = np.asarray(first_heading, dtype=np.float64)[..., None] + np.cumsum(r, axis=-1)
    moves = np.stack([s * np.cos(c), s * np.sin(c)], axis=-1)
    moves[..., 0, :] = 0.0  # s_0 = 0: x_0 is the start
    return np.asarray(start, dtype=np.float64)[..., None, :] + np.cumsum(moves, axis=-2)
