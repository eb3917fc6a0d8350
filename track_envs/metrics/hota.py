"""HOTA: Higher Order Tracking Accuracy, accumulated one frame at a time.

Luiten, Ošep, Dendorfer, Torr, Geiger, Leal-Taixé, Leibe, "HOTA: A Higher Order Metric for
Evaluating Multi-Object Tracking", IJCV 129 (2021). The input of a frame is the truth ids, the
tracker ids and a similarity ``S`` (n, m) in [0, 1] between them (IoU for boxes, OKS for poses,
``max(0, 1 − d/τ)`` for points); nothing else about the objects is needed.

**Matching.** The truth/tracker pairs are matched one-to-one in every frame, maximising the sum of

.. math::

    \\mathrm{score}_t(i, j) = A(g_i, k_j)\\, S_t(i, j),
    \\qquad
    A(g, k) = \\frac{P(g, k)}{N_g + N_k - P(g, k)},
    \\qquad
    P(g, k) = \\sum_t \\frac{S_t(i, j)}{\\sum_{j'} S_t(i, j') + \\sum_{i'} S_t(i', j) - S_t(i, j)},

where ``N_g``, ``N_k`` count the frames in which truth id ``g`` and tracker id ``k`` appear and
``P`` is the whole sequence's soft count of frames in which they are matched (a frame's term is
0 where its denominator is at most machine epsilon). ``A`` is a global alignment of identities,
so matching needs the whole sequence first:
[`HotaAccumulator.add_frame`][track_envs.metrics.HotaAccumulator.add_frame] stores each frame's non-zero
similarities and ``P``, and [`HotaAccumulator.compute`][track_envs.metrics.HotaAccumulator.compute] runs the
per-frame Hungarian assignments (as the authors' TrackEval does).

**Scores at a threshold α.** A matched pair is a true positive (TP) at α when ``S ≥ α − ε``
(machine epsilon); the other truth and tracker rows are misses (FN) and false positives (FP).
With ``c_α(g, k)`` the number of TPs between ``g`` and ``k`` and ``|·|`` counts summed over the
sequence,

.. math::

    \\mathrm{DetRe}_α = \\frac{|TP|}{|TP| + |FN|},\\;
    \\mathrm{DetPr}_α = \\frac{|TP|}{|TP| + |FP|},\\;
    \\mathrm{DetA}_α = \\frac{|TP|}{|TP| + |FN| + |FP|},

.. math::

    \\mathrm{AssA}_α = \\frac{1}{|TP|} \\sum_{(g,k)} c_α(g,k)\\, \\frac{c_α(g,k)}{N_g + N_k - c_α(g,k)},\\;
    \\mathrm{AssRe}_α = \\frac{1}{|TP|} \\sum c_α \\frac{c_α}{N_g},\\;
    \\mathrm{AssPr}_α = \\frac{1}{|TP|} \\sum c_α \\frac{c_α}{N_k},

``HOTA_α = sqrt(DetA_α · AssA_α)`` and ``LocA_α`` the mean similarity of the TPs. Every
denominator is floored at 1 (LocA's sum and count at 1e-10, so LocA is 1 with no TP), as in
TrackEval. The reported figures are the means over α = 0.05, 0.10, …, 0.95 (19 values).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

from track_envs.metrics.hota_matching import (
    column_sums,
    distinct_count,
    frame_matches,
    row_sums,
    unique_inverse,
)

#: The 19 localisation thresholds α = 0.05, 0.10, …, 0.95 (the same floats as TrackEval's).
ALPHAS: NDArray[np.float64] = np.arange(0.05, 0.99, 0.05)

#: The α-averaged figures [`HotaAccumulator.compute`][track_envs.metrics.HotaAccumulator.compute] returns, in
#: this order.
HOTA_FIELDS: tuple[str, ...] = ("HOTA", "DetA", "AssA", "LocA", "DetRe", "DetPr", "AssRe", "AssPr")

_EPS = float(np.finfo(float).eps)

#: A frame's optimum is taken component by component when unique by this margin (times
#: ``max(1, (n + m)/1024)``), far above the rounding of scipy's solver on the dense matrix
#: (about ``(n + m) ε``); see [`hota_matching`][track_envs.metrics.hota_matching].
_TIE_MARGIN = 2.0**-30

#: A frame with a (near) tie is solved on its dense matrix, as TrackEval solves it, when the matrix
#: has at most this many entries (a 2,048 × 2,048 frame, 32 MiB); a larger frame's ties are broken
#: component by component ([`hota_matching`][track_envs.metrics.hota_matching]).
DENSE_LIMIT = 2048 * 2048

#: Matched pairs: dense truth ids, dense tracker ids, frame counts per dense truth and tracker id,
#: number of tracker ids, similarities.
_Matches = tuple[
    NDArray[np.int64], NDArray[np.int64], NDArray[np.float64], NDArray[np.float64], int, NDArray[np.float64]
]


class HotaAccumulator:
    """Streaming HOTA of one sequence: feed frames with
    [`add_frame`][track_envs.metrics.HotaAccumulator.add_frame], summarise with
    [`compute`][track_envs.metrics.HotaAccumulator.compute].

    Ids are any integers (unique within a frame); similarities are in [0, 1]. Memory grows with
    the number of non-zero similarities (and of rows) seen, not with the number of ids squared.
    [`compute`][track_envs.metrics.HotaAccumulator.compute] matches each frame component by component of its
    non-zero similarities where the optimum is unique, and solves the frame's dense matrix with scipy's
    ``linear_sum_assignment`` only on a (near) tie, so the pairs are TrackEval's
    (`hota_matching`); it counts the 19 thresholds at once from each
    matched pair's similarity. [`add_sparse_frame`][track_envs.metrics.HotaAccumulator.add_sparse_frame] takes
    a frame as its non-zero entries (the streaming metrics build them through a spatial index), at a cost
    linear in them.

    Example::

        acc = HotaAccumulator()
        for gt_ids, tracker_ids, similarity in frames:
            acc.add_frame(gt_ids, tracker_ids, similarity)
        acc.compute()["HOTA"]
    """

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget every frame (start a new sequence)."""
        self._gt_ids: list[NDArray[np.int64]] = []
        self._tr_ids: list[NDArray[np.int64]] = []
        # Non-zero similarity entries: frame, row, column, similarity, per-frame soft match.
        self._rows: list[NDArray[np.int64]] = []
        self._cols: list[NDArray[np.int64]] = []
        self._sims: list[NDArray[np.float64]] = []
        self._soft: list[NDArray[np.float64]] = []
        self._frames = 0

    @property
    def n_frames(self) -> int:
        """Frames added since the last reset."""
        return self._frames

    def add_frame(self, gt_ids: ArrayLike, tracker_ids: ArrayLike, similarity: ArrayLike) -> None:
        """Add one frame.

        Args:
            gt_ids: (n,) integer truth ids present in the frame, unique.
            tracker_ids: (m,) integer tracker ids present in the frame, unique.
            similarity: (n, m) similarities in [0, 1] (row ``i`` is ``gt_ids[i]``).
        """
        gt = _ids(gt_ids, "gt_ids")
        tr = _ids(tracker_ids, "tracker_ids")
        sim = np.asarray(similarity, dtype=np.float64)
        if sim.shape != (gt.size, tr.size):
            raise ValueError(
                f"similarity has shape {sim.shape}; it must be (len(gt_ids), len(tracker_ids)) = "
                f"({gt.size}, {tr.size})"
            )
        if sim.size and not (sim.min() >= 0.0 and sim.max() <= 1.0):  # NaN fails both
            bad = sim[~((sim >= 0.0) & (sim <= 1.0))][0]
            raise ValueError(f"similarity values must be in [0, 1]; got {float(bad)}")
        rows, cols = np.nonzero(sim)
        values = sim[rows, cols]
        # Soft match S / (column sum + row sum − S), 0 where that denominator is <= eps (the
        # operations in TrackEval's order, so P sums the very same floats).
        denominator = sim.sum(0)[cols] + sim.sum(1)[rows] - values
        rows64, cols64 = rows.astype(np.int64, copy=False), cols.astype(np.int64, copy=False)
        self._store(gt, tr, rows64, cols64, values, denominator)

    def add_sparse_frame(
        self, gt_ids: ArrayLike, tracker_ids: ArrayLike, rows: ArrayLike, cols: ArrayLike, values: ArrayLike
    ) -> None:
        """Add one frame given by its non-zero similarities: the same as
        [`add_frame`][track_envs.metrics.HotaAccumulator.add_frame] of the (n, m) matrix that holds ``values``
        at ``(rows, cols)`` and 0 elsewhere, bit for bit, at a cost linear in the entries and ids
        (`hota_matching`).

        Args:
            gt_ids: (n,) integer truth ids present in the frame, unique.
            tracker_ids: (m,) integer tracker ids present in the frame, unique.
            rows: (e,) row of each entry (into ``gt_ids``), row-major: ``(rows, cols)`` strictly
                ascending in lexicographic order.
            cols: (e,) column of each entry (into ``tracker_ids``).
            values: (e,) similarities in [0, 1] (zeros are dropped).
        """
        gt = _ids(gt_ids, "gt_ids")
        tr = _ids(tracker_ids, "tracker_ids")
        r = np.ascontiguousarray(rows, dtype=np.int64)
        c = np.ascontiguousarray(cols, dtype=np.int64)
        v = np.ascontiguousarray(values, dtype=np.float64)
        if not (r.ndim == c.ndim == v.ndim == 1 and r.size == c.size == v.size):
            raise ValueError(
                f"rows, cols and values must be 1-D of one length; got {r.shape}, {c.shape}, {v.shape}"
            )
        if r.size:
            if r.min() < 0 or r.max() >= gt.size or c.min() < 0 or c.max() >= tr.size:
                raise ValueError(
                    f"entries must lie in the ({gt.size}, {tr.size}) matrix; got rows in "
                    f"[{int(r.min())}, {int(r.max())}] and cols in [{int(c.min())}, {int(c.max())}]"
                )
            flat = r * tr.size + c
            if np.any(flat[1:] <= flat[:-1]):
                at = int(np.flatnonzero(flat[1:] <= flat[:-1])[0]) + 1
                raise ValueError(
                    f"entries must be row-major without repeats; entry {at} ({int(r[at])}, {int(c[at])}) "
                    f"follows ({int(r[at - 1])}, {int(c[at - 1])})"
                )
            if not (v.min() >= 0.0 and v.max() <= 1.0):  # NaN fails both
                bad = v[~((v >= 0.0) & (v <= 1.0))][0]
                raise ValueError(f"similarity values must be in [0, 1]; got {float(bad)}")
            nonzero = v != 0.0
            if not nonzero.all():
                r, c, v = r[nonzero], c[nonzero], v[nonzero]
        denominator = column_sums(c, v, tr.size)[c] + row_sums(r, c, v, gt.size, tr.size)[r] - v
        self._store(gt, tr, r, c, v, denominator)

    def _store(
        self,
        gt: NDArray[np.int64],
        tr: NDArray[np.int64],
        rows: NDArray[np.int64],
        cols: NDArray[np.int64],
        values: NDArray[np.float64],
        denominator: NDArray[np.float64],
    ) -> None:
        """Keep a frame's non-zero entries and their soft matches (0 where the denominator <= eps)."""
        ok = denominator > _EPS
        soft = np.divide(values, denominator, out=np.zeros_like(values), where=ok)
        self._gt_ids.append(gt)
        self._tr_ids.append(tr)
        self._rows.append(rows)
        self._cols.append(cols)
        self._sims.append(values)
        self._soft.append(soft)
        self._frames += 1

    def compute_arrays(self) -> dict[str, NDArray[np.float64]]:
        """The per-α figures: each of `HOTA_FIELDS` and ``HOTA_TP``,
        ``HOTA_FN``, ``HOTA_FP`` as (19,) arrays over `ALPHAS`."""
        n_alpha = ALPHAS.size
        n_gt = sum(f.size for f in self._gt_ids)
        n_tr = sum(f.size for f in self._tr_ids)
        tp: NDArray[np.float64] = np.zeros(n_alpha)
        loc_sum: NDArray[np.float64] = np.zeros(n_alpha)
        ass = {name: np.zeros(n_alpha) for name in ("AssA", "AssRe", "AssPr")}
        matched = self._matches()
        if matched is not None:
            gt_dense, tr_dense, gt_count, tr_count, n_tr_ids, pair_sim = matched
            # A TP at α_a for every a < passes: α ascend, so a pair passes a prefix of them.
            passes = np.searchsorted(ALPHAS - _EPS, pair_sim, side="right")
            hist = np.bincount(passes, minlength=n_alpha + 1).astype(np.float64)
            tp = np.cumsum(hist[::-1])[::-1][1:]
            loc_hist = np.bincount(passes, weights=pair_sim, minlength=n_alpha + 1).astype(np.float64)
            loc_sum = np.cumsum(loc_hist[::-1])[::-1][1:]
            # c_α(g, k): TP counts per id pair and α.
            keys, key_of = unique_inverse(gt_dense * n_tr_ids + tr_dense)
            by_pass = np.zeros((keys.size, n_alpha + 1))
            np.add.at(by_pass, (key_of, passes), 1.0)
            counts = np.cumsum(by_pass[:, ::-1], axis=1)[:, ::-1][:, 1:]  # (pairs, α)
            n_g = gt_count[keys // n_tr_ids][:, np.newaxis]
            n_k = tr_count[keys % n_tr_ids][:, np.newaxis]
            weight = np.maximum(1.0, tp)
            ass["AssA"] = np.sum(counts * (counts / np.maximum(1.0, n_g + n_k - counts)), axis=0) / weight
            ass["AssRe"] = np.sum(counts * (counts / np.maximum(1.0, n_g)), axis=0) / weight
            ass["AssPr"] = np.sum(counts * (counts / np.maximum(1.0, n_k)), axis=0) / weight
        fn = n_gt - tp
        fp = n_tr - tp
        det_a = tp / np.maximum(1.0, tp + fn + fp)
        return {
            "HOTA": np.sqrt(det_a * ass["AssA"]),
            "DetA": det_a,
            "AssA": ass["AssA"],
            "LocA": np.maximum(1e-10, loc_sum) / np.maximum(1e-10, tp),
            "DetRe": tp / np.maximum(1.0, tp + fn),
            "DetPr": tp / np.maximum(1.0, tp + fp),
            "AssRe": ass["AssRe"],
            "AssPr": ass["AssPr"],
            "HOTA_TP": tp,
            "HOTA_FN": fn,
            "HOTA_FP": fp,
        }

    def compute(self) -> dict[str, float]:
        """The `HOTA_FIELDS` averaged over the 19 α (does not reset).
        With no frame, or no truth or no tracker row at all, HOTA, DetA, AssA and the rest are 0 and LocA is
        1."""
        arrays = self.compute_arrays()
        return {name: float(np.mean(arrays[name])) for name in HOTA_FIELDS}

    def _matches(
        self,
    ) -> (
        tuple[
            NDArray[np.int64],
            NDArray[np.int64],
            NDArray[np.float64],
            NDArray[np.float64],
            int,
            NDArray[np.float64],
        ]
        | None
    ):
        """Per-frame optimal assignments. Returns the dense truth and tracker id of every matched
        pair with non-zero similarity, the frame counts per dense id, the number of tracker ids and
        the pairs' similarities; None when no similarity is non-zero."""
        if not self._frames:
            return None
        sims = np.concatenate(self._sims)
        if not sims.size:
            return None
        gt_sizes = np.fromiter((f.size for f in self._gt_ids), np.int64, self._frames)
        tr_sizes = np.fromiter((f.size for f in self._tr_ids), np.int64, self._frames)
        entries = np.fromiter((f.size for f in self._sims), np.int64, self._frames)
        gt_values, gt_dense_rows = unique_inverse(np.concatenate(self._gt_ids))
        tr_values, tr_dense_rows = unique_inverse(np.concatenate(self._tr_ids))
        n_tr_ids = tr_values.size
        gt_count = np.bincount(gt_dense_rows, minlength=gt_values.size).astype(np.float64)
        tr_count = np.bincount(tr_dense_rows, minlength=n_tr_ids).astype(np.float64)
        gt_start = np.concatenate(([0], np.cumsum(gt_sizes)[:-1]))
        tr_start = np.concatenate(([0], np.cumsum(tr_sizes)[:-1]))
        frame = np.repeat(np.arange(self._frames), entries)
        rows = np.concatenate(self._rows)
        cols = np.concatenate(self._cols)
        g = gt_dense_rows[gt_start[frame] + rows]
        k = tr_dense_rows[tr_start[frame] + cols]
        # Global alignment A(g, k) over the id pairs that ever have a non-zero similarity; the
        # soft counts are summed in frame order (bincount adds in input order).
        keys, key_of = unique_inverse(g * n_tr_ids + k)
        soft_count = np.bincount(key_of, weights=np.concatenate(self._soft), minlength=keys.size)
        alignment = soft_count / (gt_count[keys // n_tr_ids] + tr_count[keys % n_tr_ids] - soft_count)
        score = alignment[key_of] * sims
        # Each frame's matching, component by component where the optimum is unique; a frame
        # with a (near) tie is solved on its dense matrix as TrackEval solves it.
        entry_start = np.concatenate(([0], np.cumsum(entries)))
        tol = _TIE_MARGIN * max(1.0, float(gt_sizes.max() + tr_sizes.max()) / 1024.0)
        take, dense_frames = frame_matches(
            entry_start, rows, cols, score, gt_sizes, tr_sizes, tol, DENSE_LIMIT
        )
        for t in np.flatnonzero(dense_frames):
            lo, hi = entry_start[t], entry_start[t + 1]
            take[lo:hi] = False
            take[_dense_matches(rows[lo:hi], cols[lo:hi], score[lo:hi], gt_sizes[t], tr_sizes[t]) + lo] = True
        return g[take], k[take], gt_count, tr_count, n_tr_ids, sims[take]


def _dense_matches(
    rows: NDArray[np.int64], cols: NDArray[np.int64], score: NDArray[np.float64], n_rows: int, n_cols: int
) -> NDArray[np.int64]:
    """The entries (positions in ``rows``) matched by scipy's assignment of the frame's dense
    ``−score`` matrix (zeros off the entries), as TrackEval matches a frame."""
    dense = np.zeros((n_rows, n_cols))
    dense[rows, cols] = score
    match_rows, match_cols = linear_sum_assignment(-dense)
    lookup = np.full((n_rows, n_cols), -1, dtype=np.int64)
    lookup[rows, cols] = np.arange(rows.size)
    chosen = lookup[match_rows, match_cols]
    return chosen[chosen >= 0]


def _ids(values: ArrayLike, name: str) -> NDArray[np.int64]:
    """``values`` as a 1-D int64 array of unique ids, or a ValueError naming ``name``."""
    ids = np.asarray(values)
    if ids.ndim != 1:
        raise ValueError(f"{name} must be 1-D; got shape {ids.shape}")
    if ids.size and ids.dtype.kind not in "iu":
        raise ValueError(f"{name} must be integers; got dtype {ids.dtype}")
    ids = np.ascontiguousarray(ids, dtype=np.int64)
    if ids.size > 1 and distinct_count(ids) < ids.size:  # (a hash: linear; the sort names the id)
        ordered = np.sort(ids)
        repeated = ordered[1:][ordered[1:] == ordered[:-1]]
        if repeated.size:
            raise ValueError(f"{name} must be unique within a frame; {int(repeated[0])} appears twice")
    return ids
