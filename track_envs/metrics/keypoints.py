"""Keypoint (pose) metrics: COCO OKS and PoseTrack-style per-keypoint MOTA.

**OKS** (COCO keypoint evaluation; Ronchi & Perona, "Benchmarking and Error Diagnosis in
Multi-Instance Pose Estimation", ICCV 2017). For a truth pose ``g`` with visibility ``v_k``, object
area ``A`` and a detected pose ``x``,

.. math::

    \\mathrm{OKS} = \\frac{1}{|\\{k: v_k > 0\\}|} \\sum_{k: v_k > 0}
    \\exp\\Big(-\\frac{\\lVert x_k - g_k \\rVert^2}{2 A \\kappa_k^2}\\Big), \\qquad \\kappa_k = 2\\sigma_k,

with the 17 COCO sigmas [`COCO_SIGMAS`][track_envs.metrics.keypoints.COCO_SIGMAS].
[`oks`][track_envs.metrics.oks] reproduces ``pycocotools.cocoeval.COCOeval.computeOks`` bit for bit on the
same arrays, including its rule for a truth without labelled keypoints (distance to a box twice the truth's
bounding box).

**Per-keypoint MOTA** (PoseTrack; Andriluka et al., "PoseTrack: A Benchmark for Human Pose
Estimation and Tracking", CVPR 2018, evaluated with the ``poseval`` tool): every keypoint type
``k`` is tracked as its own set of point targets. In a frame, the truths of type ``k`` are the
people whose keypoint ``k`` is visible, the hypotheses are the reported tracks (every reported
keypoint counts as predicted), and a pair may match when the PCKh criterion holds,
``‖x_k − g_k‖ ≤ 0.5 · head_size``. CLEAR MOT events (matches, misses, false positives, ID switches)
are counted per type with py-motmetrics' rules ([`ClearMot`][track_envs.metrics.ClearMot]), and

.. math::

    \\mathrm{MOTA}_k = 1 - \\frac{\\mathrm{FN}_k + \\mathrm{FP}_k + \\mathrm{IDSW}_k}{\\mathrm{GT}_k}, \\qquad
    \\mathrm{MOTA} = 1 - \\frac{\\sum_k (\\mathrm{FN}_k + \\mathrm{FP}_k + \\mathrm{IDSW}_k)}
        {\\sum_k \\mathrm{GT}_k}.

The nose's switches are reported on their own (Okada et al. 2020, Table II, uses the nose's
``num_switches`` as its tracking-error measure). The head size comes from the truth:
``info["truth"]["head_size"]`` when present (the environment's PoseTrack-style head size, 0.6 × the
head box diagonal), else ``head_fraction · scale``.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

from track_envs.metrics.base import MetricTraits, live_report
from track_envs.metrics.clear_mot import ClearMot
from track_envs.values.keypoints import KEYPOINT_NAMES

NUM_KEYPOINTS = 17

#: Per-keypoint OKS sigmas of the COCO keypoint evaluation (pycocotools ``kpt_oks_sigmas``).
COCO_SIGMAS: NDArray[np.float64] = (
    np.array(
        [0.26, 0.25, 0.25, 0.35, 0.35, 0.79, 0.79, 0.72, 0.72, 0.62, 0.62, 1.07, 1.07, 0.87, 0.87, 0.89, 0.89]
    )
    / 10.0
)

#: Keypoint groups of PoseTrack tables (Okada et al. 2020, Table I): head, shoulders, elbows, ...
KEYPOINT_GROUPS: dict[str, tuple[int, ...]] = {
    "head": (0, 1, 2, 3, 4),
    "shoulders": (5, 6),
    "elbows": (7, 8),
    "wrists": (9, 10),
    "hips": (11, 12),
    "knees": (13, 14),
    "ankles": (15, 16),
}

_EPS = np.spacing(1)


def oks(
    truth: ArrayLike,
    truth_visible: ArrayLike,
    area: ArrayLike,
    detections: ArrayLike,
    truth_bbox: ArrayLike | None = None,
    sigmas: ArrayLike = COCO_SIGMAS,
) -> NDArray[np.float64]:
    """OKS of every detected pose against every truth pose, as ``COCOeval.computeOks``.

    Args:
        truth: Truth keypoints (m, K, 2).
        truth_visible: (m, K) visibility (``v > 0`` counts, as COCO's ``v ∈ {1, 2}``).
        area: (m,) object areas ``A`` (px²).
        detections: Detected keypoints (n, K, 2).
        truth_bbox: (m, 4) truth boxes ``x, y, w, h``, used only for truths without visible
            keypoints (pycocotools' rule); without it such truths score 0.
        sigmas: (K,) per-keypoint sigmas (default COCO).

    Returns:
        (n, m) OKS values in [0, 1], rows detections, columns truths (pycocotools' orientation).
    """
    g = np.asarray(truth, dtype=np.float64)
    d = np.asarray(detections, dtype=np.float64)
    vis: NDArray[np.bool_] = np.asarray(np.asarray(truth_visible) > 0, dtype=bool)
    s = np.asarray(sigmas, dtype=np.float64)
    var = (2 * s) ** 2
    denom = var * (np.asarray(area, dtype=np.float64)[None, :, None] + _EPS) * 2  # (1, m, K)
    dx = d[:, None, :, 0] - g[None, :, :, 0]  # (n, m, K)
    dy = d[:, None, :, 1] - g[None, :, :, 1]
    if truth_bbox is not None:
        bb = np.asarray(truth_bbox, dtype=np.float64)
        x0, x1 = bb[:, 0] - bb[:, 2], bb[:, 0] + bb[:, 2] * 2
        y0, y1 = bb[:, 1] - bb[:, 3], bb[:, 1] + bb[:, 3] * 2
        bx = np.maximum(0, x0[None, :, None] - d[:, None, :, 0]) + np.maximum(
            0, d[:, None, :, 0] - x1[None, :, None]
        )
        by = np.maximum(0, y0[None, :, None] - d[:, None, :, 1]) + np.maximum(
            0, d[:, None, :, 1] - y1[None, :, None]
        )
        none = np.asarray(~vis.any(axis=1), dtype=bool)
        dx = np.where(none[None, :, None], bx, dx)
        dy = np.where(none[None, :, None], by, dy)
    e = (dx**2 + dy**2) / denom
    k1 = vis.sum(axis=1)  # (m,)
    weight = np.where(k1[:, None] > 0, vis, truth_bbox is not None)  # (m, K)
    count = np.where(k1 > 0, k1, vis.shape[1] if truth_bbox is not None else 1)
    return np.sum(np.exp(-e) * weight[None], axis=2) / count[None, :]


def pairwise_oks(
    a: ArrayLike,
    b: ArrayLike,
    b_valid: ArrayLike,
    area: ArrayLike,
    a_valid: ArrayLike | None = None,
    sigmas: ArrayLike = COCO_SIGMAS,
) -> NDArray[np.float64]:
    """OKS between poses ``a`` (n, K, 2) and poses ``b`` (m, K, 2) over the keypoints valid in both.

    Args:
        a: Reference poses (n, K, 2), e.g. the predicted poses of tracks.
        b: Poses (m, K, 2), e.g. detections.
        b_valid: (m, K) bool, the keypoints of ``b`` that count.
        area: (m,) object areas of ``b`` (px²).
        a_valid: (n, K) bool, the keypoints of ``a`` that count (default all).

    Returns:
        (n, m) OKS, the mean over the keypoints valid in both poses of a pair, 0 for a pair with
            none: `paired_oks` of every detection against every
            pose of ``a`` (broadcast views, one batched expression, no Python loop over pairs or keypoints).
    """
    x = np.asarray(a, dtype=np.float64)
    m = len(np.asarray(b))
    x_valid = np.ones(x.shape[:2], dtype=bool) if a_valid is None else np.asarray(a_valid, dtype=bool)
    every = (m, *x.shape)  # each detection against every pose of ``a``: the pairs of paired_oks
    oks = paired_oks(np.broadcast_to(x, every), np.broadcast_to(x_valid, every[:3]), b, b_valid, area, sigmas)
    return np.ascontiguousarray(oks.T)


def paired_oks(
    a: ArrayLike,
    a_valid: ArrayLike,
    b: ArrayLike,
    b_valid: ArrayLike,
    area: ArrayLike,
    sigmas: ArrayLike = COCO_SIGMAS,
) -> NDArray[np.float64]:
    """OKS of the poses ``a`` (c, P, K, 2) of row ``r`` against the one pose ``b[r]`` (c, K, 2): the
    pairs one chooses ([`pairwise_oks`][track_envs.metrics.pairwise_oks] is this over every pair), one batched
    expression.

    Args:
        a: (c, P, K, 2) poses, ``P`` per row (e.g. the particles of one filter).
        a_valid: (c, P, K) keypoints of ``a`` that count.
        b: (c, K, 2) one pose per row (e.g. a detection).
        b_valid: (c, K) keypoints of ``b`` that count.
        area: (c,) object areas of ``b`` (px²).

    Returns:
        (c, P) OKS.
    """
    x = np.asarray(a, dtype=np.float64)
    y = np.asarray(b, dtype=np.float64)
    valid = np.asarray(b_valid, dtype=bool)[:, None] & np.asarray(a_valid, dtype=bool)  # (c, P, K)
    var = (2 * np.asarray(sigmas, dtype=np.float64)) ** 2
    d2 = np.sum((x - y[:, None]) ** 2, axis=-1)  # (c, P, K)
    e = d2 / (var * 2 * (np.asarray(area, dtype=np.float64)[:, None] + _EPS))[:, None]
    count = np.maximum(valid.sum(axis=2), 1)
    return np.sum(np.exp(-e) * valid, axis=2) / count


def oks_upper_bound(
    low: NDArray[np.floating],
    high: NDArray[np.floating],
    box_valid: NDArray[np.bool_],
    b: NDArray[np.floating],
    b_valid: NDArray[np.bool_],
    area: NDArray[np.floating],
    sigmas: ArrayLike = COCO_SIGMAS,
) -> NDArray[np.float64]:
    """(n, m) upper bound of the OKS of any pose whose keypoints lie in boxes against poses ``b``.

    Row ``i`` stands for a set of poses (the particles of one filter) whose keypoint ``k`` lies in
    the box ``low[i, k] … high[i, k]`` (n, K, 2) wherever it is valid (``box_valid`` (n, K): some
    pose of the set has it). An OKS is the mean of ``exp(−e_k)`` over the keypoints both poses
    hold, so it is at most the largest ``exp(−e_k)``, and ``e_k`` is at least that of the point
    of the box nearest to ``b``'s keypoint: the bound is ``max_k exp(−d²_k / (2 A (2σ_k)²))`` over
    the keypoints valid in both, ``d_k`` the distance from ``b``'s keypoint to the box (0 inside),
    and 0 for a pair with no such keypoint.
    """
    y = np.asarray(b, dtype=np.float64)[None]  # (1, m, K, 2)
    lo, hi = np.asarray(low, dtype=np.float64)[:, None], np.asarray(high, dtype=np.float64)[:, None]
    gap = np.maximum(lo - y, 0.0) + np.maximum(y - hi, 0.0)  # (n, m, K, 2)
    d2 = np.sum(gap**2, axis=-1)
    var = (2 * np.asarray(sigmas, dtype=np.float64)) ** 2
    e = d2 / (var * 2 * (np.asarray(area, dtype=np.float64)[:, None] + _EPS))[None]
    valid = np.asarray(box_valid, dtype=bool)[:, None] & np.asarray(b_valid, dtype=bool)[None]
    return np.max(np.where(valid, np.exp(-e), 0.0), axis=2, initial=0.0)


def truth_poses(truth: Mapping[str, NDArray]) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Ids (m,), keypoints (m, 17, 2), keypoint visibility (m, 17), scale (m,) of the visible truths."""
    ids = np.asarray(truth["ids"], dtype=np.int64)
    keep = (ids >= 0) & np.asarray(truth["visible"], dtype=bool)
    kp = np.asarray(truth["keypoints"] if "keypoints" in truth else truth["positions"], dtype=np.float64)
    if kp.ndim != 3 or kp.shape[1:] != (NUM_KEYPOINTS, 2):
        raise ValueError(f"keypoint metrics need truth keypoints (max_targets, 17, 2), got {kp.shape}")
    return (
        ids[keep],
        kp[keep],
        np.asarray(truth["keypoint_visible"], dtype=bool)[keep],
        np.asarray(truth["scale"])[keep],
    )


def report_poses(report: Mapping[str, NDArray]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    ids, pos, _ = live_report(report)
    if pos.ndim != 3 or pos.shape[1:] != (NUM_KEYPOINTS, 2):
        raise ValueError(
            f"keypoint metrics need report positions (max_tracks, 17, 2), got {np.shape(report['positions'])}"
        )
    return ids, pos


class KeypointMota:
    """Streaming PoseTrack-style per-keypoint MOTA with PCKh matching (see the module docstring).

    A report cannot leave a keypoint out (positions are (max_tracks, 17, 2)), where a PoseTrack
    submission omits its low-score keypoints. So, per frame, reported poses and visible truth
    people are first assigned one-to-one, maximising the number of PCKh-matched keypoints (as
    poseval assigns people); a reported keypoint whose assigned person has that keypoint hidden
    is left out of that keypoint's hypotheses ("don't care"). Reported poses assigned to no one
    count with all 17 keypoints. Track ids in a frame are unique and non-negative by the report
    contract ([`track_envs.contracts.report.validate_report`][track_envs.contracts.validate_report]); rows
    that share an id anyway are scored as [`ClearMot`][track_envs.metrics.ClearMot] scores them (distinct
    hypotheses sharing the id's history).

    Args:
        pckh: Match threshold as a fraction of the head size (PoseTrack: 0.5).
        head_fraction: Head size as a fraction of ``truth["scale"]`` when the truth has no
            ``"head_size"``.
        ignore_hidden: A reported keypoint whose person is hidden there is not a false positive
            (see the class docstring); ``False`` counts every reported keypoint as a hypothesis.
    """

    traits = MetricTraits(needs_truth=True)

    def __init__(self, pckh: float = 0.5, head_fraction: float = 0.1, ignore_hidden: bool = True) -> None:
        if not (np.isfinite(pckh) and pckh > 0):
            raise ValueError(f"pckh must be a positive finite fraction of the head size, got {pckh!r}")
        if not (np.isfinite(head_fraction) and head_fraction > 0):
            raise ValueError(f"head_fraction must be positive and finite, got {head_fraction!r}")
        self.pckh = float(pckh)
        self.head_fraction = float(head_fraction)
        self.ignore_hidden = bool(ignore_hidden)
        self.reset()

    def reset(self) -> None:
        """Forget every frame (start a new episode)."""
        self._per_kp = [ClearMot(threshold=1.0) for _ in range(NUM_KEYPOINTS)]

    def update(
        self, truth: Mapping[str, NDArray], detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> None:
        """Add one frame (``detection_ids`` is unused)."""
        del detection_ids
        oids, g, vis, scale = truth_poses(truth)
        keep = np.asarray(truth["ids"]) >= 0
        keep &= np.asarray(truth["visible"], dtype=bool)
        if "head_size" in truth:
            head = np.asarray(truth["head_size"], dtype=np.float64)[keep]
        else:
            head = self.head_fraction * np.asarray(scale, dtype=np.float64)
        hids, x = report_poses(report)
        # normalised distances (m, n, K); NaN where the PCKh criterion fails
        d = np.linalg.norm(g[:, None] - x[None], axis=-1) / np.maximum(head, _EPS)[:, None, None]
        d[d > self.pckh] = np.nan
        counted = np.ones((len(hids), NUM_KEYPOINTS), dtype=bool)
        if self.ignore_hidden and len(g) and len(x):
            # person-level assignment (most PCKh-matched visible keypoints, as poseval's), then the
            # hidden keypoints of the assigned truth are "don't care" for the assigned track
            hits = np.sum(np.isfinite(d) & vis[:, None, :], axis=2)
            ti, hi = linear_sum_assignment(hits, maximize=True)
            keep = hits[ti, hi] > 0
            counted[hi[keep]] = vis[ti[keep]]
        for k, acc in enumerate(self._per_kp):
            rows, cols = vis[:, k], counted[:, k]
            acc.update_distances(oids[rows], hids[cols], d[rows][:, cols, k])

    def compute(self) -> dict[str, float]:
        """Total and per-keypoint MOTA and switches.

        Returns:
            ``mota`` (total over keypoints), ``id_switches`` (total), ``num_misses``,
                ``num_false_positives``, ``num_objects`` (totals), ``id_switches_nose`` (Okada et al. 2020,
                Table II), ``mota_<keypoint>`` and ``id_switches_<keypoint>`` for each of the 17, and
                ``mota_<group>`` for the groups of
                `KEYPOINT_GROUPS`. Ratios over zero are NaN.
        """
        parts = [acc.compute() for acc in self._per_kp]
        errors = np.array([p["num_misses"] + p["num_false_positives"] + p["id_switches"] for p in parts])
        gt = np.array([p["num_objects"] for p in parts])
        out: dict[str, float] = {}
        with np.errstate(divide="ignore", invalid="ignore"):
            out["mota"] = float(1.0 - errors.sum() / np.float64(gt.sum()))
            for group, idx in KEYPOINT_GROUPS.items():
                out[f"mota_{group}"] = float(1.0 - errors[list(idx)].sum() / np.float64(gt[list(idx)].sum()))
        for key, name in (("id_switches", "id_switches"), ("num_misses", "num_misses")):
            out[name] = float(sum(p[key] for p in parts))
        out["num_false_positives"] = float(sum(p["num_false_positives"] for p in parts))
        out["num_objects"] = float(gt.sum())
        out["id_switches_nose"] = parts[0]["id_switches"]
        for name, p in zip(KEYPOINT_NAMES, parts, strict=True):
            out[f"mota_{name}"] = p["mota"]
            out[f"id_switches_{name}"] = p["id_switches"]
        return out


class PoseOks:
    """Streaming OKS of reported poses against the visible truth poses.

    Per frame, truths and tracks are matched one-to-one by maximum total OKS (Hungarian); pairs
    below ``threshold`` do not count as matches. The truth area is ``area_factor · scale²``.
    Track ids play no part (they are unique and non-negative in a frame by the report
    contract, [`track_envs.contracts.report.validate_report`][track_envs.contracts.validate_report]).

    Returns from [`compute`][track_envs.metrics.PoseOks.compute]: ``oks_mean`` (mean OKS over matched pairs),
    ``oks_recall`` (matched / truths) and ``oks_precision`` (matched / reported), at ``threshold``.
    """

    traits = MetricTraits(needs_truth=True)

    def __init__(self, threshold: float = 0.5, area_factor: float = 0.2) -> None:
        if not 0.0 <= threshold <= 1.0:
            raise ValueError(f"threshold must be an OKS in [0, 1], got {threshold!r}")
        if not (np.isfinite(area_factor) and area_factor > 0):
            raise ValueError(f"area_factor must be positive and finite, got {area_factor!r}")
        self.threshold = float(threshold)
        self.area_factor = float(area_factor)
        self.reset()

    def reset(self) -> None:
        """Forget every frame."""
        self._sum = 0.0
        self._matches = 0
        self._truths = 0
        self._tracks = 0

    def update(
        self, truth: Mapping[str, NDArray], detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> None:
        """Add one frame (``detection_ids`` is unused)."""
        del detection_ids
        _, g, vis, scale = truth_poses(truth)
        _, x = report_poses(report)
        self._truths += len(g)
        self._tracks += len(x)
        if len(g) == 0 or len(x) == 0:
            return
        sim = oks(g, vis, self.area_factor * np.asarray(scale, dtype=np.float64) ** 2, x)  # (n, m)
        r, c = linear_sum_assignment(sim, maximize=True)
        good = sim[r, c] >= self.threshold
        self._sum += float(sim[r, c][good].sum())
        self._matches += int(good.sum())

    def compute(self) -> dict[str, float]:
        """``oks_mean``, ``oks_recall``, ``oks_precision`` (NaN over zero)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return {
                "oks_mean": float(np.float64(self._sum) / self._matches),
                "oks_recall": float(np.float64(self._matches) / self._truths),
                "oks_precision": float(np.float64(self._matches) / self._tracks),
            }


def keypoint_metrics(pckh: float = 0.5, area_factor: float = 0.2) -> list[KeypointMota | PoseOks]:
    """The metrics of keypoint scenes: per-keypoint MOTA (PCKh ``pckh``) and OKS."""
    return [KeypointMota(pckh=pckh), PoseOks(area_factor=area_factor)]
