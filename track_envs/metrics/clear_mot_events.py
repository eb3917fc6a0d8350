"""The per-frame CLEAR MOT events of py-motmetrics' ``MOTAccumulator.update``, as one compiled kernel.

The frame arrives as truth ids ``oids`` (m,), track ids ``hids`` (n,) and its *possible* pairs in
row-major sparse form (``ptr``, ``cols``, ``dist``: row ``i``'s possible tracks and distances; every
other pair is impossible, NaN in motmetrics' matrix). The kernel replays motmetrics v1.4:

1. **Carry over**: in row order, a truth matched before takes the first not yet taken track
   carrying its last matched id, if that pair is possible.
2. **Assign the rest**: the remaining rows and columns are matched maximising the number of pairs,
   then minimising their summed distance (motmetrics prices impossible pairs at
   ``2 r c + 1``, ``r = min(m, n)``, ``c = 1 + max |possible distance|``, and solves the whole
   m × n matrix with ``scipy.optimize.linear_sum_assignment``). A pair alone in its row and its
   column belongs to every such optimum and is taken directly
   ([`track_envs.infra.assignment.lone_pairs.split_lone_pairs`][track_envs.infra.assignment.lone_pairs.split_lone_pairs]
   of the free pairs). The other connected components of the free pairs are independent: each is solved on its
   own by enumerating its matchings, and where every component's optimum is unique (no other matching with as
   many pairs within a margin far above the solver's rounding) their union is motmetrics' optimum.
   Otherwise (a tie, or a component with more than 4,096 matchings) the matrix motmetrics
   builds is solved by the same algorithm
   ([`shortest_augmenting_path`][track_envs.infra.assignment.shortest_augmenting_path]), so ties are broken as
   motmetrics breaks them — in a frame whose matrix has at most
   [`DENSE_LIMIT`][track_envs.metrics.clear_mot_events.DENSE_LIMIT] entries (2,048 × 2,048). A larger frame
   (motmetrics' dense solve of it takes seconds at 10⁴ targets and does not fit in memory at 10⁵) stays
   linear: a (near) tie is broken within its component (the first best matching of the enumeration; a
   component of more than 4,096 matchings is solved on its own block, priced as motmetrics prices the matrix),
   so only there may the matching differ from motmetrics', by another of its optima. In row order, a match
   whose truth was last matched to another id is an ID switch.
3. Unmatched truths are misses, unmatched tracks false positives; a match of a truth that was
   missed since its previous match is a fragmentation.

State lives in two [`KeyTable`][track_envs.metrics.key_table.KeyTable] tables: per truth id the last
matched track id, matched-ever, missed-since-match and the last frame it appeared in; per (truth
id, track id) the number of frames the pair was possible (for IDF1). Counters are one int64 array
([`COUNTERS`][track_envs.metrics.clear_mot_events.COUNTERS]) and the summed match distance a compensated sum
([`neumaier_add`][track_envs.metrics.clear_mot_events.neumaier_add]).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.assignment.lone_pairs import split_lone_pairs
from track_envs.infra.assignment.shortest_augmenting_path import linear_sum_assignment
from track_envs.infra.compiled import njit
from track_envs.metrics.key_table import add_entry, free_entries, hash_slot

COUNTERS = (
    "frames",
    "objects",
    "predictions",
    "matches",
    "switches",
    "misses",
    "false_positives",
    "frag",
    "truth_frames",  # Σ over frames of the distinct truth ids in the frame
    "track_frames",  # Σ over frames of the distinct track ids in the frame
)
(
    FRAMES,
    OBJECTS,
    PREDICTIONS,
    MATCHES,
    SWITCHES,
    MISSES,
    FALSE_POSITIVES,
    FRAG,
    TRUTH_FRAMES,
    TRACK_FRAMES,
) = range(len(COUNTERS))
# payload columns of the truth table (entries[:, 2:]): last track id, matched ever, missed since
# the last match, last frame seen; and of the pair table: frames the pair was possible
TRUTH_VALUES = 4
_LAST, _MATCHED, _GAP, _SEEN = 2, 3, 4, 5
_TOGETHER = 2
# a connected component of free pairs with more matchings than this is solved on the dense matrix
_MAX_MATCHINGS = 4096
# a (near) tie is solved on motmetrics' whole dense matrix when it has at most this many entries
# (2,048 × 2,048, 32 MiB); a larger frame breaks it within the component (module docstring)
DENSE_LIMIT = 2048 * 2048


@njit(cache=True)
def neumaier_add(acc: NDArray[np.float64], value: float) -> None:
    """Add ``value`` to the running sum ``acc = [s, comp]`` (total ``s + comp``).

    Neumaier's improved Kahan summation: with ``t = s + v``, the rounding error of that addition
    is ``(s − t) + v`` when ``|s| >= |v|`` and ``(v − t) + s`` otherwise, and is accumulated in
    ``comp``. A plain running sum of ``N`` terms drifts by up to ``N`` roundings (``0.1`` added
    10⁵ times is off by 2e-12 relative), which would break MOTP's parity with motmetrics'
    pairwise-summed total on long episodes; this one stays within about one rounding.
    """
    s = acc[0]
    t = s + value
    if abs(s) >= abs(value):
        acc[1] += (s - t) + value
    else:
        acc[1] += (value - t) + s
    acc[0] = t


@njit(cache=True)
def _columns_by_id(hids: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64], int]:
    """A per-frame hash index of the track ids: ``(head, next_col, distinct)``.

    ``head`` (open addressing over ``len(head)`` slots, a power of two) holds, for each distinct
    id, its first column; ``next_col[j]`` is the next column with the same id as column ``j``
    (−1 after the last), so the columns of an id are visited in ascending order.
    """
    n = len(hids)
    n_slots = 2
    while n_slots < 2 * n:
        n_slots *= 2
    mask = n_slots - 1
    head = np.full(n_slots, -1, dtype=np.int64)
    next_col = np.full(n, -1, dtype=np.int64)
    distinct = 0
    for j in range(n - 1, -1, -1):
        h = hids[j]
        s = hash_slot(h, 0, mask)
        while head[s] >= 0 and hids[head[s]] != h:
            s = (s + 1) & mask
        if head[s] >= 0:
            next_col[j] = head[s]
        else:
            distinct += 1
        head[s] = j
    return head, next_col, distinct


@njit(cache=True)
def _first_free_column(
    hids: NDArray[np.int64],
    head: NDArray[np.int64],
    next_col: NDArray[np.int64],
    col_taken: NDArray[np.bool_],
    h: int,
) -> int:
    """The first column carrying track id ``h`` that is not taken yet, −1 if there is none."""
    mask = len(head) - 1
    s = hash_slot(h, 0, mask)
    while head[s] >= 0 and hids[head[s]] != h:
        s = (s + 1) & mask
    j = head[s]
    while j >= 0 and col_taken[j]:
        j = next_col[j]
    return j


@njit(cache=True)
def _possible(ptr: NDArray[np.int64], cols: NDArray[np.int64], i: int, j: int) -> int:
    """Position of pair (i, j) in the row-major lists, −1 if it is impossible."""
    for e in range(ptr[i], ptr[i + 1]):
        if cols[e] == j:
            return e
    return -1


@njit(cache=True)
def _free_pair_counts(
    ptr: NDArray[np.int64],
    cols: NDArray[np.int64],
    row_taken: NDArray[np.bool_],
    col_taken: NDArray[np.bool_],
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """Possible pairs of each free row and free column among the free ones, and the column of a
    row's last free pair, for
    [`split_lone_pairs`][track_envs.infra.assignment.lone_pairs.split_lone_pairs]."""
    m, n = len(row_taken), len(col_taken)
    counts = np.zeros(2 * m + n, dtype=np.int64)  # one allocation, three views
    row_count, only_col, col_count = counts[:m], counts[m : 2 * m], counts[2 * m :]
    for i in range(m):
        if row_taken[i]:
            continue
        for e in range(ptr[i], ptr[i + 1]):
            j = cols[e]
            if not col_taken[j]:
                row_count[i] += 1
                only_col[i] = j
                col_count[j] += 1
    return row_count, only_col, col_count


@njit(cache=True)
def _assign_like_motmetrics(
    ptr: NDArray[np.int64],
    cols: NDArray[np.int64],
    dist: NDArray[np.float64],
    row_taken: NDArray[np.bool_],
    col_taken: NDArray[np.bool_],
    n_cols: int,
) -> NDArray[np.int64]:
    """Step 2 on the whole matrix as motmetrics builds it: possible pairs of free rows and columns.

    Returns the list position of each row's pair in scipy's assignment, −1 where the row got no
    possible pair.
    """
    m = len(row_taken)
    entry = np.full((m, n_cols), -1, dtype=np.int64)
    costs = np.zeros((m, n_cols))
    n_valid = 0
    largest = 0.0
    for i in range(m):
        if row_taken[i]:
            continue
        for e in range(ptr[i], ptr[i + 1]):
            if not col_taken[cols[e]]:
                entry[i, cols[e]] = e
                costs[i, cols[e]] = dist[e]
                n_valid += 1
                largest = max(largest, abs(dist[e]))
    if n_valid < m * n_cols:  # motmetrics' add_expensive_edges
        large = float(2 * min(m, n_cols)) * (largest + 1.0) + 1.0
        for i in range(m):
            for j in range(n_cols):
                if entry[i, j] < 0:
                    costs[i, j] = large
    rows, picked = linear_sum_assignment(costs)
    at = np.full(m, -1, dtype=np.int64)
    for t in range(len(rows)):
        at[rows[t]] = entry[rows[t], picked[t]]
    return at


@njit(cache=True)
def _unique_component_optimum(
    ptr: NDArray[np.int64],
    cols: NDArray[np.int64],
    dist: NDArray[np.float64],
    col_taken: NDArray[np.bool_],
    comp_rows: NDArray[np.int64],
    tol: float,
    partner: NDArray[np.int64],
    exact: bool = True,
) -> bool:
    """Step 2 on one connected component of the free pairs, when its optimum is unique.

    Enumerates the matchings of the component's rows ``comp_rows`` (depth first, each row taking
    one of its free columns or none), keeping the best by (number of pairs, then summed
    distance). When every other matching with that many pairs is longer by more than ``tol``,
    the best one's columns go into ``partner`` and the result is True; on a (near) tie, or when
    the component has more than [`_MAX_MATCHINGS`][track_envs.metrics.clear_mot_events._MAX_MATCHINGS]
    matchings, nothing is written and the result is False. Not ``exact``: a tie is not refused (the first best
    matching found is kept).
    """
    k = len(comp_rows)
    choice = np.full(k, -2, dtype=np.int64)  # per depth: the list position tried, −1 = no pair
    best_choice = np.full(k, -1, dtype=np.int64)
    used = col_taken.copy()
    cost = np.zeros(k + 1)
    card = np.zeros(k + 1, dtype=np.int64)
    best_card, best_cost, second = -1, np.inf, np.inf
    leaves = 0
    depth = 0
    while depth >= 0:
        i = comp_rows[depth] if depth < k else -1
        if depth == k or card[depth] + (k - depth) < best_card:  # a leaf, or it cannot catch up
            if depth == k:
                leaves += 1
                if leaves > _MAX_MATCHINGS:
                    return False
                c, total = card[k], cost[k]
                if c > best_card:
                    best_card, best_cost, second = c, total, np.inf
                    best_choice[:] = choice
                elif c == best_card:
                    if total < best_cost:
                        second, best_cost = best_cost, total
                        best_choice[:] = choice
                    elif total < second:
                        second = total
            depth -= 1
            if depth >= 0 and choice[depth] >= 0:
                used[cols[choice[depth]]] = False
            continue
        # the next option of row i after choice[depth]: its free pairs in list order, then none
        e = ptr[i] if choice[depth] == -2 else choice[depth] + 1
        if choice[depth] == -1:
            choice[depth] = -2  # both kinds of option tried: back up
            depth -= 1
            if depth >= 0 and choice[depth] >= 0:
                used[cols[choice[depth]]] = False
            continue
        while e < ptr[i + 1] and used[cols[e]]:
            e += 1
        if e < ptr[i + 1]:
            choice[depth] = e
            used[cols[e]] = True
            card[depth + 1] = card[depth] + 1
            cost[depth + 1] = cost[depth] + dist[e]
        else:
            choice[depth] = -1
            card[depth + 1] = card[depth]
            cost[depth + 1] = cost[depth]
        depth += 1
        if depth < k:
            choice[depth] = -2
    if exact and not second - best_cost > tol:
        return False
    for a in range(k):
        if best_choice[a] >= 0:
            partner[comp_rows[a]] = cols[best_choice[a]]
    return True


@njit(cache=True)
def _assign_component_block(
    ptr: NDArray[np.int64],
    cols: NDArray[np.int64],
    dist: NDArray[np.float64],
    col_taken: NDArray[np.bool_],
    comp_rows: NDArray[np.int64],
    partner: NDArray[np.int64],
) -> None:
    """Step 2 on one component's own block, priced as motmetrics prices its matrix (the most
    pairs, then the least summed distance), into ``partner``: for a component too large to
    enumerate in a frame too large for the dense matrix."""
    n_local = 0
    for i in comp_rows:
        for e in range(ptr[i], ptr[i + 1]):
            if not col_taken[cols[e]]:
                n_local += 1
    block_cols = np.empty(n_local, np.int64)
    n_local = 0
    for i in comp_rows:
        for e in range(ptr[i], ptr[i + 1]):
            if not col_taken[cols[e]]:
                block_cols[n_local] = cols[e]
                n_local += 1
    block_cols = np.unique(block_cols)
    k, n_block = len(comp_rows), len(block_cols)
    costs = np.full((k, n_block), np.nan)
    largest = 0.0
    for a in range(k):
        i = comp_rows[a]
        for e in range(ptr[i], ptr[i + 1]):
            if not col_taken[cols[e]]:
                costs[a, np.searchsorted(block_cols, cols[e])] = dist[e]
                largest = max(largest, abs(dist[e]))
    large = float(2 * min(k, n_block)) * (largest + 1.0) + 1.0
    possible = ~np.isnan(costs)
    for a in range(k):
        for b in range(n_block):
            if not possible[a, b]:
                costs[a, b] = large
    rows, picked = linear_sum_assignment(costs)
    for t in range(len(rows)):
        if possible[rows[t], picked[t]]:
            partner[comp_rows[rows[t]]] = block_cols[picked[t]]


@njit(cache=True)
def _match_components(
    ptr: NDArray[np.int64],
    cols: NDArray[np.int64],
    dist: NDArray[np.float64],
    row_taken: NDArray[np.bool_],
    col_taken: NDArray[np.bool_],
    rest_rows: NDArray[np.int64],
    partner: NDArray[np.int64],
) -> bool:
    """Step 2 for the rows in ``rest_rows``, component by component, into ``partner`` (columns).

    motmetrics' dense problem prices impossible pairs so high that its optimum has the most
    possible pairs and, among those, the least summed distance; the components of the free pairs
    are independent, so that optimum is the union of the components' optima. Where each is
    unique by more than the rounding scipy's solver can make on the dense matrix (a margin of
    ``2⁻³⁰`` of its largest entry, about 10⁷ of its rounding units), that union is what
    motmetrics gets. Returns False (``partner`` then partly written) when some component's
    optimum is not so certainly unique — only in a frame of at most
    [`DENSE_LIMIT`][track_envs.metrics.clear_mot_events.DENSE_LIMIT] matrix entries: a larger frame keeps the
    component's first best matching (or solves a component of more than
    [`_MAX_MATCHINGS`][track_envs.metrics.clear_mot_events._MAX_MATCHINGS] matchings on its own block) and
    returns True.
    """
    m, n = len(row_taken), len(col_taken)
    exact = m * n <= DENSE_LIMIT
    largest = 0.0  # over every free pair, as motmetrics' price of an impossible pair takes it
    for i in range(m):
        if row_taken[i]:
            continue
        for e in range(ptr[i], ptr[i + 1]):
            if not col_taken[cols[e]]:
                largest = max(largest, abs(dist[e]))
    tol = (float(2 * min(m, n)) * (largest + 1.0) + 1.0) * 2.0**-30
    # the rows of each column's free pairs (column-major), to walk the components
    col_ptr = np.zeros(n + 1, dtype=np.int64)
    for i in rest_rows:
        for e in range(ptr[i], ptr[i + 1]):
            if not col_taken[cols[e]]:
                col_ptr[cols[e] + 1] += 1
    for j in range(n):
        col_ptr[j + 1] += col_ptr[j]
    fill = col_ptr[:-1].copy()
    col_rows = np.empty(col_ptr[n], dtype=np.int64)
    for i in rest_rows:
        for e in range(ptr[i], ptr[i + 1]):
            j = cols[e]
            if not col_taken[j]:
                col_rows[fill[j]] = i
                fill[j] += 1
    seen_row = np.zeros(m, dtype=np.bool_)
    seen_col = np.zeros(n, dtype=np.bool_)
    queue = np.empty(m, dtype=np.int64)
    for start in rest_rows:
        if seen_row[start]:
            continue
        seen_row[start] = True
        queue[0] = start
        size, head = 1, 0
        while head < size:
            i = queue[head]
            head += 1
            for e in range(ptr[i], ptr[i + 1]):
                j = cols[e]
                if col_taken[j] or seen_col[j]:
                    continue
                seen_col[j] = True
                for t in range(col_ptr[j], col_ptr[j + 1]):
                    r = col_rows[t]
                    if not seen_row[r]:
                        seen_row[r] = True
                        queue[size] = r
                        size += 1
        comp = np.sort(queue[:size])
        if not _unique_component_optimum(ptr, cols, dist, col_taken, comp, tol, partner, exact):
            if exact:
                return False
            _assign_component_block(ptr, cols, dist, col_taken, comp, partner)
    return True


@njit(cache=True)
def _match_the_rest(
    ptr: NDArray[np.int64],
    cols: NDArray[np.int64],
    dist: NDArray[np.float64],
    row_taken: NDArray[np.bool_],
    col_taken: NDArray[np.bool_],
) -> NDArray[np.int64]:
    """Step 2: the list position of each row's pair, −1 where the row is not matched here.

    Lone pairs are taken directly; the other components of the free pairs are solved on their
    own where their optimum is unique
    ([`_match_components`][track_envs.metrics.clear_mot_events._match_components]), else the whole matrix is
    solved as motmetrics solves it
    ([`_assign_like_motmetrics`][track_envs.metrics.clear_mot_events._assign_like_motmetrics]).
    """
    row_count, only_col, col_count = _free_pair_counts(ptr, cols, row_taken, col_taken)
    partner, rest_rows, _ = split_lone_pairs(row_count, only_col, col_count)
    if len(rest_rows) and not _match_components(ptr, cols, dist, row_taken, col_taken, rest_rows, partner):
        return _assign_like_motmetrics(ptr, cols, dist, row_taken, col_taken, len(col_taken))
    # every free pair is a lone pair: the unique optimum
    for i in range(len(partner)):
        if partner[i] >= 0:
            partner[i] = _possible(ptr, cols, i, partner[i])
    return partner


@njit(cache=True)
def frame_events(
    oids: NDArray[np.int64],
    hids: NDArray[np.int64],
    ptr: NDArray[np.int64],
    cols: NDArray[np.int64],
    dist: NDArray[np.float64],
    truth_index: NDArray[np.int64],
    truth_entries: NDArray[np.int64],
    pair_index: NDArray[np.int64],
    pair_entries: NDArray[np.int64],
    counts: NDArray[np.int64],
    dist_sum: NDArray[np.float64],
) -> int:
    """Add one frame's events to the state.

    Returns:
        −1 when done; otherwise nothing was changed and the value is the number of possible pairs
            (the pair table needs that many free entries, the truth table ``len(oids)``).
    """
    m, n = len(oids), len(hids)
    nnz = ptr[m]
    if free_entries(truth_index, truth_entries) < m or free_entries(pair_index, pair_entries) < nnz:
        return nnz
    frame = counts[FRAMES] + 1
    # truth rows in the state; each distinct truth id counted once per frame
    slot = np.empty(m, dtype=np.int64)
    for i in range(m):
        s = add_entry(truth_index, truth_entries, oids[i], 0)
        slot[i] = s
        if truth_entries[s, _SEEN] != frame:
            truth_entries[s, _SEEN] = frame
            counts[TRUTH_FRAMES] += 1
    # track ids by id (each distinct one counted once per frame)
    head, next_col, distinct = _columns_by_id(hids)
    counts[TRACK_FRAMES] += distinct
    # co-occurrences of possible pairs (IDF1)
    for i in range(m):
        for e in range(ptr[i], ptr[i + 1]):
            p = add_entry(pair_index, pair_entries, oids[i], hids[cols[e]])
            pair_entries[p, _TOGETHER] += 1
    match_i = np.empty(min(m, n), dtype=np.int64)
    match_e = np.empty(min(m, n), dtype=np.int64)
    n_match = 0
    n_switch = 0
    row_taken = np.zeros(m, dtype=np.bool_)
    col_taken = np.zeros(n, dtype=np.bool_)
    if m > 0 and n > 0:
        # 1. carry over previous matches
        for i in range(m):
            s = slot[i]
            if truth_entries[s, _MATCHED] == 0:
                continue
            j = _first_free_column(hids, head, next_col, col_taken, truth_entries[s, _LAST])
            if j < 0:
                continue
            e = _possible(ptr, cols, i, j)
            if e >= 0:
                row_taken[i] = True
                col_taken[j] = True
                match_i[n_match] = i
                match_e[n_match] = e
                n_match += 1
        # 2. the rest: lone pairs directly, anything else as motmetrics solves it
        rest_e = _match_the_rest(ptr, cols, dist, row_taken, col_taken)
        for i in range(m):
            e = rest_e[i]
            if e < 0:
                continue
            s = slot[i]
            h = hids[cols[e]]
            if truth_entries[s, _MATCHED] == 1 and truth_entries[s, _LAST] != h:
                n_switch += 1
            truth_entries[s, _LAST] = h
            truth_entries[s, _MATCHED] = 1
            row_taken[i] = True
            match_i[n_match] = i
            match_e[n_match] = e
            n_match += 1
    # 3. counts, distances, fragmentations
    counts[FRAMES] = frame
    counts[OBJECTS] += m
    counts[PREDICTIONS] += n
    counts[SWITCHES] += n_switch
    counts[MATCHES] += n_match - n_switch
    counts[MISSES] += m - n_match
    counts[FALSE_POSITIVES] += n - n_match
    for t in range(n_match):
        neumaier_add(dist_sum, dist[match_e[t]])
        s = slot[match_i[t]]
        if truth_entries[s, _GAP] == 1:
            counts[FRAG] += 1
            truth_entries[s, _GAP] = 0
    for i in range(m):
        if not row_taken[i]:
            s = slot[i]
            if truth_entries[s, _MATCHED] == 1:
                truth_entries[s, _GAP] = 1
    return -1
