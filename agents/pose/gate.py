"""pose-baseline's gate sized from the data: the OKS area factor at which people moving as fast as
a file's people still match their tracks.

The tracking loop ([`agents.pose.tracker.PoseTracker`][agents.pose.tracker.PoseTracker]) matches a track and a
detected pose when their OKS is at least ``τ`` (``oks_threshold``). With the detection's area
``A = a · L²`` (``L`` the longer side of its keypoint box, ``a`` the ``area_factor``), a keypoint
``j`` off by ``d`` scores ``exp(−d² / (2 a L² κ_j²))``, ``κ_j = 2 σ_j`` (the COCO sigmas). A new
track has no velocity yet, so its first prediction is off by the person's whole per-frame
displacement: when people move more per frame than the gate admits, every pose starts a new
track (e.g. people 200 px tall walking 25 px a frame: one id per pose at ``a = 0.25``).

**From the data** (in the data's own units; nothing depends on the unit, every figure is a ratio
of lengths): each pose of frame ``t + 1`` is paired with the nearest pose of frame ``t`` (their
centres: the mean of the labelled keypoints; at most ``MAX_FRAME_PAIRS`` frame pairs, evenly
spaced), and its displacement taken relative to its size, ``r_i = d_i / L_i``. The median ``r̂``
(robust to clutter, entries and exits, which pair with a far pose) is the people's typical motion
per frame, as a share of their size. The gate admits ``MARGIN · r̂`` (people up to twice as fast
still match):

    a* = the least a with  mean_j exp(−(MARGIN · r̂)² / (2 a κ_j²)) ≥ τ,
    area_factor = max(a₀, a*)

with ``a₀`` the default ``area_factor`` (0.25): the gate only widens, so data that move less than
the default gate admits are tracked exactly as before. ``--agent-kwargs area_factor=A`` sets it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from agents.pose.tracker import PoseTrackingOptions
from track_envs.metrics.keypoints import COCO_SIGMAS
from track_envs.values.poses import PoseStream

#: Frame pairs (evenly spaced) the displacements are taken over, at most.
MAX_FRAME_PAIRS = 400
#: The gate admits this many times the median relative displacement.
MARGIN = 2.0
#: The loop's default area factor (the gate never narrows below it).
DEFAULT_AREA_FACTOR = PoseTrackingOptions().area_factor


@dataclass(frozen=True)
class PoseGate:
    """The data's motion and the area factor sized from it (module docstring).

    Attributes:
        area_factor: ``max(a₀, a*)``, the area factor to track with.
        needed: ``a*``, the area factor at which ``MARGIN · r̂`` scores ``τ``.
        motion: ``r̂``, the median per-frame displacement of a pose as a share of its size (nan
            without two consecutive frames holding poses).
        size: The median pose size ``L`` (longer side of the labelled-keypoint box), in the data's
            units.
        n_pairs: Displacements ``r̂`` rests on.
    """

    area_factor: float
    needed: float
    motion: float
    size: float
    n_pairs: int

    def describe(self) -> str:
        """One line: the motion, the pose size, and the area factor chosen."""
        if not self.n_pairs:
            return f"area_factor {self.area_factor:.3g} (no consecutive frames with poses to size it from)"
        change = (
            f"widened from the default {DEFAULT_AREA_FACTOR:g} to admit {MARGIN:g}x that motion"
            if self.area_factor > DEFAULT_AREA_FACTOR
            else "the default, wide enough"
        )
        return (
            f"poses move {self.motion:.3g} of their size a frame (median of {self.n_pairs} nearest "
            f"displacements: {self.motion * self.size:.3g} at the median size {self.size:.3g}); "
            f"area_factor {self.area_factor:.3g} ({change}; --agent-kwargs area_factor=A sets it)"
        )


def pose_centres(stream: PoseStream) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Per pose: the centre (N, 2) (mean of its labelled keypoints), the size (N,) (longer side of
    their box, at least 1) and whether it has a labelled keypoint (N,)."""
    present = stream.present
    count = present.sum(axis=1)
    centre = np.sum(stream.keypoints * present[..., None], axis=1) / np.maximum(count, 1)[:, None]
    high = np.max(np.where(present[..., None], stream.keypoints, -np.inf), axis=1)
    low = np.min(np.where(present[..., None], stream.keypoints, np.inf), axis=1)
    span = np.where(count[:, None] > 0, high - low, 0.0)
    return centre, np.maximum(span.max(axis=1), 1.0), count > 0


def relative_displacements(stream: PoseStream) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``r_i``: each pose's distance to the nearest pose of the frame before, over its size, and
    the sizes ``L_i`` (both (n,), over at most ``MAX_FRAME_PAIRS`` evenly spaced frame pairs)."""
    centre, size, has = pose_centres(stream)
    counts = np.bincount(stream.frame_index()[has], minlength=stream.n_frames)
    pairs = np.flatnonzero((counts[:-1] > 0) & (counts[1:] > 0))
    if len(pairs) > MAX_FRAME_PAIRS:
        pairs = pairs[np.linspace(0, len(pairs) - 1, MAX_FRAME_PAIRS).round().astype(np.int64)]
    ratios, sizes = [], []
    for t in pairs.tolist():
        before = stream.frame_rows(t)
        now = stream.frame_rows(t + 1)
        a = centre[before][has[before]]
        keep = has[now]
        distance, _ = cKDTree(a).query(centre[now][keep])
        ratios.append(distance / size[now][keep])
        sizes.append(size[now][keep])
    if not ratios:
        return np.zeros(0), np.zeros(0)
    return np.concatenate(ratios), np.concatenate(sizes)


def needed_area_factor(motion: float, oks_threshold: float, sigmas: NDArray = COCO_SIGMAS) -> float:
    """``a*``: the least area factor at which poses displaced by ``motion`` (a share of their size)
    score a mean OKS of ``oks_threshold`` (module docstring), by bisection in ``log a``."""
    kappa2 = (2 * np.asarray(sigmas, np.float64)) ** 2
    if not (np.isfinite(motion) and motion > 0):
        return 0.0

    def score(a: float) -> float:
        return float(np.mean(np.exp(-(motion**2) / (2 * a * kappa2))))

    low, high = -40.0, 40.0  # log a
    for _ in range(100):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if score(float(np.exp(mid))) < oks_threshold else (low, mid)
    return float(np.exp(high))


def pose_gate(
    stream: PoseStream,
    *,
    oks_threshold: float = PoseTrackingOptions().oks_threshold,
    default: float = DEFAULT_AREA_FACTOR,
) -> PoseGate:
    """The area factor sized from ``stream`` (module docstring)."""
    ratios, sizes = relative_displacements(stream)
    if not len(ratios):
        return PoseGate(default, 0.0, float("nan"), float("nan"), 0)
    motion = float(np.median(ratios))
    needed = needed_area_factor(MARGIN * motion, oks_threshold)
    return PoseGate(max(default, needed), needed, motion, float(np.median(sizes)), len(ratios))
