"""Generalised optimal sub-pattern assignment (GOSPA) between two point sets.

Rahmathullah, García-Fernández, Svensson, "Generalized optimal sub-pattern assignment metric",
FUSION 2017. With cut-off ``c``, order ``p`` and ``α = 2`` the metric of truths ``X`` (m points)
and estimates ``Y`` (n points) is

.. math::

    d_p^{(c,2)}(X, Y) = \\Big( \\min_{\\gamma} \\sum_{(i,j) \\in \\gamma} d(x_i, y_j)^p
        + \\frac{c^p}{2} \\big(|X| + |Y| - 2|\\gamma|\\big) \\Big)^{1/p}

where ``γ`` ranges over partial assignments whose pairs are closer than ``c``. Equivalently,
with ``γ`` ranging over matchings of the admissible pairs (``d^p <= c^p``; a pair at
``d^p = c^p`` gains nothing either way),

.. math::

    d_p^{(c,2)}(X, Y)^p = \\frac{c^p}{2} (m + n) - \\max_{\\gamma} \\sum_{(i,j) \\in \\gamma}
        \\big(c^p - d(x_i, y_j)^p\\big).

Computed sparsely ([`track_envs.metrics.close_pairs`][track_envs.metrics.close_pairs]): only pairs within
``c`` exist, and they are assigned by
[`track_envs.infra.assignment.lone_pairs`][track_envs.infra.assignment.lone_pairs] with miss cost ``γ = c^p``:
a pair alone in its row and its column (a *lone pair*) gains ``c^p − d^p >= 0`` and blocks nothing, so it is
taken as it is; only the rows and columns left with several admissible partners go to a dense min-cost
assignment with one miss column per row (``[C | diag(c^p)]``,
[`track_envs.infra.assignment.lone_pairs.rest_problem`][track_envs.infra.assignment.lone_pairs.rest_problem]),
solved by the compiled
[`linear_sum_assignment`][track_envs.infra.assignment.shortest_augmenting_path.linear_sum_assignment] — one
connected component of the admissible pairs at a time, which is the same assignment wherever each component's
optimum is unique (by a margin ``2⁻²⁰ c^p`` far above the solver's rounding; checked by solving the component
once more without each of its assigned pairs). On a (near) tie the rest rows are solved as one problem, as
before, so that ties break as they always did — up to [`DENSE_LIMIT`][track_envs.metrics.gospa.DENSE_LIMIT]
entries (rest rows × estimates); above it a tie is broken inside its component (another optimum: the same
GOSPA value, its split into localisation and cardinality may differ). A frame costs ``O(m + n)`` for
components of bounded size. Track identities play no part (in a report they are unique and non-negative within
a frame by the report contract,
[`track_envs.contracts.report.validate_report`][track_envs.contracts.validate_report]).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.assignment.lone_pairs import merge_solution, rest_problem, split_sparse
from track_envs.infra.assignment.shortest_augmenting_path import linear_sum_assignment
from track_envs.infra.compiled import njit
from track_envs.metrics.close_pairs import close_pairs
from track_envs.metrics.live_rows import live_report_rows, live_truth_rows

# pairs are searched slightly beyond c, then kept by the exact test d^p <= c^p
_SEARCH_MARGIN = 1e-9


@dataclass(frozen=True)
class GospaResult:
    """GOSPA of one frame and its decomposition (all to the power ``p``, then the total root).

    Attributes:
        distance: ``d_p^{(c,2)}``, in sensor units.
        localisation: Sum of ``d^p`` over assigned pairs closer than ``c``.
        missed: Number of truths left unassigned (or assigned farther than ``c``).
        false: Number of estimates left unassigned (or assigned farther than ``c``).
    """

    distance: float
    localisation: float
    missed: int
    false: int


#: The largest tie-breaking problem (rest rows × estimates) solved as one matrix (2048², 32 MB):
#: larger frames break a tie inside its component.
DENSE_LIMIT = 2048 * 2048


@njit(cache=True)
def _component_gain(
    local_cost: NDArray[np.float64], cp: float
) -> tuple[float, NDArray[np.int64], NDArray[np.int64]]:
    """Optimal assignment with misses of one component's (k, l) block (``inf``: no admissible
    pair): its gain ``Σ (c^p − C)`` and its admissible pairs (block indices)."""
    k, n_cols = local_cost.shape
    rows_idx = np.arange(k)
    cols_idx = np.arange(n_cols)
    rows, picked = linear_sum_assignment(rest_problem(local_cost, cp, rows_idx, cols_idx))
    none = np.zeros(0, dtype=np.int64)
    got_rows, got_cols = merge_solution(local_cost, cp, none, none, rows_idx, cols_idx, rows, picked)
    gain = 0.0
    for t in range(len(got_rows)):
        gain += cp - local_cost[got_rows[t], got_cols[t]]
    return gain, got_rows, got_cols


@njit(cache=True)
def _assign_components(
    ptr: NDArray[np.int64],
    cols: NDArray[np.int64],
    cost: NDArray[np.float64],
    rest_rows: NDArray[np.int64],
    n_cols: int,
    cp: float,
    col_of: NDArray[np.int64],
    check_unique: bool = True,
) -> bool:
    """The rest rows assigned component by component of their admissible pairs, into ``col_of``,
    where each component's optimum is unique: for every pair ``e`` of the optimum (gain ``G``), the
    component without ``e`` gains less than ``G − tol``. Returns False (``col_of`` then partly
    written) on a (near) tie, for the caller to solve the whole rest as one problem; with
    ``check_unique=False`` every component takes its solver's optimum (ties broken inside it)."""
    m = len(ptr) - 1
    tol = abs(cp) * 2.0**-20
    # union-find over rows 0..m-1 and columns m..m+n_cols-1
    parent = np.arange(m + n_cols)
    for i in rest_rows:
        for e in range(ptr[i], ptr[i + 1]):
            a, b = i, m + cols[e]
            while parent[a] != a:
                parent[a] = parent[parent[a]]
                a = parent[a]
            while parent[b] != b:
                parent[b] = parent[parent[b]]
                b = parent[b]
            if a != b:
                parent[max(a, b)] = min(a, b)
    root = np.empty(len(rest_rows), np.int64)
    for t in range(len(rest_rows)):
        a = rest_rows[t]
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        root[t] = a
    order = np.argsort(root, kind="mergesort")
    col_local = np.full(n_cols, -1, np.int64)
    s = 0
    while s < len(order):
        f = s
        while f < len(order) and root[order[f]] == root[order[s]]:
            f += 1
        comp_rows = rest_rows[order[s:f]]  # ascending: rest_rows ascend, the sort is stable
        n_local = 0
        comp_cols = np.empty(0, np.int64)
        for i in comp_rows:
            for e in range(ptr[i], ptr[i + 1]):
                if col_local[cols[e]] < 0:
                    col_local[cols[e]] = 0
                    n_local += 1
        comp_cols = np.empty(n_local, np.int64)
        n_local = 0
        for i in comp_rows:
            for e in range(ptr[i], ptr[i + 1]):
                if col_local[cols[e]] == 0:
                    col_local[cols[e]] = 1
                    comp_cols[n_local] = cols[e]
                    n_local += 1
        comp_cols.sort()
        for b in range(n_local):
            col_local[comp_cols[b]] = b
        local_cost = np.full((len(comp_rows), n_local), np.inf)
        for a in range(len(comp_rows)):
            i = comp_rows[a]
            for e in range(ptr[i], ptr[i + 1]):
                local_cost[a, col_local[cols[e]]] = cost[e]
                if check_unique and not cp - cost[e] > tol:  # a pair that gains (next to) nothing
                    return False
        for b in range(n_local):
            col_local[comp_cols[b]] = -1
        gain, got_rows, got_cols = _component_gain(local_cost, cp)
        for t in range(len(got_rows) if check_unique else 0):
            held = local_cost[got_rows[t], got_cols[t]]
            local_cost[got_rows[t], got_cols[t]] = np.inf
            without, _, _ = _component_gain(local_cost, cp)
            local_cost[got_rows[t], got_cols[t]] = held
            if not gain - without > tol:
                return False
        for t in range(len(got_rows)):
            col_of[comp_rows[got_rows[t]]] = comp_cols[got_cols[t]]
        s = f
    return True


