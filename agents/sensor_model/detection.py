"""The detection probability ``p_D`` and the clutter density ``λ`` from a run's confident tracks.

**Detection probability.** Between two consecutive detections of a confident track the target
was in view, and every frame between them is a miss: the gaps ``g_i`` (missed frames between
consecutive detections of a track) are geometric, ``P(g) = p_D (1 − p_D)^g``. The tracker sees
only gaps of at most ``K`` frames — a track that misses more (``max_misses``, the coasting of the
run that made the tracks) is deleted, and its target comes back as another track — so the gaps
are a geometric truncated at ``K``:

.. math::

    P(g \\mid g \\le K) = \\frac{p (1 − p)^g}{1 − (1 − p)^{K+1}}, \\qquad g = 0..K,

whose maximum-likelihood ``p̂_D`` matches the mean gap: ``E[g | g ≤ K; p̂_D] = ḡ``
([`truncated_geometric_p`][agents.sensor_model.detection.truncated_geometric_p]; the mean falls from ``K / 2``
at ``p → 0`` to 0 at ``p = 1``, so bisection finds it). No gap at all gives ``p̂_D = 1``;
``p̂_D >= MIN_P_DETECT``. The frames before a track's first and after its last detection are not counted:
whether the target was in view there is not known. A count of frames, so positions × k leave ``p̂_D`` as it
is.

**Clutter density.** The detections that no track of at least ``CLUTTER_TRACK_LENGTH``
detections claims are the clutter, spread over the area the detections cover and every frame.
Clutter falls independently every frame, so a track that a clutter detection starts seldom finds a
second detection in its gate and almost never a third that fits its motion, while a target seen
for three frames gives such a track (a confident track, ``MIN_TRACK_LENGTH`` detections, would
also count the targets seen for three to five frames as clutter: on the constant-velocity stream
≈25 % too much, against ≈10 % with tracks of three):

.. math::

    λ̂ = \\frac{N_{unclaimed}}{T \\, A}, \\qquad
    A = \\prod_{d} \\frac{Q_d(1 − a) − Q_d(a)}{1 − 2 a},

with ``T`` the stream's frames and ``A`` the volume of the box between the ``a``-quantiles
(``a = AREA_QUANTILE``) of the detections per axis, widened by ``1 / (1 − 2 a)`` — for
detections uniform over a box that is its width, while a share ``a`` of stray detections on
either side (a wrong row of a file) does not move it, as it would the plain bounding box.
Positions × k give ``A`` × k^D and ``λ̂`` × k^−D (counts do not change).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: Detections of a track from which its detections are not counted as clutter.
CLUTTER_TRACK_LENGTH = 3
#: Least estimated detection probability.
MIN_P_DETECT = 0.05
#: Share of the detections on either side of each axis left out of the area's box.
AREA_QUANTILE = 0.01
#: Bisection steps of [`truncated_geometric_p`][agents.sensor_model.detection.truncated_geometric_p] (to below
#: 1e-15).
BISECTION_STEPS = 60


@dataclass(frozen=True)
class DetectionModel:
    """``p_D`` and ``λ`` estimated from the confident tracks (module docstring).

    Attributes:
        p_detect: ``p̂_D`` (None: no gap to estimate from).
        n_gaps: Gaps between consecutive detections of the confident tracks; ``mean_gap``: ``ḡ``.
        max_gap: ``K``, the longest gap a track of the run could have (its ``max_misses``).
        clutter_density: ``λ̂``, unclaimed detections per unit volume (input units^D) and frame
            (None: the detections cover no volume).
        n_unclaimed: Detections no track of ``CLUTTER_TRACK_LENGTH`` claims.
        area: ``A``, the volume the detections cover (input units^D).
        frames: ``T``.
    """

    p_detect: float | None
    n_gaps: int
    mean_gap: float
    max_gap: int
    clutter_density: float | None
    n_unclaimed: int
    area: float
    frames: int


def truncated_geometric_p(mean_gap: float, max_gap: int) -> float:
    """The ``p`` whose geometric gaps truncated at ``max_gap`` have mean ``mean_gap`` (module
    docstring), in ``[MIN_P_DETECT, 1]``; ``max_gap`` large (beyond 10^4) is the plain geometric
    ``1 / (1 + ḡ)``."""
    if not mean_gap > 0:
        return 1.0
    if max_gap > 10_000:
        return max(1.0 / (1.0 + mean_gap), MIN_P_DETECT)
    g = np.arange(max_gap + 1, dtype=np.float64)

    def mean(p: float) -> float:
        w = (1.0 - p) ** g
        return float(np.dot(g, w) / np.sum(w))

    lo, hi = MIN_P_DETECT, 1.0  # mean(lo) >= mean(hi) = 0
    if mean(lo) <= mean_gap:
        return MIN_P_DETECT
    for _ in range(BISECTION_STEPS):
        mid = 0.5 * (lo + hi)
        if mean(mid) > mean_gap:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def track_gaps(frames: NDArray[np.int64], labels: NDArray[np.int64]) -> NDArray[np.int64]:
    """Missed frames between consecutive detections of each labelled track (−1: none, skipped)."""
    idx = np.flatnonzero(labels >= 0)
    idx = idx[np.lexsort((frames[idx], labels[idx]))]
    lab, f = labels[idx], frames[idx]
    same = lab[1:] == lab[:-1]
    return (f[1:] - f[:-1] - 1)[same].astype(np.int64)


def covered_area(points: NDArray[np.float64]) -> float:
    """``A``: the volume of the widened quantile box of ``points`` (module docstring); 0 for
    fewer than two points or points on a lower-dimensional set."""
    if len(points) < 2:
        return 0.0
    lo, hi = np.quantile(points, [AREA_QUANTILE, 1.0 - AREA_QUANTILE], axis=0)
    width = (hi - lo) / (1.0 - 2.0 * AREA_QUANTILE)
    area = float(np.prod(width))
    return area if np.isfinite(area) and area > 0 else 0.0


def short_tracks(labels: NDArray[np.int64], min_length: int) -> NDArray[np.bool_]:
    """(N,) whether each detection's track (``labels``, −1: none) holds fewer than ``min_length``
    detections (a detection of no track: True)."""
    out = labels < 0
    ok = ~out
    if ok.any():
        _, inverse, counts = np.unique(labels[ok], return_inverse=True, return_counts=True)
        out[ok] = counts[inverse] < min_length
    return out


def detection_model(
    points: NDArray[np.float64],
    frames: NDArray[np.int64],
    n_frames: int,
    labels: NDArray[np.int64],
    max_gap: int,
    min_length: int,
) -> DetectionModel:
    """``p̂_D`` and ``λ̂`` (module docstring).

    Args:
        points: (N, D) detections; ``frames`` their frames; ``n_frames`` the stream's ``T``.
        labels: (N,) the track of each detection in the run (−1: none).
        max_gap: ``K``, the run's ``max_misses``.
        min_length: Detections of a confident track (the gaps are those of confident tracks).
    """
    gaps = track_gaps(frames, np.where(short_tracks(labels, min_length), -1, labels))
    mean_gap = float(np.mean(gaps)) if len(gaps) else 0.0
    p_detect = truncated_geometric_p(mean_gap, max_gap) if len(gaps) else None
    n_unclaimed = int(np.count_nonzero(short_tracks(labels, CLUTTER_TRACK_LENGTH)))
    area = covered_area(points)
    density = n_unclaimed / (max(n_frames, 1) * area) if area > 0 else None
    return DetectionModel(
        p_detect=p_detect,
        n_gaps=len(gaps),
        mean_gap=mean_gap,
        max_gap=int(max_gap),
        clutter_density=density,
        n_unclaimed=n_unclaimed,
        area=area,
        frames=int(n_frames),
    )
