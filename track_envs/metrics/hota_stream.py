"""HOTA as a streaming [`Metric`][track_envs.metrics.Metric] of the environments' reports.

Luiten et al., "HOTA: A Higher Order Metric for Evaluating Multi-Object Tracking", IJCV 2021;
the figures and their definitions are those of [`track_envs.metrics.hota`][track_envs.metrics.hota]. What the
environments add is the similarity between the visible truth and the reported tracks (mask 1):

* [`Hota`][track_envs.metrics.Hota], points: ``S = max(0, 1 − d/τ)`` with ``d`` the Euclidean distance and
``τ`` the
  metric's distance threshold (the CLEAR MOT match distance and GOSPA cut-off ``c`` of
  [`point_metrics`][track_envs.metrics.point_metrics]). A pair is then a true positive
  at α when ``d ≤ (1 − α) τ``: the α-average sweeps the match distance from ``0.95 τ`` down to
  ``0.05 τ``, and LocA is ``1 − (mean matched distance)/τ``.
* [`BoxHota`][track_envs.metrics.BoxHota], boxes (MOTChallenge files): ``S`` the intersection over union of
the boxes
  (``truth["boxes"]``, ``report["boxes"]``; a box that is not finite overlaps nothing).
* [`PoseHota`][track_envs.metrics.PoseHota], poses: ``S`` the object keypoint similarity (OKS, COCO's, with
the truth
  area ``area_factor · scale²`` as [`PoseOks`][track_envs.metrics.PoseOks] uses).

Only the non-zero similarities are computed and kept: [`Hota`][track_envs.metrics.Hota] takes the pairs closer
than ``τ`` and [`BoxHota`][track_envs.metrics.BoxHota] the overlapping boxes from a spatial index
([`point_similarity_entries`][track_envs.metrics.hota_similarity.point_similarity_entries],
[`box_iou_entries`][track_envs.metrics.hota_similarity.box_iou_entries]), and the accumulator matches each
frame per connected component ([`hota_matching`][track_envs.metrics.hota_matching]), so a frame costs time
linear in the targets; the figures are those of the dense matrices, bit for bit.
([`PoseHota`][track_envs.metrics.PoseHota] still builds the dense OKS matrix: OKS is positive for every pair.)

The keys of [`Hota.compute`][track_envs.metrics.hota_stream._StreamingHota.compute] are
[`HOTA_KEYS`][track_envs.metrics.hota_stream.HOTA_KEYS]' values: ``hota``, ``det_a``, ``ass_a``, ``loc_a``,
``det_re``, ``det_pr``, ``ass_re``, ``ass_pr`` (the α-averaged figures; 0, and ``loc_a`` 1, before any truth
or report row).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from track_envs.metrics.base import MetricTraits, live_report, live_truth
from track_envs.metrics.hota import HOTA_FIELDS, HotaAccumulator
from track_envs.metrics.hota_similarity import box_iou_entries, point_similarity_entries
from track_envs.metrics.keypoints import oks, report_poses, truth_poses

#: HOTA's figure names ([`HOTA_FIELDS`][track_envs.metrics.hota.HOTA_FIELDS]) and the metric keys they
#: have in ``episode_metrics``, records and tables.
HOTA_KEYS: dict[str, str] = {
    "HOTA": "hota",
    "DetA": "det_a",
    "AssA": "ass_a",
    "LocA": "loc_a",
    "DetRe": "det_re",
    "DetPr": "det_pr",
    "AssRe": "ass_re",
    "AssPr": "ass_pr",
}


def hota_keys(figures: Mapping[str, float]) -> dict[str, float]:
    """[`HotaAccumulator.compute`][track_envs.metrics.HotaAccumulator.compute]'s figures under their metric
    keys ([`HOTA_KEYS`][track_envs.metrics.hota_stream.HOTA_KEYS])."""
    return {HOTA_KEYS[name]: float(figures[name]) for name in HOTA_FIELDS}


class _StreamingHota:
    """What the streaming HOTA metrics share: the accumulator, ``reset`` and ``compute``; each
    subclass turns a frame into (truth ids, report ids, similarity) in ``update``."""

    traits = MetricTraits(needs_truth=True)

    def __init__(self) -> None:
        self._acc = HotaAccumulator()

    def reset(self) -> None:
        """Forget every frame (start a new episode)."""
        self._acc.reset()

    def compute(self) -> dict[str, float]:
        """``hota``, ``det_a``, ``ass_a``, ``loc_a``, ``det_re``, ``det_pr``, ``ass_re``, ``ass_pr``."""
        return hota_keys(self._acc.compute())


class Hota(_StreamingHota):
    """Streaming HOTA of point reports (mask 1 rows) against the visible truth.

    Similarity ``max(0, 1 − d/τ)`` (see the module docstring); track ids are the report's, truth
    ids the truth's.

    Args:
        threshold: τ, the distance at which the similarity reaches 0 (sensor units), > 0 and finite.
    """

    def __init__(self, threshold: float) -> None:
        if not (np.isfinite(threshold) and threshold > 0):
            raise ValueError(f"threshold must be > 0 and finite (sensor units); got {threshold!r}")
        self.threshold = float(threshold)
        super().__init__()

    def update(
        self, truth: Mapping[str, NDArray], detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> None:
        """Add one frame from ``info["truth"]`` and the report (``detection_ids`` is unused)."""
        del detection_ids
        truth_ids, x = live_truth(truth)
        report_ids, y, _ = live_report(report)
        if x.ndim != 2 or y.ndim != 2 or x.shape[1] != y.shape[1]:
            raise ValueError(
                "Hota scores point reports (max_tracks, D) against truth (max_targets, D); got report "
                f"positions {np.shape(report['positions'])} and truth {np.shape(truth['positions'])}"
            )
        rows, cols, values = point_similarity_entries(x, y, self.threshold)
        self._acc.add_sparse_frame(truth_ids, report_ids, rows, cols, values)


class BoxHota(_StreamingHota):
    """Streaming HOTA of boxed reports against the visible boxed truth, with IoU as similarity.

    Frames carry ``truth["boxes"]`` and ``report["boxes"]`` (rows, 4) ``(left, top, width, height)``
    as [`BoxClearMot`][track_envs.metrics.BoxClearMot] reads them; TrackEval's MOTChallenge HOTA is
    this on the same boxes.
    """

    def update(
        self, truth: Mapping[str, NDArray], detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> None:
        """Add one frame (``detection_ids`` is unused)."""
        del detection_ids
        if "boxes" not in truth or "boxes" not in report:
            raise ValueError("BoxHota scores boxes: the truth and the report need 'boxes' (rows, 4)")
        live_t = np.asarray(truth["visible"], dtype=bool) & (np.asarray(truth["ids"]) >= 0)
        live_r = np.asarray(report["mask"]) == 1
        a = np.asarray(truth["boxes"], dtype=np.float64)[live_t]
        b = np.asarray(report["boxes"], dtype=np.float64)[live_r]
        rows, cols, values = box_iou_entries(a.reshape(-1, 4), b.reshape(-1, 4))
        self._acc.add_sparse_frame(
            np.asarray(truth["ids"])[live_t], np.asarray(report["ids"])[live_r], rows, cols, values
        )


class PoseHota(_StreamingHota):
    """Streaming HOTA of reported poses against the visible truth poses, with OKS as similarity.

    Args:
        area_factor: The truth area is ``area_factor · scale²`` (as
            [`PoseOks`][track_envs.metrics.PoseOks]), > 0.
    """

    def __init__(self, area_factor: float = 0.2) -> None:
        if not (np.isfinite(area_factor) and area_factor > 0):
            raise ValueError(f"area_factor must be positive and finite, got {area_factor!r}")
        self.area_factor = float(area_factor)
        super().__init__()

    def update(
        self, truth: Mapping[str, NDArray], detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> None:
        """Add one frame (``detection_ids`` is unused)."""
        del detection_ids
        truth_ids, g, visible, scale = truth_poses(truth)
        report_ids, x = report_poses(report)
        area = self.area_factor * np.asarray(scale, dtype=np.float64) ** 2
        similarity = oks(g, visible, area, x).T if len(g) and len(x) else np.zeros((len(g), len(x)))
        self._acc.add_frame(truth_ids, report_ids, np.clip(similarity, 0.0, 1.0))
