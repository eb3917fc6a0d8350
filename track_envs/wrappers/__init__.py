"""Gymnasium wrappers for tracking environments."""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports
from track_envs.wrappers.record_tracking import RecordTracking
from track_envs.wrappers.tracking_metrics import TrackingMetrics

if TYPE_CHECKING:
    from track_envs.wrappers.tracking_metrics import default_metrics

#: The module of each name loaded on first access (``__getattr__``), so that importing
#: the package stays light.
_LAZY: dict[str, str] = {
    "default_metrics": "track_envs.wrappers.tracking_metrics",
}

__all__ = [
    "RecordTracking",
    "TrackingMetrics",
    "default_metrics",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
