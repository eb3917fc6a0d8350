"""Gymnasium wrappers for tracking environments."""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

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


def __getattr__(name: str) -> Any:
    """Import ``name`` from its module on first access (the module stays unloaded until then)."""
    home = _LAZY.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = vars(import_module(home))[name]
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
