"""One idempotent function that registers every environment id with Gymnasium."""

from __future__ import annotations

from typing import Any

from gymnasium.envs.registration import register, registry

#: Every environment id this package registers, with its entry point and registration kwargs.
ENV_SPECS: dict[str, dict[str, Any]] = {
    "BeltSorter-v0": {
        "entry_point": "track_envs.envs.belt_sorter:BeltSorterEnv",
        "max_episode_steps": 1500,
    },
    "BeltReplay-v0": {
        "entry_point": "track_envs.envs.belt_replay:BeltReplayEnv",
    },
    "DetectionReplay-v0": {
        "entry_point": "track_envs.envs.detection_replay:DetectionReplayEnv",
    },
    "KeypointWalkers-v0": {
        "entry_point": "track_envs.envs.keypoint_walkers:KeypointWalkersEnv",
        "max_episode_steps": 300,
    },
    "SineTarget-v0": {
        "entry_point": "track_envs.envs.single_target:SineTargetEnv",
    },
    "PiecewiseTarget-v0": {
        "entry_point": "track_envs.envs.single_target:PiecewiseTargetEnv",
    },
}

ENV_IDS: tuple[str, ...] = tuple(ENV_SPECS)


def register_envs() -> None:
    """Register every id in `ENV_SPECS`; ids already registered are left
    as they are."""
    for env_id, kwargs in ENV_SPECS.items():
        if env_id not in registry:
            register(id=env_id, **kwargs)
