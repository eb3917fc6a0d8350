"""The pose-tracking loop of Okada et al. (2020), Algorithm 1, with a pluggable motion hypothesis.

:class:`PoseTracker` is the loop every keypoint tracker here shares. Every frame, for the ``n``
active tracks and the ``m`` detected poses:

1. **predict**: the motion hypothesis (:class:`predictors.pose.base.PoseMotion`) predicts every
   track's next pose — one pose per track
   (:class:`predictors.pose.constant_velocity.ConstantVelocityPose`) or a cloud of particles per
   track (:class:`predictors.pose_lstm.motion.SmcPoseMotion`);
2. **similarity**: the motion scores every track against every detection, an (n, m) matrix of
   OKS values (for one pose: OKS; for particles: the elite-weighted mean OKS), with the detection's
   area ``area_factor · max(w, h)²`` from its keypoint bounding box;
3. **associate**: Hungarian (or greedy) assignment on ``1 − score``; pairs with
   ``score < oks_threshold`` are not allowed;
4. **update**: the motion takes the detection of every matched track; its lifetime count
   ``l ← min(l + 1, 30)``; an unmatched track coasts with ``l ← l − 1`` and is deactivated when
   ``l < 0``;
5. **initiate**: a new track (lifetime ``initial_lifetime``) from every unmatched detection, up
   to ``max_active`` active tracks (``F_max``).

The report holds the tracks updated or started this frame (as Algorithm 1 outputs the detected
poses with their track ids), or every active track with ``report_coasting=True``.

``PoseBaselineAgent`` ("pose-baseline") is the loop with
:class:`~predictors.pose.constant_velocity.ConstantVelocityPose`: the tracker
Okada et al. (2020) improve on (the Simple-Baseline tracker of Xiao et al., ECCV 2018, with the
lifetime bookkeeping of Algorithm 1).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from agents.tracking.assign import assign_greedy, assign_hungarian
from predictors.pose import ConstantVelocityPose, PoseMotion
from track_envs.metrics.keypoints import NUM_KEYPOINTS
from track_envs.observation import check_observation
from track_envs.report import pack_report
from track_envs.types import SensorSpec

MAX_LIFETIME = 30


class PoseTracker:
    """The pose-tracking loop (Okada et al. 2020, Algorithm 1): OKS scores, matching, lifetimes, births.

    Args:
        motion: The motion hypothesis (what the tracks predict), a
            :class:`~predictors.pose.base.PoseMotion`.
        oks_threshold: Smallest score at which a track and a detected pose may be matched.
        assignment: ``"hungarian"`` (optimal) or ``"greedy"`` (best pairs first).
        keypoint_threshold: Detected keypoints with a score at or below this are ignored.
        min_pose_score: Detections whose mean score over detected keypoints is below this are ignored.
        min_keypoints: Detections with fewer usable keypoints are ignored.
        initial_lifetime: Lifetime count of a new track.
        area_factor: Object area as a fraction of the squared longer side of the detection's
            keypoint bounding box.
        report_coasting: Report every active track, not only those with a detection this frame.
        max_active: Most active tracks (``F_max``); detections beyond it start no track.
    """

    #: Tracks poses (17, 2), not points (see :func:`agents.agent_applies_to`).
    position_rank = 2

    def __init__(
        self,
        motion: PoseMotion,
        *,
        oks_threshold: float = 0.3,
        assignment: str = "hungarian",
        keypoint_threshold: float = 0.0,
        min_pose_score: float = 0.0,
        min_keypoints: int = 1,
        initial_lifetime: int = 0,
        area_factor: float = 0.25,
        report_coasting: bool = False,
        max_active: int | None = None,
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
        if not (np.isfinite(area_factor) and area_factor > 0):
            raise ValueError(f"area_factor must be positive and finite, got {area_factor!r}")
        if max_active is not None and not (isinstance(max_active, int) and max_active >= 1):
            raise ValueError(f"max_active must be None or an integer >= 1, got {max_active!r}")
        self.motion = motion
        self.oks_threshold = float(oks_threshold)
        self.assign = assign_hungarian if assignment == "hungarian" else assign_greedy
        self.keypoint_threshold = float(keypoint_threshold)
        self.min_pose_score = float(min_pose_score)
        self.min_keypoints = min_keypoints
        self.initial_lifetime = initial_lifetime
        self.area_factor = float(area_factor)
        self.report_coasting = bool(report_coasting)
        self.max_active = max_active
        self._spec: SensorSpec | None = None

    def reset(self, spec: SensorSpec, *, seed: int | None = None) -> None:
        """Start a new episode; ``seed`` seeds the motion's random stream (if it has one)."""
        self._spec = spec
        self.ids = np.zeros(0, dtype=np.int64)
        self.lifetime = np.zeros(0, dtype=np.int64)
        self._next_id = 0
        self.motion.reset(spec, np.random.default_rng(seed))

    def act(self, obs: Mapping[str, NDArray]) -> dict[str, NDArray]:
        """One frame: predict, associate by score, update, initiate; the report of the tracks."""
        spec = self._spec
        if spec is None:
            raise RuntimeError("act() called before reset(spec); call agent.reset(env.unwrapped.sensor_spec)")
        rows, z = check_observation(obs, spec, (NUM_KEYPOINTS, 3))
        found = z[..., 2] > self.keypoint_threshold  # (m, 17)
        count = found.sum(axis=1)
        mean_score = np.where(found, z[..., 2], 0.0).sum(axis=1) / np.maximum(count, 1)
        usable = (count >= self.min_keypoints) & (mean_score >= self.min_pose_score)
        rows, xy, found = rows[usable], z[usable, :, :2], found[usable]
        self.motion.predict()
        sim = self.motion.score(xy, found, self._areas(xy, found))
        ti, di = self.assign(1.0 - sim, 1.0 - self.oks_threshold)
        self.motion.update(ti, di, xy, found)
        matched = np.zeros(len(self.ids), dtype=bool)
        matched[ti] = True
        lifetime = np.where(matched, np.minimum(self.lifetime + 1, MAX_LIFETIME), self.lifetime - 1)
        detection = np.full(len(self.ids), -1, dtype=np.int64)
        detection[ti] = rows[di]
        # births from the detections left over (up to max_active tracks)
        free = np.ones(len(rows), dtype=bool)
        free[di] = False
        if self.max_active is not None:
            room = max(self.max_active - int(np.sum(lifetime >= 0)), 0)
            free[np.flatnonzero(free)[room:]] = False
        self.motion.birth(xy[free], found[free])
        k = int(free.sum())
        self.ids = np.concatenate([self.ids, np.arange(self._next_id, self._next_id + k, dtype=np.int64)])
        self._next_id += k
        self.lifetime = np.concatenate([lifetime, np.full(k, self.initial_lifetime, dtype=np.int64)])
        detection = np.concatenate([detection, rows[free]])
        shown = np.concatenate([matched, np.ones(k, dtype=bool)])
        alive = self.lifetime >= 0
        self.motion.keep(alive)
        self.ids, self.lifetime = self.ids[alive], self.lifetime[alive]
        shown, detection = shown[alive], detection[alive]
        out = np.ones(len(self.ids), dtype=bool) if self.report_coasting else shown
        out_rows = np.flatnonzero(out)
        if len(out_rows) > spec.max_tracks:  # keep the tracks with a detection, then the longest-lived
            order = np.lexsort((-self.lifetime[out_rows], ~shown[out_rows]))
            out_rows = np.sort(out_rows[order[: spec.max_tracks]])
        poses = self.motion.poses()
        return pack_report(self.ids[out_rows], poses[out_rows], detection[out_rows], spec.max_tracks)

    def _areas(self, xy: NDArray, found: NDArray) -> NDArray[np.float64]:
        """Object areas (m,) of detected poses: ``area_factor · max(w, h)²`` of their keypoint box."""
        return detection_areas(xy, found, self.area_factor)


