"""track-envs: Gymnasium environments that simulate targets and a sensor and emit detections.

Importing the package registers every environment id once (idempotent)::

    import gymnasium as gym
    import track_envs

    env = gym.make("BeltSorter-v0")

Heavy modules (pymunk worlds, renderers, metrics) load only when an environment is made.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports
from track_envs.registration import ENV_IDS, register_envs

if TYPE_CHECKING:
    from track_envs.values.detections import Detections, detection_sensor_spec
    from track_envs.values.poses import PoseStream, pose_sensor_spec
    from track_envs.values.tracks import Tracks
    from track_envs.values.types import Gaussian, SensorSpec

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)


__version__ = "0.1.0"

register_envs()
