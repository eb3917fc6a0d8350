"""The pose hypothesis motion: what the tracks of a multi-person pose tracker predict.

A pose motion is the motion half of the pose-tracking loop of Okada et al. (2020), Algorithm 1
([`agents.pose.tracker.PoseTracker`][agents.pose.tracker.PoseTracker]); the loop keeps the ids, lifetimes and
matching. It differs from a [`predictors.base.Predictor`][predictors.Predictor] in three ways:

* **it owns its state and changes it in place.** The motion holds one row per active track
  (a pose, or a cloud of particles per track) and the loop addresses the rows by index:
  [`PoseMotion.update`][predictors.pose.base.PoseMotion.update] with the matched rows,
  [`PoseMotion.birth`][predictors.pose.base.PoseMotion.birth] appends rows,
  [`PoseMotion.keep`][predictors.pose.base.PoseMotion.keep] drops rows. A Predictor instead returns a new
  immutable ``BatchState`` that the tracker owns.
* **it scores, not a Gaussian.** There is no predicted measurement mean and covariance to gate
  with; [`PoseMotion.score`][predictors.pose.base.PoseMotion.score] gives an (n, m) similarity in [0, 1] of
  every track to every detected pose (OKS, or for particles the elite-weighted mean OKS), which the loop
  matches on.
* **it moves whole 17-keypoint hypotheses**, with detected and undetected keypoints (a detection
  holds a subset of the 17), not points of dimension ``D``.

The motions: [`ConstantVelocityPose`][predictors.pose.constant_velocity.ConstantVelocityPose] (one pose per
track, ``pose-baseline``) and
[`predictors.pose_lstm.motion.SmcPoseMotion`][predictors.pose_lstm.motion.SmcPoseMotion] (particles of pose
queues moved by the pose LSTM, ``pose-smc``).

Optional capabilities are declared as every plug-in's are
([`track_envs.infra.declared`][track_envs.infra.declared]): the class attribute
``capabilities: frozenset[PoseMotionCapability]``, asked with
[`pose_motion_capability`][predictors.pose.base.pose_motion_capability]. The loop needs nothing beyond the
core today, so [`PoseMotionCapability`][predictors.pose.base.PoseMotionCapability] has no member yet and every
motion declares nothing; the loop checks a motion's declaration when it is built
([`POSE_MOTION_DECLARATIONS`][predictors.pose.base.POSE_MOTION_DECLARATIONS]), and a capability added later
gets its protocol in that table.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.declared import Declarations
from track_envs.values.types import SensorSpec


class PoseMotion(Protocol):
    """The motion hypothesis of a pose tracker: per-track state, batched over tracks, changed in place.

    The loop calls, each frame, [`predict`][predictors.pose.base.PoseMotion.predict],
    [`score`][predictors.pose.base.PoseMotion.score], [`update`][predictors.pose.base.PoseMotion.update]
    (matched rows), [`birth`][predictors.pose.base.PoseMotion.birth] (new rows appended) and
    [`keep`][predictors.pose.base.PoseMotion.keep] (surviving rows), in that order; row ``i`` of the motion is
    track ``i`` of the loop.
    """

    def reset(self, spec: SensorSpec, rng: np.random.Generator) -> None:
        """Forget every track (a new episode); ``rng`` is the random stream of the episode."""

    def predict(self) -> None:
        """Predict every track's pose at the current frame."""

    def score(self, xy: NDArray, found: NDArray, area: NDArray, floor: float = 0.0) -> NDArray[np.float64]:
        """(n, m) similarity in [0, 1] of the predictions to the detections ``xy`` (m, 17, 2)
        with detected keypoints ``found`` (m, 17) and areas ``area`` (m,). A pair whose similarity
        is below ``floor`` may score anything below it (the loop matches no such pair)."""
        ...

    def update(self, ti: NDArray, di: NDArray, xy: NDArray, found: NDArray) -> None:
        """Tracks ``ti`` (k,) take the detections ``di`` (k,) of ``xy`` (m, 17, 2) with keypoints
        ``found`` (m, 17) (the rows and columns of [`score`][predictors.pose.base.PoseMotion.score]); the
        others coast."""

    def birth(self, xy: NDArray, found: NDArray) -> None:
        """Append one track per detection ``xy`` (k, 17, 2) with keypoints ``found`` (k, 17)."""

    def keep(self, alive: NDArray[np.bool_]) -> None:
        """Keep the tracks where ``alive`` (n,) is true."""

    def poses(self) -> NDArray[np.float64]:
        """(n, 17, 2) pose estimates after the update (what the report shows)."""
        ...


class PoseMotionCapability(StrEnum):
    """The optional capabilities a pose motion class may declare (none yet; module docstring)."""


#: The capabilities of pose motions and their protocols
#: ([`track_envs.infra.declared`][track_envs.infra.declared]).
POSE_MOTION_DECLARATIONS: Declarations[PoseMotionCapability] = Declarations(
    PoseMotionCapability, {}, core=PoseMotion
)


def pose_motion_capability(motion: object, which: PoseMotionCapability) -> Any:
    """``motion``, typed as the protocol of capability ``which``, when its class declares it; else
    ``None``.

    Raises:
        TypeError: if the class declares ``which`` but lacks a member of its protocol (named).
    """
    return POSE_MOTION_DECLARATIONS.get(motion, which)


def centroid_fill(xy: NDArray, found: NDArray) -> NDArray[np.float64]:
    """Full poses (k, 17, 2): undetected keypoints at the centroid of the detected ones.

    The start of a new track in every pose motion: ``ŷ_j = x_j`` for a detected keypoint ``j``,
    else ``(1/|F|) Σ_{i∈F} x_i`` over the detected keypoints ``F`` (the origin when ``F`` is empty).
    """
    centroid = np.sum(xy * found[..., None], axis=1) / np.maximum(found.sum(axis=1), 1)[:, None]
    return np.where(found[..., None], xy, centroid[:, None, :])
