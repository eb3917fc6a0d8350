"""Tracks through merged blobs: touching particles that the camera reports as one detection.

When two particles touch, the camera reports one centroid for both (the area-weighted centroid of
the blob) for a few frames. A plain GNN gives the blob to one track; the other finds no detection,
coasts, and is deleted or jumps to a neighbour, and on separation the two tracks may swap.

**Shared update.** After association, every track left without a detection whose predicted
measurement lies within ``extent`` of a detection taken by another track, which itself is
predicted within ``extent`` of it, joins that detection's blob. A blob of tracks ``G`` (two or
more) is updated as one rigid group: touching particles move together, so the blob's centroid
``z`` tells the group's common motion, and each member keeps its predicted offset from the
group's predicted centre,

.. math::

    z_j = z + \\Big(\\hat y_j - \\frac{1}{|G|} \\sum_{k \\in G} \\hat y_k\\Big), \\qquad j \\in G .

For equal areas the blob centroid is the members' mean position, so ``z − mean(ŷ)`` is exactly
the common innovation; unequal areas bias it by a fraction of the members' separation. Neither
track is pulled onto the centroid (updating both with ``z`` itself would make them converge
and swap on separation), and neither starves of updates (coasting both would let a kf-ca
prediction drift by ``½ a t²`` over a long contact and delete them after ``max_misses``). Every
member reports the blob's detection row, which the metrics count as correct for either particle.

Measured with gnn + kf-ca through the hook below (BeltSorter-v0, 300 frames, seeds 0 / 1,
e_mean): spheres at a feed of 500 /s 0.158 / 0.152 without sharing, 0.108 / 0.086 with
``extent = 4 mm`` (ID switches 361 / 360 → 265 / 219); default cylinders 0.096 / 0.080 without,
0.105 / 0.090 at 4 mm and 0.117 / 0.069 at 6 mm — no gain: many cylinders land already touching,
get one track for the pair, and sharing cannot create the missing one. On streams without merges
it costs little at 6 mm (cylinders unchanged, spheres at 500 /s 0.066 → 0.076). Sharing before
the recovery association instead of after it was worse in every case.

As a component: [`SharedBlobs`][agents.tracking.SharedBlobs] wraps another associator (gnn's
[`GatedAssignment`][agents.tracking.GatedAssignment]): after its association and second chance, before
the per-track upkeep, ``det_of_track, z_tracks = share_blobs(prediction.mean, z, det_of_track,
extent, *region)``, then ``predictor.update(state, z_tracks, seen)`` with those rows (the
tracker's upkeep kernel counts a detection shared by several tracks once when it lists the unused
detections). The taken detections near a leftover track come from the spatial index (the ball of
radius ``extent`` lies in the box of half-width ``extent``), so a frame costs ``O(n + m)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.tracking._kernels import blob_measurements
from agents.tracking.associator import Association, Associator, AssociatorCapability, FrameContext
from agents.tracking.gated import GatedAssignment
from predictors.base import Predictor
from track_envs.values.types import SensorSpec


def share_blobs(
    predicted: NDArray[np.floating],
    z: NDArray[np.floating],
    det_of_track: NDArray[np.integer],
    extent: float,
    low: NDArray[np.floating] | None = None,
    high: NDArray[np.floating] | None = None,
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Tracks that share a merged detection, and the measurement each track is updated with.

    Args:
        predicted: (n, D) predicted measurements of the tracks.
        z: (m, D) detections.
        det_of_track: (n,) detection of each track after association, −1 for none.
        extent: Largest distance (sensor units) of a member's prediction from the blob's centroid,
            about the largest particle's size; 0 turns sharing off.
        low, high: (D,) corners of the observed region; a track predicted outside it joins no
            blob (its particle has left the view). Default: no bound.

    Returns:
        ``(det_of_track, z_tracks)``: the detection of each track with blob members added (a
            detection may now appear more than once), and (n, D) the measurement of each track
            (rows of tracks without a detection are zero and unused).
    """
    if not (np.isfinite(extent) and extent >= 0):
        raise ValueError(f"extent must be a finite distance >= 0, got {extent!r}")
    det = np.ascontiguousarray(det_of_track, dtype=np.int64)
    zz = np.ascontiguousarray(z, dtype=np.float64).reshape(len(z), -1)
    y = np.ascontiguousarray(predicted, dtype=np.float64)
    if extent == 0 or len(zz) == 0:
        z_tracks = np.zeros_like(y)
        hit = det >= 0
        z_tracks[hit] = zz[det[hit]]
        return det.copy(), z_tracks
    dim = y.shape[1]
    lo = np.full(dim, -np.inf) if low is None else np.ascontiguousarray(low, dtype=np.float64)
    hi = np.full(dim, np.inf) if high is None else np.ascontiguousarray(high, dtype=np.float64)
    return blob_measurements(y, zz, det, float(extent), lo, hi)


class SharedBlobs:
    """Another associator's association, then the merged blobs of
    `share_blobs`.

    Args:
        inner: The associator whose association the blobs extend (default gnn's
            [`GatedAssignment`][agents.tracking.GatedAssignment]); its update corrects the tracks.
        blob_extent: Largest distance (sensor units) of a leftover track's prediction from a taken
            detection it may share, >= 0; 0 turns sharing off.
    """

    capabilities = frozenset({AssociatorCapability.SHARED_DETECTIONS})

    def __init__(self, inner: Associator | None = None, blob_extent: float = 0.0):
        if not (isinstance(blob_extent, int | float) and np.isfinite(blob_extent) and blob_extent >= 0):
            raise ValueError(f"blob_extent must be a finite distance >= 0, got {blob_extent!r}")
        self.inner: Associator = GatedAssignment() if inner is None else inner
        self.blob_extent = float(blob_extent)

    def reset(self, spec: SensorSpec, predictor: Predictor) -> None:
        """Start an episode (the inner associator's reset)."""
        self.inner.reset(spec, predictor)

    def associate(self, frame: FrameContext) -> Association:
        """The inner association, with the leftover tracks of a blob sharing its detection."""
        inner = self.inner.associate(frame)
        if self.blob_extent > 0 and len(frame.z):
            det_of_track, z_tracks = share_blobs(
                frame.predicted, frame.z, inner.det_of_track, self.blob_extent, *frame.region
            )
            return Association(det_of_track, z_tracks, inner.may_start, inner.detail)
        return inner

    def update(
        self, predictor: Predictor, state: Any, association: Association, seen: NDArray[np.bool_]
    ) -> Any:
        """The inner associator's update."""
        return self.inner.update(predictor, state, association, seen)

    def warm_up(self, dim: int) -> None:
        """The inner associator's warm-up."""
        self.inner.warm_up(dim)