@njit(cache=True)
def _assign_rest(
    ptr: NDArray[np.int64],
    cols: NDArray[np.int64],
    cost: NDArray[np.float64],
    rest_rows: NDArray[np.int64],
    rest_cols: NDArray[np.int64],
    n_cols: int,
    cp: float,
    col_of: NDArray[np.int64],
) -> None:
    """Assign the rows that are not in lone pairs by ``[C | diag(c^p)]``, into ``col_of``."""
    nr = len(rest_rows)
    local = np.arange(nr)
    # the rest rows' costs over every column (inf: no admissible pair), for the shared problem
    rows_cost = np.full((nr, n_cols), np.inf)
    for r in range(nr):
        i = rest_rows[r]
        for e in range(ptr[i], ptr[i + 1]):
            rows_cost[r, cols[e]] = cost[e]
    rows, picked = linear_sum_assignment(rest_problem(rows_cost, cp, local, rest_cols))
    none = np.zeros(0, dtype=np.int64)
    got_rows, got_cols = merge_solution(rows_cost, cp, none, none, local, rest_cols, rows, picked)
    col_of[rest_rows[got_rows]] = got_cols


@njit(cache=True)
def gospa_core(
    x: NDArray[np.float64], y: NDArray[np.float64], c: float, p: float, cp: float
) -> tuple[float, int]:
    """Localisation ``Σ d^p`` and number of assigned pairs closer than ``c`` (``cp = c ** p``)."""
    m, n = x.shape[0], y.shape[0]
    if m == 0 or n == 0:
        return 0.0, 0
    ptr, cols, dist = close_pairs(x, y, c * (1.0 + _SEARCH_MARGIN))
    # keep the admissible pairs (d^p <= c^p), compacting the row-major lists in place
    cost = np.empty(len(dist))
    kept = 0
    start = 0
    for i in range(m):
        end = ptr[i + 1]
        for e in range(start, end):
            d = dist[e]
            w = d * d if p == 2.0 else d**p
            if w <= cp:
                cols[kept] = cols[e]
                dist[kept] = d
                cost[kept] = w
                kept += 1
        start = end
        ptr[i + 1] = kept
    # lone pairs (alone in their row and their column) are assigned as they are
    col_of, rest_rows, rest_cols = split_sparse(ptr, cols, n)
    if len(rest_rows):
        lone = col_of.copy()
        if not _assign_components(ptr, cols, cost, rest_rows, n, cp, col_of):
            col_of = lone
            if len(rest_rows) * n <= DENSE_LIMIT:
                _assign_rest(ptr, cols, cost, rest_rows, rest_cols, n, cp, col_of)
            else:  # a tie in a frame too large for one matrix: broken inside its component
                _assign_components(ptr, cols, cost, rest_rows, n, cp, col_of, False)
    # Σ d^p over the assigned pairs closer than c, in row order
    loc = 0.0
    n_close = 0
    for i in range(m):
        j = col_of[i]
        if j < 0:
            continue
        for e in range(ptr[i], ptr[i + 1]):
            if cols[e] == j:
                if dist[e] < c:
                    loc += cost[e]
                    n_close += 1
                break
    return loc, n_close


