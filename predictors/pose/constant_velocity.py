"""Constant keypoint velocity, one pose hypothesis per track: the motion of ``pose-baseline``.

A [`PoseMotion`][predictors.pose.base.PoseMotion] that predicts ``ŷ_t = y_{t−1} + v_{t−1}`` per keypoint
(the tracker Okada et al. 2020 improve on: the Simple-Baseline tracker of Xiao et al., ECCV 2018,
with a constant velocity standing in for optical-flow propagation). Deterministic.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from predictors.pose.base import centroid_fill
from track_envs.metrics.keypoints import NUM_KEYPOINTS, pairwise_oks
from track_envs.values.types import SensorSpec


class ConstantVelocityPose:
    """Constant keypoint velocity, one hypothesis per track (the baseline's motion).

    ``ŷ_t = y_{t−1} + v_{t−1}`` per keypoint (a stand-in for optical-flow propagation). A matched
    track takes the detected keypoints and keeps its prediction for the others; its velocity is an
    exponential average (``smoothing``) of the displacements, where a keypoint not detected in
    both of the last two updates moves with the mean displacement of those that were. The score
    is the OKS of the prediction over the keypoints the detection holds that the track has seen
    before. A new track's undetected keypoints start at the centroid of its detected ones.

    Args:
        smoothing: Weight of the newest displacement in the keypoint velocity (1: the last
            displacement alone; below 1 an exponential average, which damps detector noise).
    """

    def __init__(self, smoothing: float = 0.5) -> None:
        if not 0.0 < smoothing <= 1.0:
            raise ValueError(f"smoothing must be in (0, 1], got {smoothing!r}")
        self.smoothing = float(smoothing)

    def reset(self, spec: SensorSpec, rng: np.random.Generator) -> None:
        """Forget every track (the motion is deterministic; ``rng`` is unused)."""
        del spec, rng
        self.pose = np.zeros((0, NUM_KEYPOINTS, 2))  # last pose estimate
        self.velocity = np.zeros((0, NUM_KEYPOINTS, 2))  # per keypoint, px / frame
        self.seen = np.zeros((0, NUM_KEYPOINTS), dtype=bool)  # keypoint detected in the last update
        self.known = np.zeros((0, NUM_KEYPOINTS), dtype=bool)  # keypoint detected at least once
        self.predicted = self.pose

    def predict(self) -> None:
        """``ŷ = y + v`` for every track."""
        self.predicted = self.pose + self.velocity

    def score(self, xy: NDArray, found: NDArray, area: NDArray, floor: float = 0.0) -> NDArray[np.float64]:
        """OKS (n, m) of the predictions over keypoints detected now and seen before (every pair,
        whatever ``floor``)."""
        return pairwise_oks(self.predicted, xy, found, area, a_valid=self.known)

    def update(self, ti: NDArray, di: NDArray, xy: NDArray, found: NDArray) -> None:
        """Matched tracks take the detected keypoints; all others coast on the prediction."""
        xy, found = xy[di], found[di]
        predicted = self.predicted
        pose = predicted.copy()
        new_pose = np.where(found[..., None], xy, predicted[ti])
        velocity = self.velocity.copy()
        step = self._velocity(new_pose - self.pose[ti], found & self.seen[ti], self.velocity[ti])
        velocity[ti] = self.smoothing * step + (1 - self.smoothing) * self.velocity[ti]
        seen = np.zeros_like(self.seen)
        seen[ti] = found
        known = self.known.copy()
        known[ti] |= found
        pose[ti] = new_pose
        self.pose, self.velocity, self.seen, self.known = pose, velocity, seen, known

    def birth(self, xy: NDArray, found: NDArray) -> None:
        """New tracks at rest, undetected keypoints at the detected centroid."""
        born = centroid_fill(xy, found)
        self.pose = np.concatenate([self.pose, born])
        self.velocity = np.concatenate([self.velocity, np.zeros_like(born)])
        self.seen = np.concatenate([self.seen, found])
        self.known = np.concatenate([self.known, found])

    def keep(self, alive: NDArray[np.bool_]) -> None:
        """Drop the deactivated tracks."""
        self.pose, self.velocity = self.pose[alive], self.velocity[alive]
        self.seen, self.known = self.seen[alive], self.known[alive]

    def poses(self) -> NDArray[np.float64]:
        """The pose estimates (n, 17, 2)."""
        return self.pose

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
