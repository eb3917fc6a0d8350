"""Value types shared by environments, agents and files: the sensor specification and Gaussians
(`types`), detections, tracks and pose streams. Imports only
`track_envs.infra`."""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from track_envs.values.detections import Detections, detection_sensor_spec
    from track_envs.values.keypoints import KEYPOINT_NAMES, SKELETON_EDGES
    from track_envs.values.poses import PoseStream, pose_observation, pose_sensor_spec
    from track_envs.values.tracks import Tracks, carried_boxes
    from track_envs.values.types import Gaussian, SensorSpec

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
