"""Kalman filter predictors (constant velocity, constant acceleration, random walk), batched over tracks."""

from predictors.kalman.predictor import KalmanPredictor, KalmanState

__all__ = ["KalmanPredictor", "KalmanState"]
