"""A uniform-grid spatial index: the candidate pairs of a gate without testing every pair.

Tracking pairs ``n`` queries (tracks' predicted measurements, ground-truth positions) with ``m``
points (detections, estimates) that lie near them. Testing all ``n m`` pairs costs the square of
the scene; but a query only ever interacts with the points inside its gate, and every gate used
here is bounded by an axis-aligned box: the χ² ellipse ``(z − ŷ)ᵀ S⁻¹ (z − ŷ) ≤ γ`` lies inside

.. math::

    |z_k - ŷ_k| \\le h_k = \\sqrt{γ \\, S_{kk}} \\qquad (k = 1 \\dots D),

a Euclidean ball of radius ``r`` inside ``|z_k − c_k| ≤ r``. So the index answers one question,
*which points lie in each query's box* ([`box_candidates`][track_envs.infra.spatial.box_candidates]), and the
caller runs its exact test on those candidates only.

The points are bucketed in a uniform grid over their first ``K = min(D, 2)`` coordinates (a
counting sort by cell, so each cell lists its points in ascending index). The cell's edge is the
median box width of the queries (a typical gate holds a few cells), enlarged until the grid has at
most ``4 m + 16`` cells; a query scans the cells its box overlaps and keeps the points inside
the box on every coordinate. A build is ``O(m)``, a query ``O(cells overlapped + points in them)``:
a frame costs ``O(n + m)`` for gates of bounded size, whatever the size of the scene.

The answer does not depend on the grid: it is exactly the set of points inside each box, listed
row by row in ascending point index (compressed sparse rows, ``ptr`` / ``cols``), as a dense scan
of ``|p_k − c_k| ≤ h_k`` would list them. Points with a non-finite coordinate are left out of the
index (they are in no box); a query with a non-finite centre has no candidates; a query whose box
half-width is not finite (or negative) is refused: the kernels return its row as ``bad`` and
[`candidate_pairs`][track_envs.infra.spatial.candidate_pairs] raises an error naming it and the value.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.compiled import njit

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

__all__ = ["Candidates", "GridIndex", "box_candidates", "build_grid", "candidate_pairs", "query_grid"]

#: The grid holds at most ``MAX_CELLS_PER_POINT · m + 16`` cells.
MAX_CELLS_PER_POINT = 4


class GridIndex(NamedTuple):
    """Points bucketed in a uniform grid over their first ``K`` coordinates
    ([`build_grid`][track_envs.infra.spatial.build_grid]).

    Attributes:
        origin: (K,) the lower corner of the grid.
        cell: The cells' edge (> 0).
        shape: (K,) cells along each axis.
        start: (cells + 1,) cell ``c`` holds ``order[start[c]:start[c + 1]]`` (row-major cells).
        order: The indices of the finite points, by cell, ascending within a cell.
    """

    origin: FloatArray
    cell: float
    shape: IntArray
    start: IntArray
    order: IntArray


class Candidates(NamedTuple):
    """The points inside each query's box, as compressed sparse rows.

    Attributes:
        ptr: (n + 1,) row ``i``'s points are ``cols[ptr[i]:ptr[i + 1]]``.
        cols: The point indices, ascending within each row.
        bad: −1, or the first query whose box half-width is not a finite number >= 0 (the other
            fields are then not meaningful).
    """

    ptr: IntArray
    cols: IntArray
    bad: int


@njit(cache=True)
def _finite_rows(points: FloatArray, K: int) -> NDArray[np.bool_]:
    """Which points have finite first ``K`` coordinates (NaN / inf rows are left out of the index)."""
    m = points.shape[0]
    ok = np.ones(m, np.bool_)
    for j in range(m):
        for k in range(K):
            if not np.isfinite(points[j, k]):
                ok[j] = False
    return ok


@njit(cache=True)
def build_grid(points: FloatArray, K: int, cell: float) -> GridIndex:
    """Bucket the finite points (m, D) in a grid of edge ``cell`` (> 0) over their first ``K``
    coordinates, enlarged (doubled) until it has at most ``4 m + 16`` cells."""
    m = points.shape[0]
    ok = _finite_rows(points, K)
    lo = np.full(K, np.inf)
    hi = np.full(K, -np.inf)
    n_ok = 0
    for j in range(m):
        if ok[j]:
            n_ok += 1
            for k in range(K):
                lo[k] = min(lo[k], points[j, k])
                hi[k] = max(hi[k], points[j, k])
    if n_ok == 0:
        lo[:] = 0.0
        hi[:] = 0.0
    if not (cell > 0.0 and np.isfinite(cell)):
        cell = 1.0
    limit = MAX_CELLS_PER_POINT * n_ok + 16
    shape = np.ones(K, np.int64)
    while True:
        total = 1.0
        for k in range(K):
            total *= np.floor((hi[k] - lo[k]) / cell) + 1.0
        if total <= limit:
            break
        cell *= 2.0
    n_cells = 1
    for k in range(K):
        shape[k] = int(np.floor((hi[k] - lo[k]) / cell)) + 1
        n_cells *= shape[k]
    cell_of = np.full(m, -1, np.int64)
    count = np.zeros(n_cells + 1, np.int64)
    for j in range(m):
        if not ok[j]:
            continue
        c = 0
        for k in range(K):
            ik = min(int((points[j, k] - lo[k]) / cell), shape[k] - 1)
            c = c * shape[k] + ik
        cell_of[j] = c
        count[c + 1] += 1
    start = np.cumsum(count)
    fill = start[:-1].copy()
    order = np.empty(n_ok, np.int64)
    for j in range(m):  # ascending j: each cell lists its points in ascending index
        c = cell_of[j]
        if c >= 0:
            order[fill[c]] = j
            fill[c] += 1
    return GridIndex(lo, cell, shape, start, order)


@njit(cache=True)
def _cell_range(x: float, origin: float, cell: float, size: int) -> int:
    """The cell along one axis of coordinate ``x``, clipped to ``[0, size − 1]`` (in floating point
    first, so that a huge box never overflows an integer)."""
    f = (x - origin) / cell
    f = min(max(f, 0.0), size - 1.0)
    return int(f)


@njit(cache=True)
def query_grid(grid: GridIndex, points: FloatArray, centres: FloatArray, half: FloatArray) -> Candidates:
    """The indexed points inside each query's box ``|p_k − c_k| ≤ h_k`` (first ``K`` axes).

    Args:
        grid: [`build_grid`][track_envs.infra.spatial.build_grid] of ``points``.
        points: (m, D) the indexed points.
        centres: (n, ≥ K) the boxes' centres.
        half: (n, K) the boxes' half-widths.
    """
    n = centres.shape[0]
    K = grid.shape.shape[0]
    ptr = np.zeros(n + 1, np.int64)
    cap = 4 * (n + points.shape[0]) + 16
    cols = np.empty(cap, np.int64)
    nnz = 0
    lo_c = np.zeros(K, np.int64)
    hi_c = np.zeros(K, np.int64)
    at = np.zeros(K, np.int64)
    has_points = grid.order.shape[0] > 0
    for i in range(n):
        ptr[i] = nnz
        for k in range(K):
            h = half[i, k]
            if not (np.isfinite(h) and h >= 0.0):
                return Candidates(ptr, cols[:nnz], i)
        usable = has_points
        for k in range(K):
            if not np.isfinite(centres[i, k]):
                usable = False
        if not usable:
            continue
        for k in range(K):
            lo_c[k] = _cell_range(centres[i, k] - half[i, k], grid.origin[k], grid.cell, grid.shape[k])
            hi_c[k] = _cell_range(centres[i, k] + half[i, k], grid.origin[k], grid.cell, grid.shape[k])
            at[k] = lo_c[k]
        row_start = nnz
        while True:
            c = 0
            for k in range(K):
                c = c * grid.shape[k] + at[k]
            for q in range(grid.start[c], grid.start[c + 1]):
                j = grid.order[q]
                inside = True
                for k in range(K):
                    if abs(points[j, k] - centres[i, k]) > half[i, k]:
                        inside = False
                        break
                if inside:
                    if nnz == cols.shape[0]:
                        cols = np.concatenate((cols, np.empty(cols.shape[0], np.int64)))
                    cols[nnz] = j
                    nnz += 1
            # next cell of the box (odometer over the K axes, last axis fastest)
            k = K - 1
            while k >= 0:
                at[k] += 1
                if at[k] <= hi_c[k]:
                    break
                at[k] = lo_c[k]
                k -= 1
            if k < 0:
                break
        # cells were visited in row-major order: sort the row's points by index (rows are short)
        for a in range(row_start + 1, nnz):
            v = cols[a]
            b = a - 1
            while b >= row_start and cols[b] > v:
                cols[b + 1] = cols[b]
                b -= 1
            cols[b + 1] = v
    ptr[n] = nnz
    return Candidates(ptr, cols[:nnz], -1)


@njit(cache=True)
def _typical_width(half: FloatArray) -> float:
    """The median of the finite box widths ``2 h`` (0 when there is none)."""
    flat = half.ravel()
    finite = flat[np.isfinite(flat)]
    if finite.shape[0] == 0:
        return 0.0
    return 2.0 * float(np.median(finite))


@njit(cache=True)
def box_candidates(centres: FloatArray, half: FloatArray, points: FloatArray) -> Candidates:
    """The points (m, D) inside each query's box ``|p_k − c_k| ≤ h_k`` on the first
    ``K = min(D, 2)`` axes (module docstring): a grid with cells of the median box width.

    Args:
        centres: (n, D) the boxes' centres.
        half: (n, K) the boxes' half-widths (finite, >= 0; else the row is returned as ``bad``).
        points: (m, D) the points.
    """
    K = half.shape[1]
    grid = build_grid(points, K, _typical_width(half))
    return query_grid(grid, points, centres, half)


def candidate_pairs(
    centres: NDArray[np.floating],
    half: NDArray[np.floating] | float,
    points: NDArray[np.floating],
    *,
    what: str = "query",
) -> tuple[IntArray, IntArray]:
    """The points inside each query's box, as compressed sparse rows ``(ptr, cols)``.

    Args:
        centres: (n, D) the boxes' centres.
        half: The boxes' half-widths: a number (all boxes), (n,) (square boxes) or (n, K) with
            ``K = min(D, 2)``.
        points: (m, D) the points.
        what: The name of a query in the error message (``"track"``, ``"truth"``...).

    Returns:
        ``(ptr (n + 1,), cols)``: row ``i``'s points are ``cols[ptr[i]:ptr[i + 1]]``, ascending.

    Raises:
        ValueError: if the shapes disagree, or a half-width is not a finite number >= 0 (naming the
            row and the value).
    """
    c = np.ascontiguousarray(centres, dtype=np.float64)
    p = np.ascontiguousarray(points, dtype=np.float64)
    if c.ndim != 2 or p.ndim != 2 or (len(p) and len(c) and c.shape[1] != p.shape[1]):
        raise ValueError(f"centres (n, D) and points (m, D) must share D, got {c.shape} and {p.shape}")
    D = c.shape[1] if len(c) else (p.shape[1] if p.ndim == 2 else 1)
    K = max(1, min(D, 2))
    h = np.asarray(half, dtype=np.float64)
    if h.ndim == 0:
        h = np.full((len(c), K), float(h))
    elif h.ndim == 1:
        h = np.repeat(h[:, None], K, axis=1)
    h = np.ascontiguousarray(h)
    if h.shape != (len(c), K):
        raise ValueError(f"half must be a number, (n,) or (n, {K}) for {len(c)} queries, got {h.shape}")
    if len(c) == 0:
        return np.zeros(1, np.int64), np.zeros(0, np.int64)
    if len(p) == 0:
        return np.zeros(len(c) + 1, np.int64), np.zeros(0, np.int64)
    found = box_candidates(c, h, p)
    if found.bad >= 0:
        raise ValueError(
            f"{what} {found.bad}: gate half-width {h[found.bad].tolist()} is not a finite number >= 0 "
            "(an infinite or NaN covariance?); a spatial index needs a bounded gate"
        )
    return found.ptr, found.cols
