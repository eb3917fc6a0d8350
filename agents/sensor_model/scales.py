"""Scale-free first settings of a tracker from the detections alone: a length, the flow, a spread.

Before any track exists, three figures of the stream say how big and how fast it is, in the
input's own units:

* the **length** ``ℓ``: the median distance of a detection to its nearest neighbour in the same
  frame (how far apart targets are; frames with one detection do not count). A stream with at
  most one detection per frame uses the median distance to the nearest detection of the previous
  frame instead;
* the **flow** ``ū``: the most common frame-to-frame displacement. Every detection of frame
  ``t + 1`` is paired with its ``NEIGHBOURS`` nearest detections of frame ``t``; the
  displacement with the most others within ``ℓ / 10`` of it (a kernel-density mode, so the
  wrong pairs, spread over every direction, do not move it) is the flow. On a belt this is the
  belt's motion per frame, for walking people about zero;
* the **spread** ``s``: the robust standard deviation (1.4826 × median absolute deviation, the
  larger of the axes) of the displacements within ``ℓ / 2`` of the flow — measurement noise and
  the targets' differences of motion together — at least ``MIN_SPREAD ℓ``.

Every figure is a distance (or a displacement) between detections, so positions × k give
figures × k: nothing depends on the unit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from track_envs.values.detections import Detections

#: Nearest detections of the previous frame each detection is paired with for the flow.
NEIGHBOURS = 4
#: Frame pairs (evenly spaced) the flow is taken over, at most.
MAX_FRAME_PAIRS = 400
#: Least spread, as a share of the length (noise-free targets moving alike have none).
MIN_SPREAD = 0.01
#: Displacements the mode is searched among, at most (evenly spaced).
MAX_CANDIDATES = 4000


@dataclass(frozen=True)
class DataScales:
    """The stream's length, flow and spread (module docstring), in input units per frame.

    Attributes:
        length: ``ℓ``, the median nearest-neighbour distance within a frame.
        flow: (D,) ``ū``, the most common displacement per frame.
        spread: ``s``, the robust spread of the displacements about the flow.
        n_pairs: Frame-to-frame displacements the flow and spread rest on.
    """

    length: float
    flow: NDArray[np.float64]
    spread: float
    n_pairs: int


def _frame_pairs(detections: Detections) -> NDArray[np.int64]:
    """Frames ``t`` (evenly spaced, at most ``MAX_FRAME_PAIRS``) with detections in ``t`` and ``t + 1``."""
    counts = detections.counts
    both = np.flatnonzero((counts[:-1] > 0) & (counts[1:] > 0))
    if len(both) > MAX_FRAME_PAIRS:
        both = both[np.linspace(0, len(both) - 1, MAX_FRAME_PAIRS).round().astype(np.int64)]
    return both


def within_frame_distance(detections: Detections) -> float | None:
    """Median distance of a detection to its nearest neighbour in its frame (None: no frame has two)."""
    counts = detections.counts
    frames = np.flatnonzero(counts >= 2)
    if len(frames) > MAX_FRAME_PAIRS:
        frames = frames[np.linspace(0, len(frames) - 1, MAX_FRAME_PAIRS).round().astype(np.int64)]
    nearest = [cKDTree(z).query(z, 2)[0][:, 1] for z in (detections.frame(int(t)) for t in frames)]
    if not nearest:
        return None
    d = np.concatenate(nearest)
    d = d[d > 0]
    return float(np.median(d)) if len(d) else None


def displacements(detections: Detections) -> NDArray[np.float64]:
    """(K, D) displacements from every detection of frame ``t + 1`` back to its ``NEIGHBOURS``
    nearest of frame ``t`` (sign: later minus earlier), over the frame pairs of the stream."""
    out = []
    for t in _frame_pairs(detections):
        before, after = detections.frame(int(t)), detections.frame(int(t) + 1)
        k = min(NEIGHBOURS, len(before))
        _, idx = cKDTree(before).query(after, k)
        idx = np.asarray(idx).reshape(len(after), k)
        out.append((after[:, None, :] - before[idx]).reshape(-1, detections.dim))
    return np.concatenate(out) if out else np.zeros((0, detections.dim))


def data_scales(detections: Detections) -> DataScales | None:
    """The stream's [`DataScales`][agents.sensor_model.scales.DataScales]; None for a stream without two
    consecutive frames holding detections (nothing moves that could be measured)."""
    d = displacements(detections)
    if len(d) == 0:
        return None
    length = within_frame_distance(detections)
    if length is None:  # one target at a time: its own motion per frame is the length
        length = float(np.median(np.linalg.norm(d, axis=1)))
    if not length > 0:
        return None
    cand = d if len(d) <= MAX_CANDIDATES else d[np.linspace(0, len(d) - 1, MAX_CANDIDATES).astype(np.int64)]
    density = cKDTree(d).query_ball_point(cand, 0.1 * length, return_length=True)
    flow = np.median(d[np.linalg.norm(d - cand[int(np.argmax(density))], axis=1) <= 0.1 * length], axis=0)
    near = d[np.linalg.norm(d - flow, axis=1) <= 0.5 * length]
    mad = np.median(np.abs(near - np.median(near, axis=0)), axis=0)
    spread = max(float(1.4826 * np.max(mad)), MIN_SPREAD * length)
    return DataScales(length=length, flow=flow.astype(np.float64), spread=spread, n_pairs=len(near))


def default_threshold(detections: Detections) -> float:
    """The default metric match distance: half the median nearest-neighbour distance within a
    frame (half the median frame-to-frame nearest displacement for a stream with one detection
    per frame; 1 for a stream without either)."""
    length = within_frame_distance(detections)
    if length is None:
        scales = data_scales(detections)
        length = scales.length if scales is not None else 2.0
    return length / 2
