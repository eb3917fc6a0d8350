"""Keypoint trackers: the single-hypothesis pose tracking baseline of Okada et al. (2020).

``PoseBaselineAgent`` ("pose-baseline") is the tracker Okada et al. (2020) improve on (the Simple-Baseline
tracker of Xiao et al., ECCV 2018, with the lifetime bookkeeping of Okada et al. (2020), Algorithm 1).
Every frame, for the ``n`` active tracks and the ``m`` detected poses:

1. **predict**: each track's next pose by constant keypoint velocity,
   ``ŷ_t = y_{t−1} + (y_{t−1} − y_{t−2})`` per keypoint (a stand-in for optical-flow propagation);
   a keypoint not detected in both of the last two updates moves with the mean displacement of
   those that were, and the velocity is an exponential average (``smoothing``) of displacements;
2. **similarity**: the OKS of every predicted pose against every detected pose, one batched
   numpy expression over all (n, m, 17) pairs and keypoints
   (:func:`track_envs.metrics.keypoints.pairwise_oks`), over the keypoints the detection holds
   (score > ``keypoint_threshold``) that the track has seen before, with the detection's area
   ``area_factor · max(w, h)²`` from its keypoint bounding box;
3. **associate**: Hungarian (or greedy) assignment on ``1 − OKS``; pairs with
   ``OKS < oks_threshold`` are not allowed;
4. **update**: a matched track takes the detected keypoints and keeps its prediction for the
   keypoints not detected; its lifetime count ``l ← min(l + 1, 30)``; an unmatched track coasts
   on its prediction with ``l ← l − 1`` and is deactivated when ``l < 0``;
5. **initiate**: a new track (lifetime ``initial_lifetime``) from every unmatched detection;
   its undetected keypoints are placed at the centroid of its detected ones.

The report holds the tracks updated or started this frame (as Algorithm 1 of Okada et al. (2020) outputs the
detected poses with their track ids), or every active track with ``report_coasting=True``.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from agents.association import assign_greedy, assign_hungarian
from track_envs.metrics.keypoints import NUM_KEYPOINTS, pairwise_oks
from track_envs.observation import check_observation
from track_envs.report import pack_report
from track_envs.types import SensorSpec

MAX_LIFETIME = 30


class PoseBaselineAgent:
    """Single-hypothesis pose tracker (the baseline of Okada et al. 2020): constant velocity, OKS, Hungarian.

    Args:
        oks_threshold: Smallest OKS at which a predicted and a detected pose may be matched.
        assignment: ``"hungarian"`` (optimal) or ``"greedy"`` (best pairs first).
        keypoint_threshold: Detected keypoints with a score at or below this are ignored.
        min_pose_score: Detections whose mean score over detected keypoints is below this are ignored.
        min_keypoints: Detections with fewer usable keypoints are ignored.
        initial_lifetime: Lifetime count of a new track.
        area_factor: Object area as a fraction of the squared longer side of the detection's
            keypoint bounding box.
        smoothing: Weight of the newest displacement in the keypoint velocity (1: the last
            displacement alone; below 1 an exponential average, which damps detector noise).
        report_coasting: Report every active track, not only those with a detection this frame.
    """

    #: Tracks poses (17, 2), not points (see :func:`agents.agent_applies_to`).
    position_rank = 2

    def __init__(
        self,
        oks_threshold: float = 0.3,
        assignment: str = "hungarian",
        keypoint_threshold: float = 0.0,
        min_pose_score: float = 0.0,
        min_keypoints: int = 1,
        initial_lifetime: int = 0,
        area_factor: float = 0.25,
        smoothing: float = 0.5,
        report_coasting: bool = False,
    ) -> None:
        if not 0.0 < oks_threshold < 1.0:
            raise ValueError(
                f"oks_threshold must be in (0, 1) (at 0 poses with nothing in common would match), "
                f"got {oks_threshold!r}"
            )
        if assignment not in ("hungarian", "greedy"):
            raise ValueError(f"assignment must be 'hungarian' or 'greedy', got {assignment!r}")
        if not 0.0 <= keypoint_threshold < 1.0:
            raise ValueError(f"keypoint_threshold must be in [0, 1), got {keypoint_threshold!r}")
        if not 0.0 <= min_pose_score <= 1.0:
            raise ValueError(f"min_pose_score must be in [0, 1], got {min_pose_score!r}")
        if not (isinstance(min_keypoints, int) and 1 <= min_keypoints <= NUM_KEYPOINTS):
            raise ValueError(f"min_keypoints must be an integer in [1, 17], got {min_keypoints!r}")
        if not (isinstance(initial_lifetime, int) and 0 <= initial_lifetime <= MAX_LIFETIME):
            raise ValueError(
                f"initial_lifetime must be an integer in [0, {MAX_LIFETIME}], got {initial_lifetime!r}"
            )
        if not 0.0 < smoothing <= 1.0:
            raise ValueError(f"smoothing must be in (0, 1], got {smoothing!r}")
        if not (np.isfinite(area_factor) and area_factor > 0):
            raise ValueError(f"area_factor must be positive and finite, got {area_factor!r}")
        self.oks_threshold = float(oks_threshold)
        self.assign = assign_hungarian if assignment == "hungarian" else assign_greedy
        self.keypoint_threshold = float(keypoint_threshold)
        self.min_pose_score = float(min_pose_score)
        self.min_keypoints = min_keypoints
        self.initial_lifetime = initial_lifetime
        self.area_factor = float(area_factor)
        self.smoothing = float(smoothing)
        self.report_coasting = bool(report_coasting)
        self._spec: SensorSpec | None = None

    def reset(self, spec: SensorSpec, *, seed: int | None = None) -> None:
        """Start a new episode (``seed`` is unused: the tracker is deterministic)."""
        self._spec = spec
        self.ids = np.zeros(0, dtype=np.int64)
        self.pose = np.zeros((0, NUM_KEYPOINTS, 2))  # last pose estimate
        self.velocity = np.zeros((0, NUM_KEYPOINTS, 2))  # per keypoint, px / frame
        self.lifetime = np.zeros(0, dtype=np.int64)
        self.seen = np.zeros((0, NUM_KEYPOINTS), dtype=bool)  # keypoint detected in the last update
        self.known = np.zeros((0, NUM_KEYPOINTS), dtype=bool)  # keypoint detected at least once
        self._next_id = 0

    def act(self, obs: Mapping[str, NDArray]) -> dict[str, NDArray]:
        """One frame: predict, associate by OKS, update, initiate; the report of the tracks."""
        spec = self._spec
        if spec is None:
            raise RuntimeError("act() called before reset(spec); call agent.reset(env.unwrapped.sensor_spec)")
        rows, z = check_observation(obs, spec, (NUM_KEYPOINTS, 3))
        found = z[..., 2] > self.keypoint_threshold  # (m, 17)
        count = found.sum(axis=1)
        mean_score = np.where(found, z[..., 2], 0.0).sum(axis=1) / np.maximum(count, 1)
        usable = (count >= self.min_keypoints) & (mean_score >= self.min_pose_score)
        rows, xy, found = rows[usable], z[usable, :, :2], found[usable]
        predicted = self.pose + self.velocity
        sim = pairwise_oks(predicted, xy, found, self._areas(xy, found), a_valid=self.known)
        ti, di = self.assign(1.0 - sim, 1.0 - self.oks_threshold)
        # matched tracks: detected keypoints replace the prediction
        pose = predicted.copy()
        new_pose = np.where(found[di][..., None], xy[di], predicted[ti])
        velocity = self.velocity.copy()
        step = self._velocity(new_pose - self.pose[ti], found[di] & self.seen[ti], self.velocity[ti])
        velocity[ti] = self.smoothing * step + (1 - self.smoothing) * self.velocity[ti]
        seen = np.zeros_like(self.seen)
        seen[ti] = found[di]
        known = self.known.copy()
        known[ti] |= found[di]
        pose[ti] = new_pose
        matched = np.zeros(len(self.ids), dtype=bool)
        matched[ti] = True
        lifetime = np.where(matched, np.minimum(self.lifetime + 1, MAX_LIFETIME), self.lifetime - 1)
        detection = np.full(len(self.ids), -1, dtype=np.int64)
        detection[ti] = rows[di]
        # births from the detections left over
        free = np.ones(len(rows), dtype=bool)
        free[di] = False
        born = self._births(xy[free], found[free])
        k = len(born)
        self.ids = np.concatenate([self.ids, np.arange(self._next_id, self._next_id + k, dtype=np.int64)])
        self._next_id += k
        self.pose = np.concatenate([pose, born])
        self.velocity = np.concatenate([velocity, np.zeros_like(born)])
        self.lifetime = np.concatenate([lifetime, np.full(k, self.initial_lifetime, dtype=np.int64)])
        self.seen = np.concatenate([seen, found[free]])
        self.known = np.concatenate([known, found[free]])
        detection = np.concatenate([detection, rows[free]])
        shown = np.concatenate([matched, np.ones(k, dtype=bool)])
        alive = self.lifetime >= 0
        self.ids, self.pose, self.velocity = self.ids[alive], self.pose[alive], self.velocity[alive]
        self.lifetime, self.seen, self.known = self.lifetime[alive], self.seen[alive], self.known[alive]
        shown, detection = shown[alive], detection[alive]
        out = np.ones(len(self.ids), dtype=bool) if self.report_coasting else shown
        out_rows = np.flatnonzero(out)
        if len(out_rows) > spec.max_tracks:  # keep the tracks with a detection, then the longest-lived
            order = np.lexsort((-self.lifetime[out_rows], ~shown[out_rows]))
            out_rows = np.sort(out_rows[order[: spec.max_tracks]])
        return pack_report(self.ids[out_rows], self.pose[out_rows], detection[out_rows], spec.max_tracks)

    def _areas(self, xy: NDArray, found: NDArray) -> NDArray[np.float64]:
        """Object areas (m,) of detected poses: ``area_factor · max(w, h)²`` of their keypoint box."""
        if len(xy) == 0:
            return np.zeros(0)
        f = found[..., None]
        span = np.max(np.where(f, xy, -np.inf), axis=1) - np.min(np.where(f, xy, np.inf), axis=1)
        span = np.where(np.isfinite(span), span, 0.0)
        return self.area_factor * np.maximum(np.max(span, axis=1), 1.0) ** 2

    @staticmethod
    def _velocity(step: NDArray, both: NDArray, old: NDArray) -> NDArray[np.float64]:
        """Keypoint velocities (n, 17, 2) of updated tracks.

        A keypoint detected now and at the last update moves by its own displacement ``step``;
        the others move with the mean displacement of those (the person's translation), or keep
        their ``old`` velocity when the track has no such keypoint.
        """
        count = both.sum(axis=1)
        mean = np.sum(step * both[..., None], axis=1) / np.maximum(count, 1)[:, None]
        fallback = np.where((count > 0)[:, None, None], mean[:, None, :], old)
        return np.where(both[..., None], step, fallback)

    def _births(self, xy: NDArray, found: NDArray) -> NDArray[np.float64]:
        """Full poses (k, 17, 2) of new tracks: undetected keypoints at the detected centroid."""
        centroid = np.sum(xy * found[..., None], axis=1) / np.maximum(found.sum(axis=1), 1)[:, None]
        return np.where(found[..., None], xy, centroid[:, None, :])
