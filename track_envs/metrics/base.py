"""The metric interface and the small streaming plumbing the metrics share.

A metric is streaming, in the style of py-motmetrics' accumulator: it is fed one frame at a time
with ``update(truth, detection_ids, report)`` and summarised with ``compute()``. The per-frame
arguments are exactly what a tracking environment hands out (fixed shapes, padded):

* ``truth`` — ``info["truth"]``: ``"ids"`` (max_targets,) int64, −1 for padding; ``"positions"``
  (max_targets, D); ``"visible"`` (max_targets,) bool.
* ``detection_ids`` — ``info["detection_ids"]``: (max_detections,) int64, the truth id behind each
  detection row, −1 for clutter and padding.
* ``report`` — the action: ``"ids"`` (max_tracks,) int64, ``"positions"`` (max_tracks, D),
  ``"detection"`` (max_tracks,) int64 (detection row used this frame or −1), ``"mask"``
  (max_tracks,) int8.

Every metric also has ``reset()`` to start a new episode.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray


@runtime_checkable
class Metric(Protocol):
    """A streaming scorer of reports against ground truth (motmetrics-style)."""

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


class KeyCounter:
    """A streaming multiset of integer key rows (``width`` int64 columns) with their counts.

    Frames append arrays; they are merged with :func:`numpy.unique` lazily (when read, or once
    ``compact_every`` arrays are pending), so memory grows with the number of distinct keys,
    not with the number of frames.
    """

    def __init__(self, width: int, compact_every: int = 256) -> None:
        self.width = width
        self.compact_every = compact_every
        self._keys = np.zeros((0, width), dtype=np.int64)
        self._counts = np.zeros(0, dtype=np.int64)
        self._pending: list[NDArray[np.int64]] = []

    def add(self, keys: NDArray[np.integer]) -> None:
        """Count each row of ``keys`` (n, width) once; a 1-D array is read as one column."""
        arr = np.asarray(keys, dtype=np.int64).reshape(-1, self.width)
        if len(arr):
            self._pending.append(arr)
            if len(self._pending) >= self.compact_every:
                self._compact()

    def counts(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Distinct key rows (m, width), sorted lexicographically, and how often each was added (m,)."""
        self._compact()
        return self._keys, self._counts

    def _compact(self) -> None:
        if not self._pending:
            return
        new = np.concatenate(self._pending)
        keys = np.concatenate([self._keys, new])
        weights = np.concatenate([self._counts, np.ones(len(new), dtype=np.int64)])
        self._keys, inverse = _unique_rows(keys)
        self._counts = np.bincount(inverse, weights=weights, minlength=len(self._keys)).astype(np.int64)
        self._pending = []


_PACK_LIMIT = 1 << 31


def _unique_rows(keys: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.intp]]:
    """Distinct rows of ``keys`` (sorted lexicographically) and the inverse map.

    Rows of two non-negative columns below 2³¹ are packed into one int64 (``a·2³² + b``, same
    order), which sorts an order of magnitude faster than ``np.unique(axis=0)``.
    """
    if keys.shape[1] == 1:
        unique, inverse = np.unique(keys[:, 0], return_inverse=True)
        return unique[:, None], inverse.reshape(-1)
    if keys.shape[1] == 2 and len(keys) and keys.min() >= 0 and keys.max() < _PACK_LIMIT:
        packed, inverse = np.unique((keys[:, 0] << 32) | keys[:, 1], return_inverse=True)
        return np.stack([packed >> 32, packed & (_PACK_LIMIT * 2 - 1)], axis=1), inverse.reshape(-1)
    unique, inverse = np.unique(keys, axis=0, return_inverse=True)
    return unique, inverse.reshape(-1)
