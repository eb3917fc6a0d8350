"""Synthetic detection streams with known truth, for checks that no env scene isolates: each module
builds a [`SensorSpec`][track_envs.SensorSpec], the observations a tracker consumes and the truth
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

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
