"""Pose hypothesis motions: what the tracks of a multi-person pose tracker predict.

* [`base`][predictors.pose.base]: the [`PoseMotion`][predictors.pose.base.PoseMotion] protocol (per-track
state changed in place,
  OKS scores instead of a Gaussian, whole 17-keypoint poses), its declared capabilities
  ([`PoseMotionCapability`][predictors.pose.base.PoseMotionCapability]) and
  [`centroid_fill`][predictors.pose.base.centroid_fill];
* [`constant_velocity`][predictors.pose.constant_velocity]:
[`ConstantVelocityPose`][predictors.pose.constant_velocity.ConstantVelocityPose];
* [`registry`][predictors.pose.registry]: [`POSE_MOTIONS`][predictors.pose.POSE_MOTIONS] (the SMC motion of
the pose LSTM lives in
  [`predictors.pose_lstm.motion`][predictors.pose_lstm.motion]). The pose trackers take the keywords of the
  settings they forward (each declared once) with
  [`track_envs.infra.registry.takes_keywords_of`][track_envs.infra.registry.takes_keywords_of].
"""

from predictors.pose.base import (
    POSE_MOTION_DECLARATIONS,
    PoseMotion,
    PoseMotionCapability,
    centroid_fill,
    pose_motion_capability,
)
from predictors.pose.constant_velocity import ConstantVelocityPose
from predictors.pose.registry import POSE_MOTIONS, motion_models
from track_envs.infra.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
