"""Compiled per-frame kernels of the belt world (numba): belt friction, exits, parking, read-out.

Every kernel works on the world's row table ``rows`` (m, 6) — one row per pymunk body in the
space's iteration order, columns ``x, y, angle, vx, vy, spin`` in the frame that moves with the
belt — and on the row labels ``truth`` (m,) (truth id >= 0 for a particle on the belt,
[`PARKED`][track_envs.envs.belt_kernels.PARKED] for a parked body,
[`NOT_PARTICLE`][track_envs.envs.belt_kernels.NOT_PARTICLE] for the wall body) and ``kind`` (m,).

In the belt frame a particle's velocity *is* its slip over the belt, so Coulomb friction with
deceleration ``a_k = μ_k g`` over a step ``h`` is

.. math::

    u \\leftarrow u \\, \\max\\big(0, 1 − a_k h / |u|\\big), \\qquad
    |ω| \\leftarrow \\max\\big(0, |ω| − (a_k / r_k) h\\big).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.compiled import njit

PARKED = -1
NOT_PARTICLE = -2
PARK_ORIGIN = 1000.0
PARK_SPACING = 0.1
PARK_COLUMNS = 64


@njit(cache=True)
def park_row(rows: NDArray[np.float64], truth: NDArray[np.int64], r: int) -> None:
    """Put the body of row ``r`` at rest on its own parking spot far from the belt."""
    rows[r, :] = 0.0
    rows[r, 0] = PARK_ORIGIN + PARK_SPACING * (r % PARK_COLUMNS)
    rows[r, 1] = PARK_ORIGIN + PARK_SPACING * (r // PARK_COLUMNS)
    truth[r] = PARKED


@njit(cache=True)
def park_exits(rows: NDArray[np.float64], truth: NDArray[np.int64], x_exit: float) -> int:
    """Park every particle with belt-frame ``x > x_exit``; return how many were parked."""
    parked = 0
    for r in range(rows.shape[0]):
        if truth[r] >= 0 and rows[r, 0] > x_exit:
            park_row(rows, truth, r)
            parked += 1
    return parked


@njit(cache=True)
def belt_friction(
    rows: NDArray[np.float64],
    truth: NDArray[np.int64],
    kind: NDArray[np.int64],
    decel: NDArray[np.float64],
    spin_decel: NDArray[np.float64],
    h: float,
) -> None:
    """Coulomb belt friction over a step ``h`` on every particle row (belt-frame velocities)."""
    for r in range(rows.shape[0]):
        if truth[r] < 0:
            continue
        k = kind[r]
        ux, uy = rows[r, 3], rows[r, 4]
        speed = np.sqrt(ux * ux + uy * uy)
        keep = max(0.0, 1.0 - decel[k] * h / max(speed, 1e-12))
        rows[r, 3] = ux * keep
        rows[r, 4] = uy * keep
        spin = rows[r, 5]
        rows[r, 5] = np.copysign(max(0.0, abs(spin) - spin_decel[k] * h), spin)


@njit(cache=True)
def take_parked(truth: NDArray[np.int64], row_kind: NDArray[np.int64], kinds: NDArray[np.int64]) -> NDArray:
    """Rows of parked bodies for new particles of ``kinds`` (in order), or ``-1`` where none is left.

    The ``j``-th new particle of a kind takes the ``j``-th parked row of that kind (rows ascending),
    found in one pass over the rows: linear in rows + particles.
    """
    out = np.full(len(kinds), -1, dtype=np.int64)
    if len(kinds) == 0:
        return out
    n_kinds = kinds.max() + 1
    need = np.zeros(n_kinds, np.int64)
    for i in range(len(kinds)):
        need[kinds[i]] += 1
    first = np.zeros(n_kinds + 1, np.int64)  # kind k's rows: slots[first[k]:first[k] + found[k]]
    for k in range(n_kinds):
        first[k + 1] = first[k] + need[k]
    slots = np.empty(first[n_kinds], np.int64)
    found = np.zeros(n_kinds, np.int64)
    missing = len(kinds)
    for r in range(len(truth)):
        if missing == 0:
            break
        k = row_kind[r]
        if truth[r] == PARKED and k < n_kinds and found[k] < need[k]:
            slots[first[k] + found[k]] = r
            found[k] += 1
            missing -= 1
    used = np.zeros(n_kinds, np.int64)
    for i in range(len(kinds)):
        k = kinds[i]
        if used[k] < found[k]:
            out[i] = slots[first[k] + used[k]]
        used[k] += 1
    return out


@njit(cache=True)
def window_rows(
    rows: NDArray[np.float64], truth: NDArray[np.int64], x_low: float, x_high: float
) -> NDArray[np.int64]:
    """Rows of the particles with belt-frame ``x_low <= x <= x_high``, ordered by truth id.

    Ids in view are nearly consecutive (they count landings), so they are placed by id into a
    table spanning ``min..max`` (linear time); a sort is the fallback for a sparse span.
    """
    n = 0
    lowest, highest = np.iinfo(np.int64).max, -1
    picked = np.empty(len(truth), dtype=np.int64)
    for r in range(len(truth)):
        t = truth[r]
        if t >= 0 and x_low <= rows[r, 0] <= x_high:
            picked[n] = r
            n += 1
            lowest = min(lowest, t)
            highest = max(highest, t)
    picked = picked[:n]
    if n == 0:
        return picked
    span = highest - lowest + 1
    if span > 4 * n + 64:
        return picked[np.argsort(truth[picked], kind="mergesort")]
    slot = np.full(span, -1, dtype=np.int64)
    for i in range(n):
        slot[truth[picked[i]] - lowest] = picked[i]
    k = 0
    for j in range(span):
        if slot[j] >= 0:
            picked[k] = slot[j]
            k += 1
    return picked


@njit(cache=True)
def window_state(
    rows: NDArray[np.float64],
    truth: NDArray[np.int64],
    kind: NDArray[np.int64],
    x_low: float,
    x_high: float,
    travel: float,
    belt_speed: float,
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray]:
    """Ground-frame ids, positions (n, 2), velocities (n, 2), angles and kinds of the particles with
    ground-frame ``x_low <= x <= x_high``, ordered by truth id (``x = x_belt + travel``,
    ``v_x = v_x,belt + belt_speed``)."""
    picked = window_rows(rows, truth, x_low - travel, x_high - travel)
    n = len(picked)
    ids = np.empty(n, np.int64)
    position = np.empty((n, 2))
    velocity = np.empty((n, 2))
    angle = np.empty(n)
    kinds = np.empty(n, np.int64)
    for i in range(n):
        r = picked[i]
        ids[i] = truth[r]
        position[i, 0] = rows[r, 0] + travel
        position[i, 1] = rows[r, 1]
        angle[i] = rows[r, 2]
        velocity[i, 0] = rows[r, 3] + belt_speed
        velocity[i, 1] = rows[r, 4]
        kinds[i] = kind[r]
    return ids, position, velocity, angle, kinds


@njit(cache=True)
def land(
    rows: NDArray[np.float64],
    truth: NDArray[np.int64],
    row_kind: NDArray[np.int64],
    kinds: NDArray[np.int64],
    uniform: NDArray[np.float64],
    normal: NDArray[np.float64],
    landing: NDArray[np.float64],
    half_size: NDArray[np.float64],
    geometry: NDArray[np.float64],
    first_id: int,
) -> bool:
    """Land particle ``i`` (kind ``kinds[i]``, truth id ``first_id + i``) on a parked body of its
    kind; return ``False`` and change nothing if too few bodies of some kind are parked.

    Ground frame: ``x = drop_x − drop_spread u₀``, ``y`` uniform between the walls less the
    half-size, ``v_x ~ N(chute_speed, chute_speed_std²)``, ``v_y ~ N(0, lateral_speed_std²)``,
    angle ``~ N(0, angle_std²)`` (``landing[k]`` holds those four figures); stored belt-frame.
    ``geometry`` is ``(drop_x, drop_spread, window_width, travel, belt_speed)``.
    """
    targets = take_parked(truth, row_kind, kinds)
    for i in range(len(targets)):
        if targets[i] < 0:
            return False
    drop_x, drop_spread, width, travel, belt_speed = (
        geometry[0],
        geometry[1],
        geometry[2],
        geometry[3],
        geometry[4],
    )
    for i in range(len(targets)):
        r, k = targets[i], kinds[i]
        half = half_size[k]
        rows[r, 0] = drop_x - drop_spread * uniform[i, 0] - travel
        rows[r, 1] = half + (width - 2 * half) * uniform[i, 1]
        rows[r, 2] = landing[k, 3] * normal[i, 2]
        rows[r, 3] = landing[k, 0] + landing[k, 1] * normal[i, 0] - belt_speed
        rows[r, 4] = landing[k, 2] * normal[i, 1]
        rows[r, 5] = 0.0
        truth[r] = first_id + i
    return True


@njit(cache=True)
def padded_state(
    ids: NDArray[np.int64],
    position: NDArray[np.float64],
    velocity: NDArray[np.float64],
    angle: NDArray[np.float64],
    kind: NDArray[np.int64],
    m: int,
    rows: int,
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.bool_], NDArray, NDArray, NDArray]:
    """The first ``m`` particles padded to ``rows``: ids (-1 on padding), positions, visible,
    velocities, angles, kinds (0 on padding)."""
    out_ids = np.full(rows, -1, np.int64)
    out_position = np.zeros((rows, 2))
    out_visible = np.zeros(rows, np.bool_)
    out_velocity = np.zeros((rows, 2))
    out_angle = np.zeros(rows)
    out_kind = np.zeros(rows, np.int64)
    for i in range(m):
        out_ids[i] = ids[i]
        out_position[i, 0] = position[i, 0]
        out_position[i, 1] = position[i, 1]
        out_visible[i] = True
        out_velocity[i, 0] = velocity[i, 0]
        out_velocity[i, 1] = velocity[i, 1]
        out_angle[i] = angle[i]
        out_kind[i] = kind[i]
    return out_ids, out_position, out_visible, out_velocity, out_angle, out_kind


@njit(cache=True)
def line_crossings(
    before: NDArray[np.float64],
    after: NDArray[np.float64],
    truth: NDArray[np.int64],
    line_before: float,
    line_after: float,
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """The particles whose ground-frame ``x`` reached the line ``x = L`` during one physics step.

    ``before`` and ``after`` are the row tables at the start and the end of the step (belt
    frame); the line sits at belt-frame ``line_before = L − s₀`` at the start and
    ``line_after = L − s₁`` at the end (``s`` the belt's travel). Within a step pymunk moves a
    body on a straight line at its end-of-step velocity (semi-implicit Euler) and the belt
    travels uniformly, so the ground-frame position is linear in time and the crossing is exact:

    .. math::

        f = \\frac{L − x_0}{x_1 − x_0}, \\qquad y_c = y_0 + f\\,(y_1 − y_0)

    with ground-frame ``x₀ < L <= x₁`` and ``f ∈ (0, 1]`` the fraction of the step at which the
    particle crosses. Rows parked or landed during the step (label changed) are skipped by
    requiring the same truth id before and after, which the caller guarantees by passing the
    labels of the step.

    Returns:
        ids (k,) int64, fractions (k,), lateral positions ``y_c`` (k,), in row order.
    """
    n = 0
    for r in range(len(truth)):
        if truth[r] >= 0 and before[r, 0] < line_before and after[r, 0] >= line_after:
            n += 1
    ids = np.empty(n, np.int64)
    fraction = np.empty(n)
    lateral = np.empty(n)
    k = 0
    for r in range(len(truth)):
        if truth[r] >= 0 and before[r, 0] < line_before and after[r, 0] >= line_after:
            x0 = before[r, 0] - line_before  # ground-frame x₀ − L < 0
            x1 = after[r, 0] - line_after  # ground-frame x₁ − L >= 0
            f = -x0 / (x1 - x0)
            ids[k] = truth[r]
            fraction[k] = f
            lateral[k] = before[r, 1] + f * (after[r, 1] - before[r, 1])
            k += 1
    return ids, fraction, lateral
