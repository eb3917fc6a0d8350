"""Value types shared by environments, agents and files: the sensor specification and Gaussians
(:mod:`~track_envs.values.types`), detections, tracks and pose streams. Imports only
:mod:`track_envs.infra`."""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from track_envs.values.detections import Detections, detection_sensor_spec
    from track_envs.values.keypoints import KEYPOINT_NAMES, SKELETON_EDGES
    from track_envs.values.poses import PoseStream, pose_observation, pose_sensor_spec
    from track_envs.values.tracks import Tracks, carried_boxes
    from track_envs.values.types import Gaussian, SensorSpec

#: The module of each name loaded on first access (``__getattr__``), so that importing
#: the package stays light.
_LAZY: dict[str, str] = {
    "Detections": "track_envs.values.detections",
    "detection_sensor_spec": "track_envs.values.detections",
    "KEYPOINT_NAMES": "track_envs.values.keypoints",
    "SKELETON_EDGES": "track_envs.values.keypoints",
    "PoseStream": "track_envs.values.poses",
    "pose_observation": "track_envs.values.poses",
    "pose_sensor_spec": "track_envs.values.poses",
    "Tracks": "track_envs.values.tracks",
    "carried_boxes": "track_envs.values.tracks",
    "Gaussian": "track_envs.values.types",
    "SensorSpec": "track_envs.values.types",
}

__all__ = [
    "KEYPOINT_NAMES",
    "SKELETON_EDGES",
    "Detections",
    "Gaussian",
    "PoseStream",
    "SensorSpec",
    "Tracks",
    "carried_boxes",
    "detection_sensor_spec",
    "pose_observation",
    "pose_sensor_spec",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
