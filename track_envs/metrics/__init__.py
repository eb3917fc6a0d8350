"""Streaming, vectorised scorers of tracker reports against ground truth."""

from track_envs.metrics.gospa import GospaResult, gospa

__all__ = ["GospaResult", "gospa"]
