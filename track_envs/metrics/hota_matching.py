"""HOTA's per-frame pieces on the non-zero similarities only: the soft-match sums and the matching.

[`HotaAccumulator`][track_envs.metrics.HotaAccumulator] keeps a frame as its non-zero similarities
``S_t(i, j)`` (row-major: rows ascending, columns ascending within a row). Two steps of
TrackEval's HOTA read the whole ``n × m`` matrix of a frame; here they cost the number of
non-zero entries (plus ``n + m``), with the same floating-point results.

* **Soft-match denominators** ``Σ_{j'} S(i, j') + Σ_{i'} S(i', j) − S(i, j)``. TrackEval takes
  ``S.sum(1)`` and ``S.sum(0)`` of the dense matrix. numpy adds a column sum row by row, in row
  order: [`column_sums`][track_envs.metrics.hota_matching.column_sums] adds the entries in that order (a zero
  term is exact). A row sum runs along the contiguous axis, where numpy uses its pairwise summation (eight
  interleaved partial sums in blocks of at most 128 numbers, halves of longer runs split at a multiple of 8):
  [`row_sums`][track_envs.metrics.hota_matching.row_sums] follows that tree over the row's ``m`` positions,
  descending only where a non-zero lies, so each sum is the very float numpy returns.
* **Matching** ([`frame_matches`][track_envs.metrics.hota_matching.frame_matches]). A frame's pairs are
matched maximising
  ``Σ A(g_i, k_j) S_t(i, j)``; TrackEval solves the dense matrix with scipy's
  ``linear_sum_assignment`` (zeros everywhere else) and keeps the matched pairs with ``S > 0``.
  The connected components of the non-zero entries are independent, so that optimum is the union
  of the components' optima; where each component's optimum is unique by more than a margin
  ``tol`` far above the solver's rounding, every optimal assignment of the dense matrix — scipy's
  included — takes exactly those pairs. A frame whose entries are all alone in their row and
  column (and of positive score) takes them all, as TrackEval's solver does. Otherwise a
  component that is one entry is taken; one row (or one column) takes its largest score; any
  other is solved on its own dense block with the compiled twin of scipy's solver
  ([`shortest_augmenting_path`][track_envs.infra.assignment.shortest_augmenting_path]), and its optimum ``M``
  (value ``V``) is unique by ``tol`` when, for every pair ``e ∈ M``, the block without ``e`` has a
  smaller optimum than ``V − tol`` (another matching at least as good misses some ``e ∈ M``; one
  that contains ``M`` and more is better than the optimum). A frame with a
  (near) tie, or with a score ``≤ tol`` (an entry whose similarity is so small that its soft
  match vanished), is returned as *dense*: the caller solves that frame's whole matrix as
  TrackEval does, so the result equals TrackEval's also there — up to a size: a frame of more
  than ``dense_limit`` matrix entries ([`DENSE_LIMIT`][track_envs.metrics.hota.DENSE_LIMIT], a
  2,048 × 2,048 matrix; TrackEval's dense solve of it takes seconds and gigabytes at 10⁴ targets)
  is always solved component by component, its (near) ties broken as the compiled solver breaks
  them on the component's own block and every positive-score pair of a one-pair component taken.
  Then only where a frame has two optimal matchings (to ``tol``) may the pairs differ from
  TrackEval's, by another of its optima.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.assignment.shortest_augmenting_path import linear_sum_assignment
from track_envs.infra.compiled import njit
from track_envs.metrics.key_table import hash_slot

#: numpy's pairwise summation: a block of at most this many numbers is summed with eight
#: interleaved partial sums (``PW_BLOCKSIZE`` of numpy's ``loops_utils.h``).
_PW_BLOCK = 128


@njit(cache=True)
def _block_sum(pos: NDArray[np.int64], val: NDArray[np.float64], a: int, b: int, lo: int, n: int) -> float:
    """numpy's sum of a run ``[lo, lo + n)`` of at most 128 numbers whose non-zeros are
    ``val[a:b]`` at the ascending positions ``pos[a:b]``: sequential below 8 numbers, else eight
    interleaved partial sums, combined pairwise, then the tail beyond the last multiple of 8."""
    if n < 8:
        res = 0.0
        for e in range(a, b):
            res += val[e]
        return res
    r0 = r1 = r2 = r3 = r4 = r5 = r6 = r7 = 0.0
    main_end = lo + n - n % 8
    e = a
    while e < b and pos[e] < main_end:
        lane = (pos[e] - lo) % 8
        if lane == 0:
            r0 += val[e]
        elif lane == 1:
            r1 += val[e]
        elif lane == 2:
            r2 += val[e]
        elif lane == 3:
            r3 += val[e]
        elif lane == 4:
            r4 += val[e]
        elif lane == 5:
            r5 += val[e]
        elif lane == 6:
            r6 += val[e]
        else:
            r7 += val[e]
        e += 1
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while e < b:
        res += val[e]
        e += 1
    return res


@njit(cache=True)
def _pairwise(
    pos: NDArray[np.int64], val: NDArray[np.float64], a: int, b: int, n: int, stack: NDArray[np.int64]
) -> float:
    """numpy's ``pairwise_sum`` of a run of ``n`` numbers whose non-zeros are ``val[a:b]`` at the
    ascending positions ``pos[a:b]``: a run longer than 128 is the sum of its halves, split at a
    multiple of 8 (an explicit stack, ``stack`` (5, 130) scratch, instead of recursion; a run
    without non-zeros sums to 0)."""
    s_lo, s_n, s_a, s_b, s_open = stack[0], stack[1], stack[2], stack[3], stack[4]
    results = np.empty(stack.shape[1], np.float64)
    top, n_res = 0, 0
    s_lo[0], s_n[0], s_a[0], s_b[0], s_open[0] = 0, n, a, b, 0
    top = 1
    while top > 0:
        t = top - 1
        lo, m, ea, eb = s_lo[t], s_n[t], s_a[t], s_b[t]
        if s_open[t]:  # both halves summed: left + right
            results[n_res - 2] = results[n_res - 2] + results[n_res - 1]
            n_res -= 1
            top -= 1
        elif ea == eb or m <= _PW_BLOCK:
            results[n_res] = 0.0 if ea == eb else _block_sum(pos, val, ea, eb, lo, m)
            n_res += 1
            top -= 1
        else:
            n2 = m // 2
            n2 -= n2 % 8
            split = ea
            while split < eb and pos[split] < lo + n2:
                split += 1
            s_open[t] = 1
            # the right half below the left one: the left is summed first
            s_lo[top], s_n[top], s_a[top], s_b[top] = lo + n2, m - n2, split, eb
            s_lo[top + 1], s_n[top + 1], s_a[top + 1], s_b[top + 1] = lo, n2, ea, split
            s_open[top] = s_open[top + 1] = 0
            top += 2
    return results[0]


@njit(cache=True)
def row_sums(
    rows: NDArray[np.int64], cols: NDArray[np.int64], values: NDArray[np.float64], n_rows: int, n_cols: int
) -> NDArray[np.float64]:
    """``S.sum(1)`` of the (n_rows, n_cols) matrix whose non-zeros are the row-major entries
    ``(rows, cols, values)``, bit for bit as numpy sums the dense rows (module docstring)."""
    out = np.zeros(n_rows)
    stack = np.zeros((5, 2 * 64 + 2), np.int64)
    e = 0
    n = len(rows)
    while e < n:
        f = e
        while f < n and rows[f] == rows[e]:
            f += 1
        if f - e == 1:  # zeros add exactly: one or two non-zeros sum alike in any order
            out[rows[e]] = values[e]
        elif f - e == 2:
            out[rows[e]] = values[e] + values[e + 1]
        else:
            out[rows[e]] = 0.0 + _pairwise(cols, values, e, f, n_cols, stack)
        e = f
    return out


@njit(cache=True)
def column_sums(cols: NDArray[np.int64], values: NDArray[np.float64], n_cols: int) -> NDArray[np.float64]:
    """``S.sum(0)``: the row-major entries added into their columns in row order, as numpy does."""
    out = np.zeros(n_cols)
    for e in range(len(cols)):
        out[cols[e]] += values[e]
    return out


@njit(cache=True)
def _block_value(block: NDArray[np.float64]) -> tuple[float, NDArray[np.int64], NDArray[np.int64]]:
    """The optimum of ``max Σ block`` over matchings (non-positive costs ``block`` = −score):
    its value and its pairs with a positive score."""
    r, c = linear_sum_assignment(block)
    value = 0.0
    keep = 0
    for t in range(len(r)):
        if block[r[t], c[t]] < 0.0:
            value -= block[r[t], c[t]]
            keep += 1
    rr = np.empty(keep, np.int64)
    cc = np.empty(keep, np.int64)
    keep = 0
    for t in range(len(r)):
        if block[r[t], c[t]] < 0.0:
            rr[keep] = r[t]
            cc[keep] = c[t]
            keep += 1
    return value, rr, cc


@njit(cache=True)
def _component(
    entries: NDArray[np.int64],
    rows: NDArray[np.int64],
    cols: NDArray[np.int64],
    score: NDArray[np.float64],
    tol: float,
    take: NDArray[np.bool_],
    exact: bool,
) -> bool:
    """Match one component (its entry numbers ``entries``) into ``take``; False on a (near) tie
    when ``exact`` (else ties are broken as the solver on the component's block breaks them, and
    only pairs of positive score are taken)."""
    k = len(entries)
    if k == 1:
        take[entries[0]] = score[entries[0]] > 0.0
        return True
    # the component's rows and columns, numbered locally in ascending order
    rs = np.unique(rows[entries])
    cs = np.unique(cols[entries])
    if len(rs) == 1 or len(cs) == 1:  # a star: the largest score, unique by tol
        best = -1
        for e in entries:
            if best < 0 or score[e] > score[best]:
                best = e
        if exact:
            for e in entries:
                if e != best and not score[best] - score[e] > tol:
                    return False
        take[best] = score[best] > 0.0
        return True
    block = np.zeros((len(rs), len(cs)))
    for e in entries:
        block[np.searchsorted(rs, rows[e]), np.searchsorted(cs, cols[e])] = -score[e]
    value, rr, cc = _block_value(block)
    for t in range(len(rr) if exact else 0):
        held = block[rr[t], cc[t]]
        block[rr[t], cc[t]] = 0.0
        without, _, _ = _block_value(block)
        block[rr[t], cc[t]] = held
        if not value - without > tol:
            return False
    for e in entries:
        i = np.searchsorted(rs, rows[e])
        j = np.searchsorted(cs, cols[e])
        for t in range(len(rr)):
            if rr[t] == i and cc[t] == j:
                take[e] = True
    return True


@njit(cache=True)
def _find(parent: NDArray[np.int64], x: int) -> int:
    """Root of ``x`` in a union-find forest (path halving)."""
    while parent[x] != x:
        parent[x] = parent[parent[x]]
        x = parent[x]
    return x


@njit(cache=True)
def frame_matches(
    entry_start: NDArray[np.int64],
    rows: NDArray[np.int64],
    cols: NDArray[np.int64],
    score: NDArray[np.float64],
    n_rows: NDArray[np.int64],
    n_cols: NDArray[np.int64],
    tol: float,
    dense_limit: int,
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Each frame's optimal matching, component by component (module docstring).

    Args:
        entry_start: (frames + 1,) frame ``t``'s entries are ``entry_start[t]:entry_start[t + 1]``.
        rows: Per entry, its row in the frame (row-major within a frame).
        cols: Per entry, its column in the frame.
        score: Per entry, ``A(g, k) S`` (> 0 unless the soft match vanished).
        n_rows: (frames,) rows (truth) per frame.
        n_cols: (frames,) columns (tracker) per frame.
        tol: The uniqueness margin.
        dense_limit: A frame of more than this many matrix entries (``n m``) is never returned
            as dense: its ties are broken component by component.

    Returns:
        ``(take, dense)``: per entry, whether its pair is matched; per frame, whether it must be
            solved on its dense matrix instead (``take`` is then not meaningful for it).
    """
    n_frames = len(n_rows)
    take = np.zeros(len(rows), np.bool_)
    dense = np.zeros(n_frames, np.bool_)
    for t in range(n_frames):
        lo, hi = entry_start[t], entry_start[t + 1]
        if hi == lo:
            continue
        nr, nc = n_rows[t], n_cols[t]
        row_seen = np.zeros(nr, np.bool_)
        col_seen = np.zeros(nc, np.bool_)
        repeats = False
        positive = True
        low_score = False
        for e in range(lo, hi):
            repeats |= row_seen[rows[e]] or col_seen[cols[e]]
            row_seen[rows[e]] = True
            col_seen[cols[e]] = True
            positive &= score[e] > 0.0
            low_score |= not score[e] > tol
        if not repeats and positive:  # every pair alone in its row and column: all matched
            take[lo:hi] = True
            continue
        exact = nr * nc <= dense_limit
        if low_score and exact:
            dense[t] = True
            continue
        # components over the nodes 0..nr-1 (rows) and nr..nr+nc-1 (columns)
        parent = np.arange(nr + nc)
        for e in range(lo, hi):
            a = _find(parent, rows[e])
            b = _find(parent, nr + cols[e])
            if a != b:
                parent[max(a, b)] = min(a, b)
        # the entries grouped by component (a counting sort by root row, entry order kept)
        start = np.zeros(nr + 1, np.int64)
        root = np.empty(hi - lo, np.int64)
        for e in range(lo, hi):
            root[e - lo] = _find(parent, rows[e])
            start[root[e - lo] + 1] += 1
        for i in range(nr):
            start[i + 1] += start[i]
        order = np.empty(hi - lo, np.int64)
        fill = start[:-1].copy()
        for e in range(lo, hi):
            order[fill[root[e - lo]]] = e
            fill[root[e - lo]] += 1
        for i in range(nr):
            a, b = start[i], start[i + 1]
            if b == a:
                continue
            if b - a == 1:
                take[order[a]] = score[order[a]] > 0.0
            elif not _component(order[a:b], rows, cols, score, tol, take, exact):
                dense[t] = True
                break
    return take, dense


