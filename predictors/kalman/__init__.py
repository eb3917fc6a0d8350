"""Kalman filter predictors (constant velocity, constant acceleration, random walk), batched over tracks."""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

from predictors.kalman.predictor import KalmanPredictor, KalmanState

if TYPE_CHECKING:
    from predictors.kalman.rollout import kalman_crossings

#: The module of each name loaded on first access (``__getattr__``), so that importing
#: the package stays light.
_LAZY: dict[str, str] = {
    "kalman_crossings": "predictors.kalman.rollout",
}

__all__ = [
    "KalmanPredictor",
    "KalmanState",
    "kalman_crossings",
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
