"""Box overlap (IoU) and CLEAR MOT / IDF1 on boxes, the MOTChallenge way.

The intersection over union of two axis-aligned boxes ``a``, ``b`` given as ``(left, top, width,
height)``:

.. math::

    \\mathrm{IoU}(a, b) = \\frac{|a \\cap b|}{|a| + |b| - |a \\cap b|}, \\qquad
    |a \\cap b| = \\prod_{k \\in \\{x, y\\}} \\max(0, \\min(a_k + a_{w_k}, b_k + b_{w_k})
        - \\max(a_k, b_k)),

and 0 where the boxes do not overlap (two empty boxes included). MOTChallenge (Milan et al.,
"MOT16: A Benchmark for Multi-Object Tracking", 2016) matches a track to a truth when
``IoU >= 0.5`` and scores the match at distance ``1 − IoU``; py-motmetrics does the same with
``iou_matrix(gt, hyp, max_iou=0.5)`` (distance ``1 − IoU``, NaN where it exceeds ``max_iou``).
[`BoxClearMot`][track_envs.metrics.BoxClearMot] feeds that distance matrix to
[`ClearMot.update_distances`][track_envs.metrics.ClearMot.update_distances], so its MOTA, IDF1, MOTP (mean
``1 − IoU`` of the matches) and counts are motmetrics' on the same boxes.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from track_envs.metrics.base import MetricTraits
from track_envs.metrics.clear_mot import ClearMot
from track_envs.metrics.hota_similarity import box_iou, box_iou_entries


def iou_distances(a: ArrayLike, b: ArrayLike, min_iou: float = 0.5) -> NDArray[np.float64]:
    """(m, n) distances ``1 − IoU``, NaN (impossible pair) where ``1 − IoU > 1 − min_iou`` (the
    test motmetrics' ``iou_matrix(max_iou=1 − min_iou)`` makes, rounding included)."""
    dist = 1.0 - box_iou(a, b)
    return np.where(dist > 1.0 - float(min_iou), np.nan, dist)


def iou_distance_entries(
    a: ArrayLike, b: ArrayLike, min_iou: float = 0.5
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """The finite entries of [`iou_distances`][track_envs.metrics.iou_distances] as compressed sparse rows
    ``(ptr, cols, dist)``, at a cost linear in the boxes: a match needs ``IoU >= min_iou > 0``, so only
    overlapping boxes ([`box_iou_entries`][track_envs.metrics.hota_similarity.box_iou_entries], a spatial
    index) are candidates, and the same ``1 − IoU > 1 − min_iou`` test drops the rest."""
    ta = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    tb = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    rows, cols, iou = box_iou_entries(ta, tb)
    dist = 1.0 - iou
    keep = ~(dist > 1.0 - float(min_iou))
    rows, cols, dist = rows[keep], cols[keep], dist[keep]
    ptr = np.zeros(len(ta) + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=len(ta)), out=ptr[1:])
    return ptr, cols, dist


class BoxClearMot(ClearMot):
    """[`ClearMot`][track_envs.metrics.ClearMot] and IDF1 on boxes: a track matches a truth when their boxes
    overlap with ``IoU >= min_iou`` (default 0.5, the MOTChallenge rule), at distance ``1 − IoU``.

    Frames carry their boxes as ``truth["boxes"]`` and ``report["boxes"]`` (rows, 4), padded like
    the positions ([`track_envs.values.tracks.Tracks.padded_frame`][track_envs.Tracks.padded_frame]); a row
    whose box is not finite matches nothing. ``detection_ids`` are not needed (merged detections are a
    point-env notion).

    Args:
        min_iou: Smallest overlap of a match, in (0, 1].
    """

    traits = MetricTraits(needs_truth=True)  # (ClearMot's, without merged ids)

    def __init__(self, min_iou: float = 0.5) -> None:
        if not (np.isfinite(min_iou) and 0 < min_iou <= 1):
            raise ValueError(f"min_iou must be in (0, 1], got {min_iou!r}")
        super().__init__(threshold=1.0 - min_iou if min_iou < 1 else 1.0)  # (threshold unused)
        self.min_iou = float(min_iou)

    def update(
        self, truth: Mapping[str, NDArray], detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> None:
        """Add one frame (``truth`` and ``report`` with ``"boxes"``)."""
        if "boxes" not in truth or "boxes" not in report:
            raise ValueError("BoxClearMot scores boxes: the truth and the report need 'boxes' (rows, 4)")
        live_truth = np.asarray(truth["visible"], dtype=bool) & (np.asarray(truth["ids"]) >= 0)
        live_report = np.asarray(report["mask"]) == 1
        truth_boxes = np.asarray(truth["boxes"], dtype=np.float64)[live_truth]
        report_boxes = np.asarray(report["boxes"], dtype=np.float64)[live_report]
        ptr, cols, dist = iou_distance_entries(truth_boxes, report_boxes, self.min_iou)
        self.update_entries(
            np.asarray(truth["ids"])[live_truth], np.asarray(report["ids"])[live_report], ptr, cols, dist
        )
