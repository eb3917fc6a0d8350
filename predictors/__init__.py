"""Motion models with uncertainty, batched over tracks (the Predictor protocol).

Registry: :func:`make_predictor` builds a predictor by name; an unknown name raises a
``ValueError`` that lists the valid ones.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from track_envs.registry import Registry

PREDICTORS = Registry("predictor")


def register_predictor(name: str, factory: Callable[..., Any]) -> None:
    """Register ``factory`` under ``name`` (re-registering a name replaces it)."""
    PREDICTORS.register(name, factory)


def available_predictors() -> list[str]:
    """Names accepted by :func:`make_predictor`."""
    return PREDICTORS.names()


def make_predictor(name: str, **kwargs: Any) -> Any:
    """Build the predictor registered as ``name`` (an unknown name raises ``ValueError`` listing them)."""
    return PREDICTORS.make(name, **kwargs)


def kf_cv(**kwargs: Any) -> Any:
    """Constant-velocity Kalman filter (white-noise acceleration of intensity q), batched over tracks."""
    from predictors.kalman import KalmanPredictor

    return KalmanPredictor("cv", **kwargs)


def kf_ca(**kwargs: Any) -> Any:
    """Constant-acceleration Kalman filter (white-noise jerk of intensity q), batched over tracks."""
    from predictors.kalman import KalmanPredictor

    return KalmanPredictor("ca", **kwargs)


def random_walk(**kwargs: Any) -> Any:
    """Position-only random-walk Kalman filter (white-noise velocity of intensity q), batched."""
    from predictors.kalman import KalmanPredictor

    return KalmanPredictor("random-walk", **kwargs)


def _register_builtin() -> None:
    register_predictor("kf-cv", kf_cv)
    register_predictor("kf-ca", kf_ca)
    register_predictor("random-walk", random_walk)


_register_builtin()
