"""The pose-tracking loop of Okada et al. (2020), Algorithm 1, with a pluggable motion hypothesis.

[`PoseTracker`][agents.pose.tracker.PoseTracker] is the loop every keypoint tracker here shares. Every frame,
for the ``n`` active tracks and the ``m`` detected poses:

1. **predict**: the motion hypothesis ([`predictors.pose.base.PoseMotion`][predictors.pose.base.PoseMotion])
predicts every
   track's next pose — one pose per track
   ([`predictors.pose.constant_velocity.ConstantVelocityPose`][predictors.pose.constant_velocity.ConstantVelocityPose])
   or a cloud of particles per track
   ([`predictors.pose_lstm.motion.SmcPoseMotion`][predictors.pose_lstm.motion.SmcPoseMotion]);
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
[`ConstantVelocityPose`][predictors.pose.constant_velocity.ConstantVelocityPose]: the tracker
Okada et al. (2020) improve on (the Simple-Baseline tracker of Xiao et al., ECCV 2018, with the
lifetime bookkeeping of Algorithm 1).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.base import AgentTraits
from agents.tracking.assign import assign_greedy, assign_hungarian
from predictors.pose import POSE_MOTION_DECLARATIONS, ConstantVelocityPose, PoseMotion
from track_envs.contracts.observation import check_observation
from track_envs.contracts.report import pack_report
from track_envs.infra.registry import split_keywords, takes_keywords_of
from track_envs.metrics.keypoints import NUM_KEYPOINTS
from track_envs.values.types import SensorSpec

MAX_LIFETIME = 30


@dataclass(frozen=True)
class PoseTrackingOptions:
    """The settings of the pose-tracking loop ([`PoseTracker`][agents.pose.tracker.PoseTracker]; keywords of
    every pose agent).

    Attributes:
        oks_threshold: Smallest score at which a track and a detected pose may be matched, in (0, 1).
        assignment: ``"hungarian"`` (optimal) or ``"greedy"`` (best pairs first).
        keypoint_threshold: Detected keypoints with a score at or below this are ignored, in [0, 1).
        min_pose_score: Detections whose mean score over detected keypoints is below this are
            ignored, in [0, 1].
        min_keypoints: Detections with fewer usable keypoints are ignored, in [1, 17].
        initial_lifetime: Lifetime count of a new track, in [0, 30].
        area_factor: Object area as a fraction of the squared longer side of the detection's
            keypoint bounding box (> 0).
        report_coasting: Report every active track, not only those with a detection this frame.
        max_active: Most active tracks (``F_max``); detections beyond it start no track
            (``None``: no limit).
    """

    oks_threshold: float = 0.3
    assignment: str = "hungarian"
    keypoint_threshold: float = 0.0
    min_pose_score: float = 0.0
    min_keypoints: int = 1
    initial_lifetime: int = 0
    area_factor: float = 0.25
    report_coasting: bool = False
    max_active: int | None = None

    def __post_init__(self) -> None:
        if not 0.0 < self.oks_threshold < 1.0:
            raise ValueError(
                f"oks_threshold must be in (0, 1) (at 0 poses with nothing in common would match), "
                f"got {self.oks_threshold!r}"
            )
        if self.assignment not in ("hungarian", "greedy"):
            raise ValueError(f"assignment must be 'hungarian' or 'greedy', got {self.assignment!r}")
        if not 0.0 <= self.keypoint_threshold < 1.0:
            raise ValueError(f"keypoint_threshold must be in [0, 1), got {self.keypoint_threshold!r}")
        if not 0.0 <= self.min_pose_score <= 1.0:
            raise ValueError(f"min_pose_score must be in [0, 1], got {self.min_pose_score!r}")
        if not (isinstance(self.min_keypoints, int) and 1 <= self.min_keypoints <= NUM_KEYPOINTS):
            raise ValueError(f"min_keypoints must be an integer in [1, 17], got {self.min_keypoints!r}")
        lifetime = self.initial_lifetime
        if not (isinstance(lifetime, int) and 0 <= lifetime <= MAX_LIFETIME):
            raise ValueError(f"initial_lifetime must be an integer in [0, {MAX_LIFETIME}], got {lifetime!r}")
        if not (np.isfinite(self.area_factor) and self.area_factor > 0):
            raise ValueError(f"area_factor must be positive and finite, got {self.area_factor!r}")
        if self.max_active is not None and not (isinstance(self.max_active, int) and self.max_active >= 1):
            raise ValueError(f"max_active must be None or an integer >= 1, got {self.max_active!r}")
        for name in ("oks_threshold", "keypoint_threshold", "min_pose_score", "area_factor"):
            object.__setattr__(self, name, float(getattr(self, name)))
        object.__setattr__(self, "report_coasting", bool(self.report_coasting))


class PoseTracker:
    """The pose-tracking loop (Okada et al. 2020, Algorithm 1): OKS scores, matching, lifetimes, births.

    Args:
        motion: The motion hypothesis (what the tracks predict), a
            [`PoseMotion`][predictors.pose.base.PoseMotion].
        options: The keywords of [`PoseTrackingOptions`][agents.pose.tracker.PoseTrackingOptions]
            (``oks_threshold``, ``assignment``, …, ``max_active``), kept as `options`.
    """

    #: Tracks poses (17, 2), not points (see [`agents.agent_applies_to`][agents.agent_applies_to]).
    traits = AgentTraits(position_rank=2)

    @takes_keywords_of(PoseTrackingOptions)
    def __init__(self, motion: PoseMotion, **options: Any) -> None:
        self.options = PoseTrackingOptions(**options)
        POSE_MOTION_DECLARATIONS.declared(motion)  # a malformed declaration fails here, named
        self.motion = motion
        self.assign = assign_hungarian if self.options.assignment == "hungarian" else assign_greedy
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
        o = self.options
        rows, z = check_observation(obs, spec, (NUM_KEYPOINTS, 3))
        found = z[..., 2] > o.keypoint_threshold  # (m, 17)
        count = found.sum(axis=1)
        mean_score = np.where(found, z[..., 2], 0.0).sum(axis=1) / np.maximum(count, 1)
        usable = (count >= o.min_keypoints) & (mean_score >= o.min_pose_score)
        rows, xy, found = rows[usable], z[usable, :, :2], found[usable]
        self.motion.predict()
        sim = self.motion.score(xy, found, self._areas(xy, found), floor=o.oks_threshold)
        ti, di = self.assign(1.0 - sim, 1.0 - o.oks_threshold)
        self.motion.update(ti, di, xy, found)
        matched = np.zeros(len(self.ids), dtype=bool)
        matched[ti] = True
        lifetime = np.where(matched, np.minimum(self.lifetime + 1, MAX_LIFETIME), self.lifetime - 1)
        detection = np.full(len(self.ids), -1, dtype=np.int64)
        detection[ti] = rows[di]
        # births from the detections left over (up to max_active tracks)
        free = np.ones(len(rows), dtype=bool)
        free[di] = False
        if o.max_active is not None:
            room = max(o.max_active - int(np.sum(lifetime >= 0)), 0)
            free[np.flatnonzero(free)[room:]] = False
        self.motion.birth(xy[free], found[free])
        k = int(free.sum())
        self.ids = np.concatenate([self.ids, np.arange(self._next_id, self._next_id + k, dtype=np.int64)])
        self._next_id += k
        self.lifetime = np.concatenate([lifetime, np.full(k, o.initial_lifetime, dtype=np.int64)])
        detection = np.concatenate([detection, rows[free]])
        shown = np.concatenate([matched, np.ones(k, dtype=bool)])
        alive = self.lifetime >= 0
        self.motion.keep(alive)
        self.ids, self.lifetime = self.ids[alive], self.lifetime[alive]
        shown, detection = shown[alive], detection[alive]
        out = np.ones(len(self.ids), dtype=bool) if o.report_coasting else shown
        out_rows = np.flatnonzero(out)
        if len(out_rows) > spec.max_tracks:  # keep the tracks with a detection, then the longest-lived
            order = np.lexsort((-self.lifetime[out_rows], ~shown[out_rows]))
            out_rows = np.sort(out_rows[order[: spec.max_tracks]])
        poses = self.motion.poses()
        return pack_report(self.ids[out_rows], poses[out_rows], detection[out_rows], spec.max_tracks)

    def _areas(self, xy: NDArray, found: NDArray) -> NDArray[np.float64]:
        """Object areas (m,) of detected poses: ``area_factor · max(w, h)²`` of their keypoint box."""
        return detection_areas(xy, found, self.options.area_factor)


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

    The [`PoseTracker`][agents.pose.tracker.PoseTracker] loop with the
    [`ConstantVelocityPose`][predictors.pose.constant_velocity.ConstantVelocityPose] motion.

    Args:
        options: The keywords of
            [`ConstantVelocityPose`][predictors.pose.constant_velocity.ConstantVelocityPose] (``smoothing``)
            and of [`PoseTrackingOptions`][agents.pose.tracker.PoseTrackingOptions]; the signature lists them
            with their defaults.
    """

    @takes_keywords_of(ConstantVelocityPose, PoseTrackingOptions)
    def __init__(self, **options: Any) -> None:
        motion, loop = split_keywords(ConstantVelocityPose, options)
        super().__init__(ConstantVelocityPose(**motion), **loop)
