"""Kalman filter predictors (constant velocity, constant acceleration, random walk), batched over tracks."""

from __future__ import annotations

from typing import TYPE_CHECKING

from predictors.kalman.predictor import KalmanPredictor, KalmanState
from track_envs.infra.lazy import lazy_exports

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


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
