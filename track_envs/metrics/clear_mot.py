"""CLEAR MOT (MOTA, MOTP, ID switches, fragmentations) and IDF1 on point distances.

CLEAR MOT: Bernardin, Stiefelhagen, "Evaluating Multiple Object Tracking Performance: the CLEAR
MOT Metrics", EURASIP JIVP 2008; with the event rules of py-motmetrics' ``MOTAccumulator.update``
(Heindl, Valmadre et al., https://github.com/cheind/py-motmetrics, v1.4), reproduced exactly:

1. a truth matched before keeps its last track if that track is in the frame and the pair is
   possible (distance not NaN); rows are tried in order, each track serves one truth;
2. the remaining truths and tracks are matched by a min-cost assignment (scipy
   ``linear_sum_assignment``, impossible pairs priced as motmetrics' ``add_expensive_edges``
   prices them, then dropped); a match whose track differs from the truth's last match is an
   ID switch;
3. unmatched truths are misses, unmatched tracks false positives.

.. math::

    \\mathrm{MOTA} = 1 - \\frac{\\mathrm{FN} + \\mathrm{FP} + \\mathrm{IDSW}}{\\mathrm{GT}}, \\qquad
    \\mathrm{MOTP} = \\frac{\\sum_{\\text{matches}} d}{\\#\\text{matches (incl. switches)}}

(MOTP here is the mean *distance* of the matches, as in motmetrics). A fragmentation is a run of
misses of a truth between two of its matches.

IDF1: Ristani, Solera, Zou, Cucchiara, Tomasi, "Performance Measures and a Data Set for
Multi-Target, Multi-Camera Tracking", ECCV Workshops 2016. Truth ids and track ids are matched
one-to-one over the whole sequence so as to maximise IDTP, the number of (frame, truth, track)
co-occurrences within the threshold of matched id pairs; then

.. math::

    \\mathrm{IDF1} = \\frac{2\\,\\mathrm{IDTP}}{2\\,\\mathrm{IDTP} + \\mathrm{IDFP} + \\mathrm{IDFN}}
        = \\frac{2\\,\\mathrm{IDTP}}{\\mathrm{GT} + \\#\\text{track rows}}.

The matching is solved on the co-occurrence counts alone (a maximum-weight assignment, per
connected component of the co-occurrence graph), which has the same optimum as motmetrics' square
min-cost problem over truths, tracks and dummies: IDFN = Σ_o (frames with truth o) − max,
IDFP = Σ_h (frames with track h) − max and IDTP = GT − IDFN, exactly motmetrics' bookkeeping (the
three agree with the textbook IDTP = max unless an id repeats within a frame).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from track_envs.assignment import max_cardinality_min_cost, pairwise_distances
from track_envs.metrics.base import KeyCounter, live_report, live_truth

_COUNTS = ("frames", "objects", "predictions", "matches", "switches", "misses", "false_positives", "frag")


def assign_like_motmetrics(costs: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Min-cost assignment with NaN / inf marking impossible pairs, with motmetrics' objective.

    motmetrics prices impossible pairs at ``2 r c + 1`` (``r`` the smaller side, ``c`` one more
    than the largest finite |cost|), which maximises the number of pairs first and then minimises
    their cost; :func:`track_envs.assignment.max_cardinality_min_cost` solves that objective with
    lone pairs taken directly, so large sparse frames stay fast.

    Returns:
        Row and column indices of the possible assigned pairs, rows ascending.
    """
    return max_cardinality_min_cost(costs)


