"""Environment classes. Make them with ``gymnasium.make`` after ``import track_envs``."""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from track_envs.envs.base import TrackingEnv, Truth
    from track_envs.envs.belt_physics import PARTICLE_KINDS, BeltParams
    from track_envs.envs.belt_replay import BeltReplayEnv, sample_recording_path
    from track_envs.envs.belt_sorter import BeltSorterEnv
    from track_envs.envs.detection_replay import (
        SAMPLE_NOISE_STD,
        SAMPLE_READ_OPTIONS,
        DetectionReplayEnv,
        sample_detections_path,
    )
    from track_envs.envs.drift import DRIFT_PRESETS, RandomWalk, SensorDrift, Steps, resolve_drift
    from track_envs.envs.keypoint_walkers import KeypointWalkersEnv
    from track_envs.envs.nozzle import recorded_crossings
    from track_envs.envs.pose_recording import record_keypoint_walkers
    from track_envs.envs.recording import record_belt_sorter
    from track_envs.envs.rendering import Canvas, LegendEntry, WorldToPixel
    from track_envs.envs.single_target import PiecewiseTargetEnv, SineTargetEnv, SingleTargetEnv

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
