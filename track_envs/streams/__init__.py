"""Synthetic detection streams with known truth, for checks that no env scene isolates: each module
builds a :class:`~track_envs.values.types.SensorSpec`, the observations a tracker consumes and the truth
to score it by."""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from track_envs.streams.constant_velocity import (
        ConstantVelocityStream,
        constant_density,
        constant_velocity_stream,
        score_tracker,
    )
    from track_envs.streams.merge_events import MergeEventStream, merge_event_streams
    from track_envs.streams.merge_scenes import MergeScene, merge_scene
    from track_envs.streams.merge_scoring import EventScores, score_events

#: The module of each name loaded on first access (``__getattr__``), so that importing
#: the package stays light.
_LAZY: dict[str, str] = {
    "ConstantVelocityStream": "track_envs.streams.constant_velocity",
    "constant_density": "track_envs.streams.constant_velocity",
    "constant_velocity_stream": "track_envs.streams.constant_velocity",
    "score_tracker": "track_envs.streams.constant_velocity",
    "MergeEventStream": "track_envs.streams.merge_events",
    "merge_event_streams": "track_envs.streams.merge_events",
    "MergeScene": "track_envs.streams.merge_scenes",
    "merge_scene": "track_envs.streams.merge_scenes",
    "EventScores": "track_envs.streams.merge_scoring",
    "score_events": "track_envs.streams.merge_scoring",
}

__all__ = [
    "ConstantVelocityStream",
    "EventScores",
    "MergeEventStream",
    "MergeScene",
    "constant_density",
    "constant_velocity_stream",
    "merge_event_streams",
    "merge_scene",
    "score_events",
    "score_tracker",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
