"""CLEAR MOT (MOTA, MOTP, ID switches, fragmentations) and IDF1 on point distances.

CLEAR MOT: Bernardin, Stiefelhagen, "Evaluating Multiple Object Tracking Performance: the CLEAR
MOT Metrics", EURASIP JIVP 2008; with the event rules of py-motmetrics' ``MOTAccumulator.update``
(Heindl, Valmadre et al., https://github.com/cheind/py-motmetrics, v1.4), reproduced exactly:

1. a truth matched before keeps its last track if that track is in the frame and the pair is
   possible (distance not NaN); rows are tried in order, each track serves one truth;
2. the remaining truths and tracks are matched by a min-cost assignment (scipy
   ``linear_sum_assignment``, impossible pairs priced as motmetrics' ``add_expensive_edges``
   prices them, then dropped); a match whose track differs from the truth's last match is an
   ID switch (lone pairs,
   [`track_envs.infra.assignment.lone_pairs.split_lone_pairs`][track_envs.infra.assignment.lone_pairs.split_lone_pairs],
   are taken directly and the other components of the possible pairs solved one by one where their optimum is
   unique; [`track_envs.metrics.clear_mot_events`][track_envs.metrics.clear_mot_events] runs these rules per
   frame as one compiled kernel);
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

Merged detections (touching particles seen as one blob; ``detection_ids`` given as
(max_detections, K) merged ids): a track updated with a merged detection counts as correctly
placed for any particle behind it — it may match each of them within the threshold plus the
blob's spread, as [`track_envs.metrics.merged`][track_envs.metrics.merged] defines — so following either
particle through a merge is neither a miss nor a false positive, and IDF1 counts those frames as
co-occurrences.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from track_envs.infra.compiled import njit
from track_envs.metrics.base import MetricTraits, report_arrays, truth_arrays
from track_envs.metrics.clear_mot_events import COUNTERS, TRUTH_VALUES, frame_events
from track_envs.metrics.close_pairs import close_pairs, finite_entries
from track_envs.metrics.key_table import KeyTable
from track_envs.metrics.live_rows import live_report_rows, live_truth_rows
from track_envs.metrics.merged import as_merged, with_merged_pairs


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


@njit(cache=True)
def _points_frame(
    truth_ids: NDArray[np.int64],
    truth_positions: NDArray[np.float64],
    visible: NDArray[np.bool_],
    report_ids: NDArray[np.int64],
    report_positions: NDArray[np.float64],
    report_mask: NDArray[np.int8],
    threshold: float,
    truth_index: NDArray[np.int64],
    truth_entries: NDArray[np.int64],
    pair_index: NDArray[np.int64],
    pair_entries: NDArray[np.int64],
    counts: NDArray[np.int64],
    dist_sum: NDArray[np.float64],
) -> tuple[int, int]:
    """Events of a padded point frame; ``(frame_events' status, number of visible truths)``."""
    oids, x = live_truth_rows(truth_ids, truth_positions, visible)
    hids, y = live_report_rows(report_ids, report_positions, report_mask)
    ptr, cols, dist = close_pairs(x, y, threshold)
    status = frame_events(
        oids, hids, ptr, cols, dist, truth_index, truth_entries, pair_index, pair_entries, counts, dist_sum
    )
    return status, len(oids)


@njit(cache=True)
def _points_frame_merged(
    truth_ids: NDArray[np.int64],
    truth_positions: NDArray[np.float64],
    visible: NDArray[np.bool_],
    report_ids: NDArray[np.int64],
    report_positions: NDArray[np.float64],
    report_rows: NDArray[np.int64],
    report_mask: NDArray[np.int8],
    merged: NDArray[np.int64],
    threshold: float,
    truth_index: NDArray[np.int64],
    truth_entries: NDArray[np.int64],
    pair_index: NDArray[np.int64],
    pair_entries: NDArray[np.int64],
    counts: NDArray[np.int64],
    dist_sum: NDArray[np.float64],
) -> tuple[int, int]:
    """As [`_points_frame`][track_envs.metrics.clear_mot._points_frame], with the pairs of tracks updated with
    merged detections."""
    oids, x = live_truth_rows(truth_ids, truth_positions, visible)
    hids, y = live_report_rows(report_ids, report_positions, report_mask)
    keep = report_mask == 1
    live_rows = np.empty(len(hids), np.int64)
    t = 0
    for k in range(len(keep)):
        if keep[k]:
            live_rows[t] = report_rows[k]
            t += 1
    ptr, cols, dist = close_pairs(x, y, threshold)
    ptr, cols, dist = with_merged_pairs(x, oids, y, live_rows, merged, threshold, ptr, cols, dist)
    status = frame_events(
        oids, hids, ptr, cols, dist, truth_index, truth_entries, pair_index, pair_entries, counts, dist_sum
    )
    return status, len(oids)


class ClearMot:
    """Streaming CLEAR MOT and IDF1 of reports against the visible truth, with motmetrics parity.

    Per frame, a truth and a track can match when their Euclidean distance is at most
    ``threshold`` (as motmetrics' ``norm2squared_matrix`` with ``max_d2``: a pair exactly at the
    threshold is possible); only those pairs are ever formed
    (`close_pairs`).
    [`update_distances`][track_envs.metrics.ClearMot.update_distances] takes a distance matrix directly (NaN
    for impossible pairs) and produces the same events as ``motmetrics.MOTAccumulator.update``.

    Track ids in a frame are unique and non-negative by the report contract
    ([`track_envs.contracts.report.validate_report`][track_envs.contracts.validate_report]: a repeated id
    would let one identity claim several truths and inflate MOTA, so environments reject it). Fed a report
    that breaks the contract directly, rows sharing an id are scored as motmetrics scores them: separate
    hypotheses sharing the id's history.

    With merged detection ids (``info["detection_ids_merged"]``), a track updated with a merged
    detection may also match the blob's other particles (module docstring).

    Args:
        threshold: Largest distance, in sensor units, at which a track can match a truth.
    """

    traits = MetricTraits(needs_truth=True, accepts_merged_ids=True)

    def __init__(self, threshold: float) -> None:
        if not (np.isfinite(threshold) and threshold > 0):
            raise ValueError(f"ClearMot threshold must be a positive finite distance, got {threshold!r}")
        self.threshold = float(threshold)
        self.reset()

    def reset(self) -> None:
        """Forget every frame (start a new episode)."""
        self._truths = KeyTable(n_values=TRUTH_VALUES)  # per truth id: last, matched, gap, seen
        self._pairs = KeyTable(n_values=1)  # per (truth id, track id): frames the pair was possible
        self._counts = np.zeros(len(COUNTERS), dtype=np.int64)
        self._dist_sum = np.zeros(2)  # compensated sum of the match distances

    def update(
        self, truth: Mapping[str, NDArray], detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> None:
        """Add one frame from ``info["truth"]`` and the report.

        ``detection_ids`` matters only as merged ids (max_detections, K) with a merged detection
        in the frame; plain (max_detections,) ids are not needed (matching is by distance).

        Raises:
            ValueError: if report positions are not points (n, D) matching the truth's D.
        """
        truth_ids, x, visible = truth_arrays(truth)
        hids, y, rows, mask = report_arrays(report)
        merged = as_merged(detection_ids) if np.ndim(detection_ids) != 1 else None
        if merged is not None and merged.shape[1] < 2:
            merged = None  # (a frame without merged updates costs the merged kernel nothing more)
        if y.ndim != 2 or x.ndim != 2 or x.shape[1:] != y.shape[1:]:
            raise ValueError(
                "ClearMot scores point reports (max_tracks, D) against truth (max_targets, D); got report "
                f"positions {np.shape(report['positions'])} and truth {np.shape(truth['positions'])}"
            )
        truths, pairs = self._truths, self._pairs
        while True:
            if merged is None:
                status, m = _points_frame(
                    truth_ids,
                    x,
                    visible,
                    hids,
                    y,
                    mask,
                    self.threshold,
                    truths.index,
                    truths.entries,
                    pairs.index,
                    pairs.entries,
                    self._counts,
                    self._dist_sum,
                )
            else:
                status, m = _points_frame_merged(
                    truth_ids,
                    x,
                    visible,
                    hids,
                    y,
                    rows,
                    mask,
                    merged,
                    self.threshold,
                    truths.index,
                    truths.entries,
                    pairs.index,
                    pairs.entries,
                    self._counts,
                    self._dist_sum,
                )
            if status < 0:
                return
            truths.reserve(m)
            pairs.reserve(status)

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
        oids = np.ascontiguousarray(truth_ids, dtype=np.int64).reshape(-1)
        hids = np.ascontiguousarray(track_ids, dtype=np.int64).reshape(-1)
        no, nh = len(oids), len(hids)
        d = np.ascontiguousarray(np.atleast_2d(np.asarray(dist_matrix, dtype=np.float64)).reshape(no, nh))
        ptr, cols, dist = finite_entries(d)
        self.update_entries(oids, hids, ptr, cols, dist)

    def update_entries(
        self,
        truth_ids: ArrayLike,
        track_ids: ArrayLike,
        ptr: NDArray[np.int64],
        cols: NDArray[np.int64],
        dist: NDArray[np.float64],
    ) -> None:
        """Add one frame from ids and its possible pairs only, row-major: truth ``i``'s possible
        tracks are ``cols[ptr[i]:ptr[i + 1]]`` (ascending) at distances ``dist[ptr[i]:ptr[i + 1]]``
        (finite); every other pair is impossible. The same frame as
        [`update_distances`][track_envs.metrics.ClearMot.update_distances] of the matrix holding those
        distances and NaN elsewhere, at a cost linear in the pairs.
        """
        oids = np.ascontiguousarray(truth_ids, dtype=np.int64).reshape(-1)
        hids = np.ascontiguousarray(track_ids, dtype=np.int64).reshape(-1)
        ptr = np.ascontiguousarray(ptr, dtype=np.int64)
        cols = np.ascontiguousarray(cols, dtype=np.int64)
        dist = np.ascontiguousarray(dist, dtype=np.float64)
        if ptr.shape != (len(oids) + 1,) or cols.shape != dist.shape or ptr[-1] != len(cols):
            raise ValueError(
                f"ptr must be ({len(oids) + 1},) ending at len(cols) = len(dist); got ptr {ptr.shape}, "
                f"cols {cols.shape}, dist {dist.shape}"
            )
        self._truths.reserve(len(oids))
        self._pairs.reserve(len(cols))
        frame_events(
            oids,
            hids,
            ptr,
            cols,
            dist,
            self._truths.index,
            self._truths.entries,
            self._pairs.index,
            self._pairs.entries,
            self._counts,
            self._dist_sum,
        )

    def _identity(self) -> tuple[int, int]:
        """(IDFN, IDFP) of the global one-to-one id matching that maximises IDTP."""
        pairs, together = self._pairs.stored_keys(), self._pairs.stored_values()[:, 0]
        n = dict(zip(COUNTERS, self._counts.tolist(), strict=True))
        best = 0
        if len(pairs):
            _, oi = np.unique(pairs[:, 0], return_inverse=True)
            _, hi = np.unique(pairs[:, 1], return_inverse=True)
            best = max_weight_matching(oi.reshape(-1), hi.reshape(-1), together)
        return n["truth_frames"] - best, n["track_frames"] - best

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
        n = dict(zip(COUNTERS, self._counts.tolist(), strict=True))
        idfn, idfp = self._identity()
        idtp = n["objects"] - idfn
        detections = n["matches"] + n["switches"]
        with np.errstate(divide="ignore", invalid="ignore"):
            errors = np.float64(n["misses"] + n["switches"] + n["false_positives"])
            mota = 1.0 - errors / np.float64(n["objects"])
            motp = np.float64(self._dist_sum[0] + self._dist_sum[1]) / np.float64(detections)
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
