"""Gymnasium wrappers for tracking environments."""

from track_envs.wrappers.record_tracking import RecordTracking
from track_envs.wrappers.tracking_metrics import TrackingMetrics

__all__ = ["RecordTracking", "TrackingMetrics"]
