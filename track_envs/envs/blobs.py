"""Merged blobs: touching particles seen by a camera as one centroid.

A camera segments the belt image into connected foreground regions and reports one centroid per
region, so particles whose silhouettes touch give one detection, at the area-weighted centroid
of the region, until they separate. This module finds those groups and their centroids for one
frame, in compiled code (no per-particle Python).

**Silhouettes.** Every particle kind is a *rounded rectangle*: a core rectangle of half extents
``(a, b)`` (along the particle's axis, across it) grown by a disc of radius ``ρ`` (the Minkowski
sum). Spheres are a point core (``a = b = 0``) with ``ρ`` the radius; cylinders lying flat and
cuboids are their length × width box with the rounding radius of their pymunk collision shape
([`BOX_ROUNDING`][track_envs.envs.belt_physics.BOX_ROUNDING]), so that two particles in contact in the
physics are exactly touching silhouettes here. The area of a silhouette is

.. math::

    A = 4ab + 4ρ(a + b) + πρ^2 .

**Touching.** Silhouettes ``i`` and ``j`` touch when the distance between their core rectangles
is at most ``ρ_i + ρ_j + tol``; the core distance is exact (0 when the cores overlap, by the
separating axis theorem, else the least distance of a corner of one core to the other). ``tol`` (default
0.1 mm, about a camera pixel) absorbs pymunk's contact slop and the gap a segmentation cannot
resolve. Only pairs whose centres are closer than the sum of the circumradii plus ``tol`` are
tested: particles are bucketed in a grid over ``(x, y)`` with cells as wide as the largest such
sum ([`build_grid`][track_envs.infra.spatial.build_grid]), and each is compared with the rest of its cell
and the neighbouring cells ahead of it, so a frame costs ``O(n)`` at a bounded density whatever
the belt's width and length.

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
from numpy.typing import NDArray

from track_envs.infra.compiled import njit
from track_envs.infra.spatial import build_grid

#: Truth ids listed per merged detection in ``info["detection_ids_merged"]``.
MAX_MERGED = 8
#: Default touching tolerance in metres.
MERGE_TOLERANCE = 1e-4
#: The largest touching tolerance (m): a particle's length; a larger one joins particles far apart.
MAX_MERGE_TOLERANCE = 0.01


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
def _point_rect_sq(px: float, py: float, x: float, y: float, c: float, s: float, a: float, b: float) -> float:
    """Squared distance from a point to the rectangle (centre, cos/sin of its angle, half extents)."""
    u = c * (px - x) + s * (py - y)
    v = -s * (px - x) + c * (py - y)
    du = max(abs(u) - a, 0.0)
    dv = max(abs(v) - b, 0.0)
    return du * du + dv * dv


@njit(cache=True)
def _separated(
    dx: float, dy: float, nx: float, ny: float,
    ci: float, si: float, ai: float, bi: float,
    cj: float, sj: float, aj: float, bj: float,
) -> bool:  # fmt: skip
    """Whether the unit axis ``n`` separates the two rectangles (centre offset ``(dx, dy)``)."""
    hi = ai * abs(nx * ci + ny * si) + bi * abs(-nx * si + ny * ci)
    hj = aj * abs(nx * cj + ny * sj) + bj * abs(-nx * sj + ny * cj)
    return abs(nx * dx + ny * dy) > hi + hj


@njit(cache=True)
def _core_distance(
    xi: float, yi: float, ci: float, si: float, ai: float, bi: float,
    xj: float, yj: float, cj: float, sj: float, aj: float, bj: float,
) -> float:  # fmt: skip
    """[`core_distance`][track_envs.envs.blobs.core_distance] with each angle given by its cosine and sine.

    Two rectangles overlap unless one of their four edge normals separates them (separating axis
    theorem); two disjoint convex polygons have a closest pair with a vertex of one of them, so
    their distance is the least distance of a corner of one to the other rectangle.
    """
    dx, dy = xj - xi, yj - yi
    if not (
        _separated(dx, dy, ci, si, ci, si, ai, bi, cj, sj, aj, bj)
        or _separated(dx, dy, -si, ci, ci, si, ai, bi, cj, sj, aj, bj)
        or _separated(dx, dy, cj, sj, ci, si, ai, bi, cj, sj, aj, bj)
        or _separated(dx, dy, -sj, cj, ci, si, ai, bi, cj, sj, aj, bj)
    ):
        return 0.0
    best = np.inf
    for su in (-1.0, 1.0):
        for sv in (-1.0, 1.0):
            px = xj + su * aj * cj - sv * bj * sj
            py = yj + su * aj * sj + sv * bj * cj
            best = min(best, _point_rect_sq(px, py, xi, yi, ci, si, ai, bi))
            px = xi + su * ai * ci - sv * bi * si
            py = yi + su * ai * si + sv * bi * ci
            best = min(best, _point_rect_sq(px, py, xj, yj, cj, sj, aj, bj))
    return math.sqrt(best)


@njit(cache=True)
def core_distance(
    xi: float, yi: float, ti: float, ai: float, bi: float,
    xj: float, yj: float, tj: float, aj: float, bj: float,
) -> float:  # fmt: skip
    """Least distance between two rotated rectangles (centre, angle, half extents; 0 if they overlap)."""
    return _core_distance(
        xi, yi, math.cos(ti), math.sin(ti), ai, bi, xj, yj, math.cos(tj), math.sin(tj), aj, bj
    )  # fmt: skip


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
        table: (n_kinds, 4) silhouettes ``(a, b, ρ, A)``
            ([`silhouette_table`][track_envs.envs.blobs.silhouette_table]).
        tol: Touching tolerance (see the module docstring).
    """
    n = len(positions)
    parent = np.arange(n)
    reach = np.empty(n)  # circumradius of each silhouette
    inner = np.empty(n)  # inradius
    cos = np.empty(n)
    sin = np.empty(n)
    turned = np.zeros(n, np.bool_)  # cos, sin computed (only particles in a close pair need them)
    for i in range(n):
        k = kinds[i]
        reach[i] = math.sqrt(table[k, 0] ** 2 + table[k, 1] ** 2) + table[k, 2]
        inner[i] = min(table[k, 0], table[k, 1]) + table[k, 2]
    if n < 2:
        return parent
    # a grid over (x, y) with cells at least as wide as the largest reach of a pair: a touching
    # pair lies in one cell or in two neighbouring ones; each cell is compared with itself and
    # with the four neighbours ahead of it, so every pair once. The test is symmetric in i and j
    # bit for bit and a group's root is always its lowest index (parent[max] = min), so the
    # labels do not depend on the order in which the pairs are visited
    width = 2.0 * reach.max() + tol
    grid = build_grid(positions, 2, width * (1.0 + 1e-9) + 1e-12)
    n_x, n_y = grid.shape[0], grid.shape[1]
    start, members = grid.start, grid.order
    step_x = np.array([0, 0, 1, 1, 1])  # the cell itself, then the four neighbours ahead
    step_y = np.array([0, 1, -1, 0, 1])
    for cx in range(n_x):
        for cy in range(n_y):
            c = cx * n_y + cy
            for a in range(start[c], start[c + 1]):
                i = members[a]
                for s in range(5):
                    nx, ny = cx + step_x[s], cy + step_y[s]
                    if nx >= n_x or ny < 0 or ny >= n_y:
                        continue
                    d = nx * n_y + ny
                    # the rest of its own cell, the whole of a neighbour
                    for b in range(a + 1 if s == 0 else start[d], start[d + 1]):
                        j = members[b]
                        dx = positions[j, 0] - positions[i, 0]
                        dy = positions[j, 1] - positions[i, 1]
                        d2 = dx * dx + dy * dy
                        if d2 > (reach[i] + reach[j] + tol) ** 2:
                            continue
                        ki, kj = kinds[i], kinds[j]
                        touch = d2 <= (inner[i] + inner[j] + tol) ** 2  # the inscribed discs touch
                        if not touch:
                            for q in (i, j):
                                if not turned[q]:
                                    cos[q] = math.cos(angles[q])
                                    sin[q] = math.sin(angles[q])
                                    turned[q] = True
                            gap = _core_distance(
                                positions[i, 0], positions[i, 1], cos[i], sin[i], table[ki, 0], table[ki, 1],
                                positions[j, 0], positions[j, 1], cos[j], sin[j], table[kj, 0], table[kj, 1],
                            )  # fmt: skip
                            touch = gap <= table[ki, 2] + table[kj, 2] + tol
                        if touch:
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
        positions, angles, kinds, table, tol: As in
            [`touching_groups`][track_envs.envs.blobs.touching_groups].
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
    lists the blob's members; every other entry is −1. Linear time: the primaries are found through
    a table over their id span (a binary search when the span is sparse).
    """
    m = len(detection_ids)
    out = np.full((m, max_merged), -1, np.int64)
    for r in range(m):
        out[r, 0] = detection_ids[r]
    g = len(merged)
    if g == 0:
        return out
    lowest, highest = merged[0, 0], merged[0, 0]
    for q in range(g):
        lowest = min(lowest, merged[q, 0])
        highest = max(highest, merged[q, 0])
    span = highest - lowest + 1
    if span <= 4 * (m + g) + 64:
        # primary ids are truth ids of particles in view, nearly consecutive: a table by id
        group = np.full(span, -1, np.int64)
        for q in range(g):
            group[merged[q, 0] - lowest] = q
        for r in range(m):
            d = detection_ids[r]
            if d >= 0 and lowest <= d <= highest:
                q = group[d - lowest]
                if q >= 0:
                    for k in range(1, max_merged):
                        out[r, k] = merged[q, k]
        return out
    order = np.argsort(merged[:, 0])
    primaries = merged[order, 0]
    for r in range(m):
        d = detection_ids[r]
        if d < 0:
            continue
        at = np.searchsorted(primaries, d)
        if at < len(primaries) and primaries[at] == d:
            q = order[at]
            for k in range(1, max_merged):
                out[r, k] = merged[q, k]
    return out