def max_weight_matching(rows: NDArray[np.intp], cols: NDArray[np.intp], weight: NDArray[np.int64]) -> int:
    """Largest total weight of a one-to-one matching on a sparse bipartite graph.

    Edge ``k`` joins row node ``rows[k]`` and column node ``cols[k]`` (both ``0..n-1``, every node on
    an edge, no repeated edge) with weight ``weight[k] >= 0``. The graph is split into connected
    components (ids that never co-occur cannot matter to each other); a component with one row or
    one column node takes its heaviest edge, the others are solved densely with scipy's
    ``linear_sum_assignment(maximize=True)``. Same optimum as one dense assignment, without a
    (#truth ids × #track ids) matrix.
    """
    n_rows, n_cols = int(rows.max()) + 1, int(cols.max()) + 1
    graph = coo_matrix((np.ones(len(rows)), (rows, cols + n_rows)), shape=(n_rows + n_cols,) * 2)
    n_comp, label = connected_components(graph, directed=False)
    comp = label[rows]
    order = np.argsort(comp, kind="stable")
    rows, cols, weight, comp = rows[order], cols[order], weight[order], comp[order]
    starts = np.flatnonzero(np.r_[True, comp[1:] != comp[:-1]])
    star = (np.bincount(label[:n_rows], minlength=n_comp) == 1) | (
        np.bincount(label[n_rows:], minlength=n_comp) == 1
    )
    total = int(np.maximum.reduceat(weight, starts)[star[comp[starts]]].sum())
    for lo, hi in zip(starts, np.r_[starts[1:], len(comp)], strict=True):
        if star[comp[lo]]:
            continue
        _, r = np.unique(rows[lo:hi], return_inverse=True)
        _, c = np.unique(cols[lo:hi], return_inverse=True)
        dense = np.zeros((r.max() + 1, c.max() + 1), dtype=np.int64)
        dense[r, c] = weight[lo:hi]
        ri, ci = linear_sum_assignment(dense, maximize=True)
        total += int(dense[ri, ci].sum())
    return total


