"""Pose hypothesis motions: what the tracks of a multi-person pose tracker predict.

* :mod:`~predictors.pose.base`: the :class:`PoseMotion` protocol (per-track state changed in place,
  OKS scores instead of a Gaussian, whole 17-keypoint poses), its declared capabilities
  (:class:`PoseMotionCapability`) and :func:`centroid_fill`;
* :mod:`~predictors.pose.constant_velocity`: :class:`ConstantVelocityPose`;
* :mod:`~predictors.pose.registry`: :data:`POSE_MOTIONS` (the SMC motion of the pose LSTM lives in
  :mod:`predictors.pose_lstm.motion`). The pose trackers take the keywords of the settings they
  forward (each declared once) with :func:`track_envs.infra.registry.takes_keywords_of`.
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

__all__ = [
    "POSE_MOTIONS",
    "POSE_MOTION_DECLARATIONS",
    "ConstantVelocityPose",
    "PoseMotion",
    "PoseMotionCapability",
    "centroid_fill",
    "motion_models",
    "pose_motion_capability",
]
