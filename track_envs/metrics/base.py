"""The metric interface and the small streaming plumbing the metrics share.

A metric is streaming, in the style of py-motmetrics' accumulator: it is fed one frame at a time
with ``update(truth, detection_ids, report)`` and summarised with ``compute()``. The per-frame
arguments are exactly what a tracking environment hands out (fixed shapes, padded):

* ``truth`` — ``info["truth"]``: ``"ids"`` (max_targets,) int64, −1 for padding; ``"positions"``
  (max_targets, D); ``"visible"`` (max_targets,) bool.
* ``detection_ids`` — ``info["detection_ids"]``: (max_detections,) int64, the truth id behind each
  detection row, −1 for clutter and padding. A metric whose class declares
  ``traits = MetricTraits(accepts_merged_ids=True)`` may instead get
  ``info["detection_ids_merged"]`` (max_detections, K): every truth id behind each row (touching
  particles seen as one blob), −1 padded, column 0 the primary (see
  [`track_envs.metrics.merged`][track_envs.metrics.merged]).
* ``report`` — the action: ``"ids"`` (max_tracks,) int64, ``"positions"`` (max_tracks, D),
  ``"detection"`` (max_tracks,) int64 (detection row used this frame or −1), ``"mask"``
  (max_tracks,) int8. By the report contract
  ([`track_envs.contracts.report.validate_report`][track_envs.contracts.validate_report], which every
  environment applies in ``step``) the ids of the rows with mask 1 are unique within the frame and
  non-negative; a metric fed reports directly may assume it.

Every metric also has ``reset()`` to start a new episode.

What a metric is, it declares in one class attribute ``traits = MetricTraits(...)`` (read with
[`metric_traits`][track_envs.metrics.metric_traits], the way agents declare theirs,
[`track_envs.infra.declared`][track_envs.infra.declared]): a metric that scores against the truth declares
``needs_truth=True`` (every metric here does); one that reads only the reports (a track count, say) declares
nothing, since the default is ``False``. [`TrackingMetrics`][track_envs.wrappers.TrackingMetrics] skips the
metrics that need truth on an environment without it (``has_truth = False``, DetectionReplay-v0).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.declared import declared_value


@dataclass(frozen=True)
class MetricTraits:
    """What a metric class declares about itself (``traits = MetricTraits(...)``); the defaults
    are those of a class that declares nothing.

    Attributes:
        needs_truth: Scores against the truth: skipped on an environment without it.
        accepts_merged_ids: Takes ``info["detection_ids_merged"]`` (every truth id behind a
            merged detection) as its ``detection_ids``.
    """

    needs_truth: bool = False
    accepts_merged_ids: bool = False


def metric_traits(metric: object) -> MetricTraits:
    """The traits ``metric``'s class (or ``metric``, a class) declares; the defaults where none."""
    return declared_value(metric, "traits", MetricTraits, MetricTraits())


@runtime_checkable
class Metric(Protocol):
    """A streaming scorer of reports against ground truth (motmetrics-style). What it is beyond
    this, it declares in ``traits`` ([`MetricTraits`][track_envs.metrics.MetricTraits], read by
    [`TrackingMetrics`][track_envs.wrappers.TrackingMetrics] with
    [`metric_traits`][track_envs.metrics.metric_traits])."""

    def update(
        self, truth: Mapping[str, NDArray], detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> None:
        """Add one frame: the truth and detection sources of the frame and the report answering it."""
        ...

    def compute(self) -> dict[str, float]:
        """Summarise every frame added so far (does not reset)."""
        ...

    def reset(self) -> None:
        """Forget every frame: start a new episode."""
        ...


def truth_arrays(
    truth: Mapping[str, NDArray],
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.bool_]]:
    """The padded ``info["truth"]`` arrays as compiled kernels take them: ids (max_targets,) int64,
    positions (max_targets, D) C-contiguous float64, visible (max_targets,) bool (no copies when
    they already are)."""
    return (
        np.ascontiguousarray(truth["ids"], dtype=np.int64),
        np.ascontiguousarray(truth["positions"], dtype=np.float64),
        np.ascontiguousarray(truth["visible"], dtype=np.bool_),
    )


def report_arrays(
    report: Mapping[str, NDArray],
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64], NDArray[np.int8]]:
    """The padded report arrays as compiled kernels take them: ids (max_tracks,) int64, positions
    (max_tracks, *P) C-contiguous float64, detection (max_tracks,) int64, mask (max_tracks,) int8
    (see [`report_mask`][track_envs.metrics.base.report_mask])."""
    return (
        np.ascontiguousarray(report["ids"], dtype=np.int64),
        np.ascontiguousarray(report["positions"], dtype=np.float64),
        np.ascontiguousarray(report["detection"], dtype=np.int64),
        report_mask(report),
    )


def report_mask(report: Mapping[str, NDArray]) -> NDArray[np.int8]:
    """``report["mask"]`` as a contiguous int8 array that is 1 exactly where the mask equals 1."""
    mask = np.asarray(report["mask"])
    if mask.dtype != np.int8:
        mask = (mask == 1).astype(np.int8)
    return np.ascontiguousarray(mask)


def live_truth(truth: Mapping[str, NDArray]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Ids (m,) and positions (m, D) of the real, visible truth rows of ``info["truth"]``."""
    ids = np.asarray(truth["ids"], dtype=np.int64)
    keep = (ids >= 0) & np.asarray(truth["visible"], dtype=bool)
    return ids[keep], np.asarray(truth["positions"], dtype=np.float64)[keep]


def live_report(
    report: Mapping[str, NDArray],
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64]]:
    """Ids (n,), positions (n, *P) and detection rows (n,) of the rows of ``report`` with mask 1."""
    keep = np.asarray(report["mask"]) == 1
    ids = np.asarray(report["ids"], dtype=np.int64)[keep]
    positions = np.asarray(report["positions"], dtype=np.float64)[keep]
    detection = np.asarray(report["detection"], dtype=np.int64)[keep]
    return ids, positions, detection