@njit(cache=True)
def _first_seen_groups(keys: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Group equal keys with an open-addressing hash (load ≤ ½): the group of each key, numbered
    in order of first appearance, and the first position of each group."""
    n = len(keys)
    n_slots = 2
    while n_slots < 2 * n:
        n_slots *= 2
    mask = n_slots - 1
    slot_group = np.full(n_slots, -1, np.int64)
    group_of = np.empty(n, np.int64)
    first = np.empty(n, np.int64)
    n_groups = 0
    for t in range(n):
        s = hash_slot(keys[t], 0, mask)
        while True:
            g = slot_group[s]
            if g < 0:
                slot_group[s] = n_groups
                first[n_groups] = t
                group_of[t] = n_groups
                n_groups += 1
                break
            if keys[first[g]] == keys[t]:
                group_of[t] = g
                break
            s = (s + 1) & mask
    return group_of, first[:n_groups]


def distinct_count(keys: NDArray[np.int64]) -> int:
    """How many distinct values the int64 ``keys`` hold (a hash, ``O(n)``)."""
    return len(_first_seen_groups(keys)[1])


def unique_inverse(keys: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """``np.unique(keys, return_inverse=True)`` of int64 keys in ``O(n + u log u)`` (``u`` distinct
    keys): grouped by a hash, then only the distinct keys sorted."""
    keys = np.ascontiguousarray(keys, dtype=np.int64)
    group_of, first = _first_seen_groups(keys)
    distinct = keys[first]
    order = np.argsort(distinct, kind="stable")
    rank = np.empty(order.size, np.int64)
    rank[order] = np.arange(order.size)
    return distinct[order], rank[group_of]