@njit(cache=True)
def gospa_frame(
    truth_ids: NDArray[np.int64],
    truth_positions: NDArray[np.float64],
    visible: NDArray[np.bool_],
    report_ids: NDArray[np.int64],
    report_positions: NDArray[np.float64],
    report_mask: NDArray[np.int8],
    c: float,
    p: float,
    cp: float,
) -> tuple[float, int, int, int]:
    """GOSPA terms of a padded frame: ``(Σ d^p, pairs, m visible truths, n reported rows)``."""
    _, x = live_truth_rows(truth_ids, truth_positions, visible)
    _, y = live_report_rows(report_ids, report_positions, report_mask)
    loc, pairs = gospa_core(x, y, c, p, cp)
    return loc, pairs, x.shape[0], y.shape[0]


def check_gospa_parameters(c: float, p: float) -> None:
    """Raise ``ValueError`` naming ``c`` or ``p`` unless ``0 < c < inf`` and ``1 <= p < inf``."""
    if not 0 < c < np.inf:
        raise ValueError(f"GOSPA cut-off c must be > 0 and finite, got {c!r}")
    if not 1 <= p < np.inf:
        raise ValueError(f"GOSPA order p must be >= 1 and finite, got {p!r}")


def gospa_result(loc: float, pairs: int, m: int, n: int, c: float, p: float) -> GospaResult:
    """Assemble [`GospaResult`][track_envs.metrics.GospaResult] from the localisation sum and the number of
    close pairs."""
    total = loc + c**p / 2 * (m + n - 2 * pairs)
    return GospaResult(total ** (1 / p), loc, m - pairs, n - pairs)


def gospa(
    truth: NDArray[np.floating], estimates: NDArray[np.floating], c: float, p: float = 2.0
) -> GospaResult:
    """GOSPA (α = 2) of ``estimates`` (n, D) against ``truth`` (m, D).

    Args:
        truth: True positions, (m, D).
        estimates: Estimated positions, (n, D).
        c: Cut-off distance, > 0 and finite.
        p: Order, >= 1 and finite.

    Raises:
        ValueError: on a bad ``c`` or ``p``, or (both sets non-empty) points that are not (m, D)
            and (n, D) with the same D.
    """
    check_gospa_parameters(c, p)
    x = np.ascontiguousarray(truth, dtype=np.float64)
    y = np.ascontiguousarray(estimates, dtype=np.float64)
    m, n = len(x), len(y)
    if m == 0 or n == 0:
        return gospa_result(0.0, 0, m, n, c, p)
    if x.ndim != 2 or y.ndim != 2 or x.shape[1] != y.shape[1]:
        raise ValueError(f"GOSPA needs points (m, D) and (n, D) with the same D, got {x.shape} and {y.shape}")
    loc, pairs = gospa_core(x, y, float(c), float(p), float(c) ** float(p))
    return gospa_result(loc, pairs, m, n, c, p)
