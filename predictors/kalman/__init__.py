"""Kalman filter predictors (constant velocity, constant acceleration, random walk), batched over tracks."""

from __future__ import annotations

from typing import TYPE_CHECKING

from predictors.kalman.predictor import KalmanPredictor, KalmanState
from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from predictors.kalman.rollout import kalman_crossings

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