class ClearMot:
    """Streaming CLEAR MOT and IDF1 of reports against the visible truth, with motmetrics parity.

    Per frame, the distance matrix is the Euclidean distance between the visible truth rows and
    the report rows with mask 1, NaN where it exceeds ``threshold`` (as motmetrics'
    ``norm2squared_matrix`` with ``max_d2``: a pair exactly at the threshold is possible).
    :meth:`update_distances` takes such a matrix directly and produces the same events as
    ``motmetrics.MOTAccumulator.update``.

    Duplicate ids in one frame (a report may hold them) are scored as motmetrics scores them:
    each row is a separate object / hypothesis sharing the id's history. Frames without
    duplicates take a vectorised path; a frame with duplicates replays motmetrics' row-by-row
    carry-over step (a documented slow path for malformed reports only).

    Args:
        threshold: Largest distance, in sensor units, at which a track can match a truth.
    """

    def __init__(self, threshold: float) -> None:
        if not (np.isfinite(threshold) and threshold > 0):
            raise ValueError(f"ClearMot threshold must be a positive finite distance, got {threshold!r}")
        self.threshold = float(threshold)
        self.reset()

    def reset(self) -> None:
        """Forget every frame (start a new episode)."""
        self._ids = np.zeros(0, dtype=np.int64)  # truth ids seen so far, sorted
        self._last = np.zeros(0, dtype=np.int64)  # last track id each truth id was matched to
        self._matched = np.zeros(0, dtype=bool)  # matched at least once (motmetrics: ``o in self.m``)
        self._gap = np.zeros(0, dtype=bool)  # missed since its last match (a fragmentation pending)
        self._n = dict.fromkeys(_COUNTS, 0)
        self._dist_sum = 0.0
        self._pairs = KeyCounter(2)  # (truth id, track id) per frame where the pair is possible
        self._truth_frames = KeyCounter(1)  # each truth id once per frame it appears in
        self._track_frames = KeyCounter(1)

    def update(
        self, truth: Mapping[str, NDArray], detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> None:
        """Add one frame from ``info["truth"]`` and the report (``detection_ids`` is unused).

        Raises:
            ValueError: if report positions are not points (n, D) matching the truth's D.
        """
        del detection_ids
        oids, x = live_truth(truth)
        hids, y, _ = live_report(report)
        if y.ndim != 2 or x.shape[1:] != y.shape[1:]:
            raise ValueError(
                "ClearMot scores point reports (max_tracks, D) against truth (max_targets, D); got report "
                f"positions {np.shape(report['positions'])} and truth {np.shape(truth['positions'])}"
            )
        d = pairwise_distances(x, y)
        d[d > self.threshold] = np.nan
        self.update_distances(oids, hids, d)

    def update_distances(
        self,
        truth_ids: ArrayLike,
        track_ids: ArrayLike,
        dist_matrix: ArrayLike,
    ) -> None:
        """Add one frame from ids and a distance matrix, like ``MOTAccumulator.update(oids, hids, dists)``.

        Args:
            truth_ids: (m,) integer truth (object) ids.
            track_ids: (n,) integer track (hypothesis) ids.
            dist_matrix: (m, n) distances, NaN (or inf) for pairs that may not match.
        """
        oids = np.asarray(truth_ids, dtype=np.int64).reshape(-1)
        hids = np.asarray(track_ids, dtype=np.int64).reshape(-1)
        no, nh = len(oids), len(hids)
        d = np.atleast_2d(np.asarray(dist_matrix, dtype=np.float64)).reshape(no, nh).copy()
        possible_i, possible_j = np.nonzero(np.isfinite(d))
        self._pairs.add(np.stack([oids[possible_i], hids[possible_j]], axis=1))
        unique_oids, unique_hids = np.unique(oids), np.unique(hids)
        self._truth_frames.add(unique_oids)
        self._track_frames.add(unique_hids)
        rows = self._rows(unique_oids, oids)
        if len(unique_oids) == no and len(unique_hids) == nh:
            mi, mj, switch = self._assign(rows, hids, d)
        else:
            mi, mj, switch = self._assign_rowwise(rows, hids, d)
        self._count(rows, mi, mj, switch, d, no, nh)

    def _rows(self, unique_oids: NDArray[np.int64], oids: NDArray[np.int64]) -> NDArray[np.intp]:
        """Rows of ``oids`` in the per-truth state (sorted by id), adding unseen ids first."""
        at = np.minimum(np.searchsorted(self._ids, unique_oids), max(len(self._ids) - 1, 0))
        known = self._ids[at] == unique_oids if len(self._ids) else np.zeros(len(unique_oids), dtype=bool)
        new = unique_oids[~known]
        if len(new):
            order = np.argsort(np.concatenate([self._ids, new]), kind="stable")
            self._ids = np.concatenate([self._ids, new])[order]
            self._last = np.concatenate([self._last, np.zeros(len(new), np.int64)])[order]
            self._matched = np.concatenate([self._matched, np.zeros(len(new), bool)])[order]
            self._gap = np.concatenate([self._gap, np.zeros(len(new), bool)])[order]
        return np.searchsorted(self._ids, oids)

    def _assign(
        self, rows: NDArray[np.intp], hids: NDArray[np.int64], d: NDArray[np.float64]
    ) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.bool_]]:
        """Matches of a frame with unique ids: (truth rows, track rows, is-switch), vectorised."""
        no, nh = d.shape
        if no == 0 or nh == 0:
            return np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0, bool)
        last, seen = self._last[rows], self._matched[rows]
        # 1. carry over: each truth's last track, if present and possible; the first row wins a track
        order = np.argsort(hids, kind="stable")
        pos = np.minimum(np.searchsorted(hids[order], last), nh - 1)
        cand = seen & (hids[order][pos] == last)
        cand_j = order[pos]
        cand[cand] = np.isfinite(d[np.flatnonzero(cand), cand_j[cand]])
        ci, cj = np.flatnonzero(cand), cand_j[cand]
        _, first = np.unique(cj, return_index=True)
        i1, j1 = ci[first], cj[first]
        # 2. min-cost assignment of the rest
        free_row = np.ones(no, dtype=bool)
        free_row[i1] = False
        free_col = np.ones(nh, dtype=bool)
        free_col[j1] = False
        free_i, free_j = np.flatnonzero(free_row), np.flatnonzero(free_col)
        i2, j2 = assign_like_motmetrics(d[np.ix_(free_i, free_j)])
        i2, j2 = free_i[i2], free_j[j2]
        switch = seen[i2] & (last[i2] != hids[j2])
        self._last[rows[i2]] = hids[j2]
        self._matched[rows[i2]] = True
        mi, mj = np.concatenate([i1, i2]), np.concatenate([j1, j2])
        return mi, mj, np.concatenate([np.zeros(len(i1), bool), switch])

    def _assign_rowwise(
        self, rows: NDArray[np.intp], hids: NDArray[np.int64], d: NDArray[np.float64]
    ) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.bool_]]:
        """Matches of a frame with duplicate ids, replaying motmetrics' loops row by row."""
        no, nh = d.shape
        mi: list[int] = []
        mj: list[int] = []
        switch: list[bool] = []
        if no == 0 or nh == 0:
            return np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0, bool)
        taken_j = np.zeros(nh, dtype=bool)
        for i, r in enumerate(rows):
            if not self._matched[r]:
                continue
            js = np.flatnonzero(~taken_j & (hids == self._last[r]))
            if len(js) and np.isfinite(d[i, js[0]]):
                taken_j[js[0]] = True
                mi.append(i)
                mj.append(int(js[0]))
                switch.append(False)
        free = d.copy()
        free[mi, :] = np.nan
        free[:, taken_j] = np.nan
        for i, j in zip(*assign_like_motmetrics(free), strict=True):
            r = rows[i]
            switch.append(bool(self._matched[r] and self._last[r] != hids[j]))
            self._last[r], self._matched[r] = hids[j], True
            mi.append(int(i))
            mj.append(int(j))
        return np.asarray(mi, np.intp), np.asarray(mj, np.intp), np.asarray(switch, bool)

    def _count(
        self,
        rows: NDArray[np.intp],
        mi: NDArray[np.intp],
        mj: NDArray[np.intp],
        switch: NDArray[np.bool_],
        d: NDArray[np.float64],
        no: int,
        nh: int,
    ) -> None:
        n = self._n
        n["frames"] += 1
        n["objects"] += no
        n["predictions"] += nh
        n["switches"] += int(switch.sum())
        n["matches"] += len(mi) - int(switch.sum())
        n["misses"] += no - len(mi)
        n["false_positives"] += nh - len(mj)
        self._dist_sum += float(d[mi, mj].sum())
        # fragmentation: a match after a miss that followed an earlier match (motmetrics' event order)
        hit = np.unique(rows[mi])
        n["frag"] += int(self._gap[hit].sum())
        self._gap[hit] = False
        missed = np.ones(no, dtype=bool)
        missed[mi] = False
        self._gap[rows[missed]] |= self._matched[rows[missed]]

    def _identity(self) -> tuple[int, int]:
        """(IDFN, IDFP) of the global one-to-one id matching that maximises IDTP."""
        pairs, together = self._pairs.counts()
        truth_frames = int(self._truth_frames.counts()[1].sum())
        track_frames = int(self._track_frames.counts()[1].sum())
        best = 0
        if len(pairs):
            _, oi = np.unique(pairs[:, 0], return_inverse=True)
            _, hi = np.unique(pairs[:, 1], return_inverse=True)
            best = max_weight_matching(oi.reshape(-1), hi.reshape(-1), together)
        return truth_frames - best, track_frames - best

    def compute(self) -> dict[str, float]:
        """CLEAR MOT and ID measures over every frame added (motmetrics' names and definitions).

        Returns:
            ``mota``, ``motp`` (mean match distance), ``id_switches``, ``idf1``, ``num_misses``,
            ``num_false_positives``, ``num_matches`` (matches that are not switches, as in
            motmetrics), ``num_objects`` (truth rows), plus ``num_predictions`` (track rows),
            ``num_detections`` (matches + switches), ``num_fragmentations``, ``num_frames``,
            ``idtp``, ``idfp``, ``idfn``, ``idp``, ``idr``. Ratios over zero are NaN (0 / 0) or
            ±inf, as numpy divides.
        """
        n = self._n
        idfn, idfp = self._identity()
        idtp = n["objects"] - idfn
        detections = n["matches"] + n["switches"]
        with np.errstate(divide="ignore", invalid="ignore"):
            errors = np.float64(n["misses"] + n["switches"] + n["false_positives"])
            mota = 1.0 - errors / np.float64(n["objects"])
            motp = np.float64(self._dist_sum) / np.float64(detections)
            idf1 = np.float64(2 * idtp) / np.float64(n["objects"] + n["predictions"])
            idp = np.float64(idtp) / np.float64(idtp + idfp)
            idr = np.float64(idtp) / np.float64(idtp + idfn)
        return {
            "mota": float(mota),
            "motp": float(motp),
            "id_switches": float(n["switches"]),
            "idf1": float(idf1),
            "num_misses": float(n["misses"]),
            "num_false_positives": float(n["false_positives"]),
            "num_matches": float(n["matches"]),
            "num_objects": float(n["objects"]),
            "num_predictions": float(n["predictions"]),
            "num_detections": float(detections),
            "num_fragmentations": float(n["frag"]),
            "num_frames": float(n["frames"]),
            "idtp": float(idtp),
            "idfp": float(idfp),
            "idfn": float(idfn),
            "idp": float(idp),
            "idr": float(idr),
        }
