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

#: The module of each name loaded on first access (``__getattr__``), so that importing
#: the package stays light.
_LAZY: dict[str, str] = {
    "TrackingEnv": "track_envs.envs.base",
    "Truth": "track_envs.envs.base",
    "BeltParams": "track_envs.envs.belt_physics",
    "PARTICLE_KINDS": "track_envs.envs.belt_physics",
    "BeltReplayEnv": "track_envs.envs.belt_replay",
    "sample_recording_path": "track_envs.envs.belt_replay",
    "BeltSorterEnv": "track_envs.envs.belt_sorter",
    "DetectionReplayEnv": "track_envs.envs.detection_replay",
    "SAMPLE_NOISE_STD": "track_envs.envs.detection_replay",
    "SAMPLE_READ_OPTIONS": "track_envs.envs.detection_replay",
    "sample_detections_path": "track_envs.envs.detection_replay",
    "DRIFT_PRESETS": "track_envs.envs.drift",
    "RandomWalk": "track_envs.envs.drift",
    "SensorDrift": "track_envs.envs.drift",
    "Steps": "track_envs.envs.drift",
    "resolve_drift": "track_envs.envs.drift",
    "KeypointWalkersEnv": "track_envs.envs.keypoint_walkers",
    "recorded_crossings": "track_envs.envs.nozzle",
    "record_keypoint_walkers": "track_envs.envs.pose_recording",
    "record_belt_sorter": "track_envs.envs.recording",
    "Canvas": "track_envs.envs.rendering",
    "LegendEntry": "track_envs.envs.rendering",
    "WorldToPixel": "track_envs.envs.rendering",
    "PiecewiseTargetEnv": "track_envs.envs.single_target",
    "SineTargetEnv": "track_envs.envs.single_target",
    "SingleTargetEnv": "track_envs.envs.single_target",
}

__all__ = [
    "DRIFT_PRESETS",
    "PARTICLE_KINDS",
    "SAMPLE_NOISE_STD",
    "SAMPLE_READ_OPTIONS",
    "BeltParams",
    "BeltReplayEnv",
    "BeltSorterEnv",
    "Canvas",
    "DetectionReplayEnv",
    "KeypointWalkersEnv",
    "LegendEntry",
    "PiecewiseTargetEnv",
    "RandomWalk",
    "SensorDrift",
    "SineTargetEnv",
    "SingleTargetEnv",
    "Steps",
    "TrackingEnv",
    "Truth",
    "WorldToPixel",
    "record_belt_sorter",
    "record_keypoint_walkers",
    "recorded_crossings",
    "resolve_drift",
    "sample_detections_path",
    "sample_recording_path",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
