"""Gymnasium wrappers for tracking environments."""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports
from track_envs.wrappers.record_tracking import RecordTracking
from track_envs.wrappers.tracking_metrics import TrackingMetrics

if TYPE_CHECKING:
    from track_envs.wrappers.tracking_metrics import default_metrics

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
