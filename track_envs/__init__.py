"""track-envs: Gymnasium environments that simulate targets and a sensor and emit detections.

Importing the package registers every environment id once (idempotent)::

    import gymnasium as gym
    import track_envs

    env = gym.make("BeltSorter-v0")

Heavy modules (pymunk worlds, renderers, metrics) load only when an environment is made.
"""

from __future__ import annotations

from track_envs.infra import moved_modules
from track_envs.registration import ENV_IDS, register_envs

__all__ = ["ENV_IDS", "register_envs"]
__version__ = "0.1.0"

moved_modules.install()  # the old module paths, deprecated
register_envs()