def detection_areas(xy: NDArray, found: NDArray, area_factor: float) -> NDArray[np.float64]:
    """Object areas (m,) of detected poses: ``area_factor · max(w, h)²`` of their keypoint box."""
    if len(xy) == 0:
        return np.zeros(0)
    f = found[..., None]
    span = np.max(np.where(f, xy, -np.inf), axis=1) - np.min(np.where(f, xy, np.inf), axis=1)
    span = np.where(np.isfinite(span), span, 0.0)
    return area_factor * np.maximum(np.max(span, axis=1), 1.0) ** 2


class PoseBaselineAgent(PoseTracker):
    """Single-hypothesis pose tracker (the baseline of Okada et al. 2020): constant velocity, OKS, Hungarian.

    The :class:`PoseTracker` loop with the
    :class:`~predictors.pose.constant_velocity.ConstantVelocityPose` motion.

    Args:
        oks_threshold, assignment, keypoint_threshold, min_pose_score, min_keypoints,
            initial_lifetime, area_factor, report_coasting, max_active: see :class:`PoseTracker`.
        smoothing: see :class:`~predictors.pose.constant_velocity.ConstantVelocityPose`.
    """

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
        max_active: int | None = None,
    ) -> None:
        super().__init__(
            ConstantVelocityPose(smoothing),
            oks_threshold=oks_threshold,
            assignment=assignment,
            keypoint_threshold=keypoint_threshold,
            min_pose_score=min_pose_score,
            min_keypoints=min_keypoints,
            initial_lifetime=initial_lifetime,
            area_factor=area_factor,
            report_coasting=report_coasting,
            max_active=max_active,
        )
