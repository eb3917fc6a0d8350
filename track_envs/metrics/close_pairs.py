"""The pairs of two point sets within a distance, as a sparse row-major (CSR) list, for numba kernels.

Tracking metrics only ever look at truth–track pairs closer than a threshold (CLEAR MOT's match
threshold, GOSPA's cut-off), and only a handful of pairs per truth qualify. Instead of the full
(m, n) distance matrix, the candidates are the points of the second set inside the box
``|y_k − x_k| ≤ r`` around each point of the first (the uniform grid of
[`track_envs.infra.spatial.box_candidates`][track_envs.infra.spatial.box_candidates] over the first two
coordinates, the box widened by a relative ``10⁻⁹`` so that rounding never drops a pair the exact test keeps),
and distances are computed for those only: ``O(m + n + candidates)`` per frame whatever the extent of the
scene. (A radius that is not finite falls back to buckets along the first coordinate.)

Distances are computed exactly as ``scipy.spatial.distance.cdist(x, y)`` computes them,
``d = sqrt(Σ_k (x_k − y_k)²)`` summed in coordinate order, so a pair exactly at the radius is
decided as on the dense matrix. Pairs with a NaN distance (non-finite coordinates) never qualify.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.compiled import njit
from track_envs.infra.spatial import box_candidates

# cells are widened by this relative margin so that rounding in d or in the cell index can never
# drop a pair that the exact test d <= radius keeps (|x₀ − y₀| <= d up to a few ulps)
_CELL_MARGIN = 1e-9


@njit(cache=True)
def _cells(
    y: NDArray[np.float64], radius: float
) -> tuple[float, float, NDArray[np.int64], NDArray[np.int64]]:
    """Bucket ``y`` by its first coordinate: ``(origin, width, start, members)``.

    Cell ``k`` covers ``[origin + k·width, origin + (k+1)·width)`` and holds the rows
    ``members[start[k]:start[k + 1]]`` (ascending); rows with a non-finite first coordinate are
    left out (they have no finite distance).
    """
    n = y.shape[0]
    lo, hi = np.inf, -np.inf
    for j in range(n):
        v = y[j, 0]
        if np.isfinite(v):
            lo = min(lo, v)
            hi = max(hi, v)
    if lo > hi:  # no finite point
        return 0.0, 1.0, np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64)
    width = max(radius * (1.0 + _CELL_MARGIN), (hi - lo) / (4 * n))
    n_cells = 1 if not np.isfinite(width) else int((hi - lo) / width) + 1
    cell = np.full(n, -1, dtype=np.int64)
    start = np.zeros(n_cells + 1, dtype=np.int64)
    for j in range(n):
        v = y[j, 0]
        if np.isfinite(v):
            k = 0 if n_cells == 1 else min(int((v - lo) / width), n_cells - 1)
            cell[j] = k
            start[k + 1] += 1
    for k in range(n_cells):
        start[k + 1] += start[k]
    fill = start[:-1].copy()
    members = np.empty(start[n_cells], dtype=np.int64)
    for j in range(n):
        k = cell[j]
        if k >= 0:
            members[fill[k]] = j
            fill[k] += 1
    return lo, width, start, members


@njit(cache=True)
def _neighbour_cells(v: float, origin: float, width: float, n_cells: int) -> tuple[int, int]:
    """First and last cell (inclusive) within one cell of coordinate ``v``; empty if last < first."""
    if not np.isfinite(v):
        return 0, -1
    if n_cells == 1 or not np.isfinite(width):
        return 0, 0
    q = (v - origin) / width
    if q < -1.0 or q >= n_cells + 1.0:
        return 0, -1
    k = int(np.floor(q))
    return max(k - 1, 0), min(k + 1, n_cells - 1)


@njit(cache=True)
def close_pairs(
    x: NDArray[np.float64], y: NDArray[np.float64], radius: float
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """Every pair ``(i, j)`` with ``d(x_i, y_j) <= radius``, row-major.

    Args:
        x: Points (m, D), float64.
        y: Points (n, D), same D.
        radius: Largest distance kept, > 0.

    Returns:
        ``(ptr, cols, dist)``: row ``i``'s pairs are ``cols[ptr[i]:ptr[i + 1]]`` (ascending) with
            distances ``dist[ptr[i]:ptr[i + 1]]``.
    """
    m, n = x.shape[0], y.shape[0]
    ptr = np.zeros(m + 1, dtype=np.int64)
    if m == 0 or n == 0:
        return ptr, np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.float64)
    half = radius * (1.0 + _CELL_MARGIN)
    if not (np.isfinite(half) and half >= 0.0):
        return _close_pairs_strips(x, y, radius)
    found = box_candidates(x, np.full((m, min(x.shape[1], 2)), half), y)
    cols = np.empty(len(found.cols), dtype=np.int64)
    dist = np.empty(len(found.cols), dtype=np.float64)
    n_dims = x.shape[1]
    nnz = 0
    for i in range(m):
        # branch-free scan: every candidate is written, and kept by advancing nnz when close
        for t in range(found.ptr[i], found.ptr[i + 1]):
            j = found.cols[t]
            sq = 0.0  # Σ_k (x_k − y_k)², in coordinate order as cdist sums it
            for k in range(n_dims):
                step = x[i, k] - y[j, k]
                sq += step * step
            d = np.sqrt(sq)
            cols[nnz] = j
            dist[nnz] = d
            nnz += d <= radius
        ptr[i + 1] = nnz
    return ptr, cols[:nnz], dist[:nnz]


@njit(cache=True)
def _close_pairs_strips(
    x: NDArray[np.float64], y: NDArray[np.float64], radius: float
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """[`close_pairs`][track_envs.metrics.close_pairs.close_pairs] by buckets along the first coordinate (any
    radius, also not finite).

    Args:
        x: Points (m, D), float64.
        y: Points (n, D), same D.
        radius: Largest distance kept, > 0 and finite.

    Returns:
        ``(ptr, cols, dist)``: row ``i``'s pairs are ``cols[ptr[i]:ptr[i + 1]]`` (ascending) with
            distances ``dist[ptr[i]:ptr[i + 1]]``.
    """
    m, n = x.shape[0], y.shape[0]
    ptr = np.zeros(m + 1, dtype=np.int64)
    if m == 0 or n == 0:
        return ptr, np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.float64)
    origin, width, start, members = _cells(y, radius)
    n_cells = len(start) - 1
    # candidates bound the number of pairs: one allocation, no growth
    bound = 0
    for i in range(m):
        first, last = _neighbour_cells(x[i, 0], origin, width, n_cells)
        if last >= first:
            bound += start[last + 1] - start[first]
    cols = np.empty(bound, dtype=np.int64)
    dist = np.empty(bound, dtype=np.float64)
    n_dims = x.shape[1]
    nnz = 0
    for i in range(m):
        first, last = _neighbour_cells(x[i, 0], origin, width, n_cells)
        row_start = nnz
        # branch-free scan: every candidate is written, and kept by advancing nnz when close
        for t in range(start[first], start[last + 1] if last >= first else start[first]):
            j = members[t]
            sq = 0.0  # Σ_k (x_k − y_k)², in coordinate order as cdist sums it
            for k in range(n_dims):
                step = x[i, k] - y[j, k]
                sq += step * step
            d = np.sqrt(sq)
            cols[nnz] = j
            dist[nnz] = d
            nnz += d <= radius
        # order the row's pairs by column (they come cell by cell; usually one or two)
        for a in range(row_start + 1, nnz):
            j, d = cols[a], dist[a]
            at = a
            while at > row_start and cols[at - 1] > j:
                cols[at] = cols[at - 1]
                dist[at] = dist[at - 1]
                at -= 1
            cols[at] = j
            dist[at] = d
        ptr[i + 1] = nnz
    return ptr, cols[:nnz], dist[:nnz]


@njit(cache=True)
def finite_entries(
    matrix: NDArray[np.float64],
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """The finite entries of a dense (m, n) matrix in the same row-major form as
    [`close_pairs`][track_envs.metrics.close_pairs.close_pairs]."""
    m, n = matrix.shape
    ptr = np.zeros(m + 1, dtype=np.int64)
    nnz = 0
    for i in range(m):
        for j in range(n):
            if np.isfinite(matrix[i, j]):
                nnz += 1
        ptr[i + 1] = nnz
    cols = np.empty(nnz, dtype=np.int64)
    dist = np.empty(nnz, dtype=np.float64)
    k = 0
    for i in range(m):
        for j in range(n):
            if np.isfinite(matrix[i, j]):
                cols[k] = j
                dist[k] = matrix[i, j]
                k += 1
    return ptr, cols, dist
