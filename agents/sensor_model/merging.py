"""jpda's merge extent from the data: how close two targets come and are still seen apart.

jpda's merge model ([`agents.jpda`][agents.jpda]) lets two tracks predicted within ``merge_extent`` take
one detection together, as the merged blob that two touching objects give. Two objects touch when
their centres are about one object's size apart, so the extent is the objects' size, in the
input's units:

* **boxes given** (a MOTChallenge file): the median of ``sqrt(w h)`` over the detections' boxes —
  the side of the square of a box's area, an isotropic size as the merge model's one distance is
  isotropic (a round particle's diameter × 0.89; between a pedestrian's width and height);
* **points only**: the *resolution* of the detector, read from the confident tracks. Two objects
  closer than their size give one blob, not two detections, so the distances at which two
  confident tracks are both detected in one frame start at about that size. Every sampled frame's
  confident detections are paired with their nearest confident neighbour of another track; each
  pair of tracks keeps its closest approach, and the extent is the ``MERGE_QUANTILE`` quantile of
  these closest approaches (a low quantile: the closest targets that stay apart, robust to the few
  pairs whose detections a wrong association brought together). For point targets that never
  merge (a detector that resolves every pair) this is small, and the merge model rarely fires.

At least ``MIN_EXTENT_SHARE`` of the stream's nearest-neighbour distance ``ℓ`` (never 0). No box
and no pair of confident tracks seen together: ``None`` (the merge model is then turned off).
Every figure is a distance, so positions × k give the extent × k.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from track_envs.values.detections import Detections

#: Quantile of the track pairs' closest approaches that is the extent (points only).
MERGE_QUANTILE = 0.05
#: Frames (evenly spaced) the closest approaches are looked for in, at most ...
MAX_FRAMES = 1000
#: ... and detections in those frames, at most (fewer frames of a crowded stream).
MAX_DETECTIONS = 200_000
#: Least extent, as a share of the stream's nearest-neighbour distance.
MIN_EXTENT_SHARE = 1e-3


def box_size(boxes: NDArray[np.float64]) -> float | None:
    """Median ``sqrt(w h)`` of the boxes with a positive area (None: none has one)."""
    size = np.sqrt(boxes[:, 2] * boxes[:, 3])
    size = size[size > 0]
    return float(np.median(size)) if len(size) else None


def closest_approaches(detections: Detections, labels: NDArray[np.int64]) -> NDArray[np.float64]:
    """Each pair of confident tracks' (``labels >= 0``) smallest distance in a frame where both
    are detected and one is the other's nearest confident neighbour (over at most ``MAX_FRAMES``
    frames, evenly spaced, holding about ``MAX_DETECTIONS`` detections at most)."""
    counts = detections.counts
    frames = np.flatnonzero(counts >= 2)
    most = min(MAX_FRAMES, max(1, int(MAX_DETECTIONS * len(frames) / max(int(counts[frames].sum()), 1))))
    if len(frames) > most:
        frames = frames[np.linspace(0, len(frames) - 1, most).round().astype(np.int64)]
    pairs, dists = [], []
    for t in frames:
        lo, hi = detections.offsets[t], detections.offsets[t + 1]
        lab = labels[lo:hi]
        sure = lab >= 0
        if np.count_nonzero(sure) < 2:
            continue
        z, lab = detections.points[lo:hi][sure], lab[sure]
        d, j = cKDTree(z).query(z, 2)
        other = lab[j[:, 1]]
        keep = other != lab
        a, b = lab[keep], other[keep]
        pairs.append(np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1))
        dists.append(d[keep, 1])
    if not pairs:
        return np.zeros(0)
    pair, dist = np.concatenate(pairs), np.concatenate(dists)
    order = np.lexsort((dist, pair[:, 1], pair[:, 0]))
    pair, dist = pair[order], dist[order]
    first = np.concatenate([[True], np.any(pair[1:] != pair[:-1], axis=1)])
    return dist[first]


def merge_extent(
    detections: Detections, labels: NDArray[np.int64], length: float
) -> tuple[float | None, str]:
    """The merge extent (module docstring) and the rule that gave it (``"boxes"``,
    ``"closest approaches"`` or ``"none"``)."""
    floor = MIN_EXTENT_SHARE * length
    if detections.boxes is not None:
        size = box_size(detections.boxes)
        if size is not None:
            return max(size, floor), "boxes"
    approach = closest_approaches(detections, labels)
    if not len(approach):
        return None, "none"
    return max(float(np.quantile(approach, MERGE_QUANTILE)), floor), "closest approaches"
