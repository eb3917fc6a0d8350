"""Merged blobs: touching particles seen by a camera as one centroid.

A camera segments the belt image into connected foreground regions and reports one centroid per
region, so particles whose silhouettes touch give one detection, at the area-weighted centroid
of the region, until they separate. This module finds those groups and their centroids for one
frame, in compiled code (no per-particle Python).

**Silhouettes.** Every particle kind is a *rounded rectangle*: a core rectangle of half extents
``(a, b)`` (along the particle's axis, across it) grown by a disc of radius ``ρ`` (the Minkowski
sum). Spheres are a point core (``a = b = 0``) with ``ρ`` the radius; cylinders lying flat and
cuboids are their length × width box with the rounding radius of their pymunk collision shape
(:data:`~track_envs.envs.belt_physics.BOX_ROUNDING`), so that two particles in contact in the
physics are exactly touching silhouettes here. The area of a silhouette is

.. math::

    A = 4ab + 4ρ(a + b) + πρ^2 .

**Touching.** Silhouettes ``i`` and ``j`` touch when the distance between their core rectangles
is at most ``ρ_i + ρ_j + tol``; the core distance is exact (0 when the cores overlap, else the
least distance between their edges, computed as segment–segment distances). ``tol`` (default
0.1 mm, about a camera pixel) absorbs pymunk's contact slop and the gap a segmentation cannot
resolve. Only pairs whose centres are closer than the sum of the circumradii plus ``tol`` are
tested (a sweep over the particles sorted along the belt).

**Groups** are the connected components of the touching relation (three in a row make one
blob), found by union–find. A blob's centroid is

.. math::

    \\bar x = \\frac{\\sum_{i \\in G} A_i x_i}{\\sum_{i \\in G} A_i}

(the centroid of the union of the silhouettes, neglecting their overlap, which the physics keeps
below its contact slop). Its *primary* particle is the member with the largest area (ties: the
first in input order, i.e. the lowest truth id); its members are listed largest area first.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

#: Truth ids listed per merged detection in ``info["detection_ids_merged"]``.
MAX_MERGED = 8
#: Default touching tolerance in metres.
MERGE_TOLERANCE = 1e-4


def silhouette_table(shapes: list[tuple[str, float, float]], box_rounding: float) -> NDArray[np.float64]:
    """Per-kind silhouette parameters ``(a, b, ρ, A)`` (n_kinds, 4).

    Args:
        shapes: ``(shape, length, width)`` per kind, ``shape`` ``"circle"`` or ``"box"``.
        box_rounding: Rounding radius ``ρ`` of box silhouettes (metres).
    """
    table = np.zeros((len(shapes), 4))
    for k, (shape, length, width) in enumerate(shapes):
        a, b, rho = (
            (0.0, 0.0, 0.5 * length) if shape == "circle" else (0.5 * length, 0.5 * width, box_rounding)
        )
        table[k] = a, b, rho, 4 * a * b + 4 * rho * (a + b) + math.pi * rho * rho
    return table


@njit(cache=True)
def _corners(x: float, y: float, angle: float, a: float, b: float, out: NDArray[np.float64]) -> None:
    c, s = math.cos(angle), math.sin(angle)
    for k, (u, v) in enumerate(((a, b), (-a, b), (-a, -b), (a, -b))):
        out[k, 0] = x + c * u - s * v
        out[k, 1] = y + s * u + c * v


@njit(cache=True)
def _point_segment(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0.0 else min(max(((px - ax) * dx + (py - ay) * dy) / length2, 0.0), 1.0)
    ex, ey = ax + t * dx - px, ay + t * dy - py
    return math.sqrt(ex * ex + ey * ey)


@njit(cache=True)
def _cross(ox: float, oy: float, ax: float, ay: float, bx: float, by: float) -> float:
    return (ax - ox) * (by - oy) - (ay - oy) * (bx - ox)


@njit(cache=True)
def _segment_segment(p: NDArray[np.float64], q: NDArray[np.float64], i: int, j: int) -> float:
    """Distance between edge ``i`` of corner ring ``p`` and edge ``j`` of ring ``q``."""
    ax, ay, bx, by = p[i, 0], p[i, 1], p[(i + 1) % 4, 0], p[(i + 1) % 4, 1]
    cx, cy, dx, dy = q[j, 0], q[j, 1], q[(j + 1) % 4, 0], q[(j + 1) % 4, 1]
    d1, d2 = _cross(ax, ay, bx, by, cx, cy), _cross(ax, ay, bx, by, dx, dy)
    d3, d4 = _cross(cx, cy, dx, dy, ax, ay), _cross(cx, cy, dx, dy, bx, by)
    if d1 * d2 < 0.0 and d3 * d4 < 0.0:  # proper crossing
        return 0.0
    return min(
        min(_point_segment(ax, ay, cx, cy, dx, dy), _point_segment(bx, by, cx, cy, dx, dy)),
        min(_point_segment(cx, cy, ax, ay, bx, by), _point_segment(dx, dy, ax, ay, bx, by)),
    )


@njit(cache=True)
def _inside(px: float, py: float, x: float, y: float, angle: float, a: float, b: float) -> bool:
    c, s = math.cos(angle), math.sin(angle)
    u = c * (px - x) + s * (py - y)
    v = -s * (px - x) + c * (py - y)
    return abs(u) <= a and abs(v) <= b


@njit(cache=True)
def core_distance(
    xi: float, yi: float, ti: float, ai: float, bi: float,
    xj: float, yj: float, tj: float, aj: float, bj: float,
) -> float:  # fmt: skip
    """Least distance between two rotated rectangles (centre, angle, half extents; 0 if they overlap)."""
    p = np.empty((4, 2))
    q = np.empty((4, 2))
    _corners(xi, yi, ti, ai, bi, p)
    _corners(xj, yj, tj, aj, bj, q)
    for k in range(4):
        if _inside(q[k, 0], q[k, 1], xi, yi, ti, ai, bi) or _inside(p[k, 0], p[k, 1], xj, yj, tj, aj, bj):
            return 0.0
    best = np.inf
    for i in range(4):
        for j in range(4):
            best = min(best, _segment_segment(p, q, i, j))
    return best


@njit(cache=True)
def _find(parent: NDArray[np.int64], i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(cache=True)
def touching_groups(
    positions: NDArray[np.float64],
    angles: NDArray[np.float64],
    kinds: NDArray[np.int64],
    table: NDArray[np.float64],
    tol: float,
) -> NDArray[np.int64]:
    """Group label of each particle (n,): the index of the first member of its touching group.

    Args:
        positions: (n, 2) centres.
        angles: (n,) orientations (rad).
        kinds: (n,) row of each particle in ``table``.
        table: (n_kinds, 4) silhouettes ``(a, b, ρ, A)`` (:func:`silhouette_table`).
        tol: Touching tolerance (see the module docstring).
    """
    n = len(positions)
    parent = np.arange(n)
    reach = np.empty(n)
    for i in range(n):
        k = kinds[i]
        reach[i] = math.sqrt(table[k, 0] ** 2 + table[k, 1] ** 2) + table[k, 2]
    longest = reach.max() if n else 0.0
    order = np.argsort(positions[:, 0])
    for oi in range(n):
        i = order[oi]
        for oj in range(oi + 1, n):
            j = order[oj]
            dx = positions[j, 0] - positions[i, 0]
            if dx > reach[i] + longest + tol:
                break
            dy = positions[j, 1] - positions[i, 1]
            if dx * dx + dy * dy > (reach[i] + reach[j] + tol) ** 2:
                continue
            ki, kj = kinds[i], kinds[j]
            gap = core_distance(
                positions[i, 0], positions[i, 1], angles[i], table[ki, 0], table[ki, 1],
                positions[j, 0], positions[j, 1], angles[j], table[kj, 0], table[kj, 1],
            )  # fmt: skip
            if gap <= table[ki, 2] + table[kj, 2] + tol:
                ri, rj = _find(parent, i), _find(parent, j)
                if ri != rj:
                    parent[max(ri, rj)] = min(ri, rj)
    for i in range(n):
        parent[i] = _find(parent, i)
    return parent


@njit(cache=True)
def merge_blobs(
    positions: NDArray[np.float64],
    ids: NDArray[np.int64],
    angles: NDArray[np.float64],
    kinds: NDArray[np.int64],
    table: NDArray[np.float64],
    tol: float,
    max_merged: int,
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64], int]:
    """The blobs of one frame.

    Args:
        positions, angles, kinds, table, tol: As in :func:`touching_groups`.
        ids: (n,) truth ids.
        max_merged: Member ids kept per blob (``K``).

    Returns:
        ``(centres, primary, merged, truncated)``: area-weighted centroid (b, 2) and primary
        truth id (b,) of every blob (singletons included, in order of their first member);
        ``merged`` (g, K) the member ids, largest area first, −1 padded, of the ``g`` blobs with
        two or more members, whose primary ids are ``merged[:, 0]``; ``truncated`` the member ids
        left out of ``merged`` because a blob had more than ``K``.
    """
    n = len(positions)
    label = touching_groups(positions, angles, kinds, table, tol)
    size = np.zeros(n, np.int64)
    for i in range(n):
        size[label[i]] += 1
    slot = np.full(n, -1, np.int64)
    n_blobs = 0
    n_merged = 0
    for i in range(n):
        if label[i] == i:
            slot[i] = n_blobs
            n_blobs += 1
            if size[i] > 1:
                n_merged += 1
    centres = np.zeros((n_blobs, 2))
    weight = np.zeros(n_blobs)
    primary = np.full(n_blobs, -1, np.int64)
    best = np.full(n_blobs, -1.0)
    for i in range(n):
        b = slot[label[i]]
        area = table[kinds[i], 3]
        if size[label[i]] == 1:  # a lone particle's centroid is its centre, bit for bit
            centres[b, 0] = positions[i, 0]
            centres[b, 1] = positions[i, 1]
            weight[b] = 1.0
        else:
            centres[b, 0] += area * positions[i, 0]
            centres[b, 1] += area * positions[i, 1]
            weight[b] += area
        if area > best[b]:
            best[b] = area
            primary[b] = ids[i]
    for b in range(n_blobs):
        centres[b, 0] /= weight[b]
        centres[b, 1] /= weight[b]
    merged = np.full((n_merged, max_merged), -1, np.int64)
    merged_area = np.zeros((n_merged, max_merged))
    row = np.full(n, -1, np.int64)
    g = 0
    for i in range(n):
        if label[i] == i and size[i] > 1:
            row[i] = g
            g += 1
    truncated = 0
    for i in range(n):
        r = row[label[i]]
        if r < 0:
            continue
        area = table[kinds[i], 3]
        # insertion into the row, largest area first, stable for equal areas
        at = 0
        while at < max_merged and merged[r, at] >= 0 and merged_area[r, at] >= area:
            at += 1
        if at == max_merged:
            truncated += 1
            continue
        if merged[r, max_merged - 1] >= 0:
            truncated += 1
        for k in range(max_merged - 1, at, -1):
            merged[r, k] = merged[r, k - 1]
            merged_area[r, k] = merged_area[r, k - 1]
        merged[r, at] = ids[i]
        merged_area[r, at] = area
    return centres, primary, merged, truncated


@njit(cache=True)
def merged_rows(
    detection_ids: NDArray[np.int64], merged: NDArray[np.int64], max_merged: int
) -> NDArray[np.int64]:
    """``info["detection_ids_merged"]`` (max_detections, K): each detection row's truth ids.

    Column 0 is ``detection_ids``; a row whose id is the primary of a merged blob (``merged[g, 0]``)
    lists the blob's members; every other entry is −1.
    """
    m = len(detection_ids)
    out = np.full((m, max_merged), -1, np.int64)
    for r in range(m):
        out[r, 0] = detection_ids[r]
    for g in range(len(merged)):
        for r in range(m):
            if detection_ids[r] == merged[g, 0]:
                for k in range(max_merged):
                    out[r, k] = merged[g, k]
                break
    return out
