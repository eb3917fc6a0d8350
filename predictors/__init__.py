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


def kf_cv(
    *, q: float | None = None, initial_velocity_std: float | None = None, initial_velocity: Any = None
) -> Any:
    """Constant-velocity Kalman filter (white-noise acceleration of intensity q), batched over tracks."""
    from predictors.kalman import KalmanPredictor

    return KalmanPredictor(
        "cv", q=q, initial_velocity_std=initial_velocity_std, initial_velocity=initial_velocity
    )


def kf_ca(
    *,
    q: float | None = None,
    initial_velocity_std: float | None = None,
    initial_acceleration_std: float | None = None,
    initial_velocity: Any = None,
) -> Any:
    """Constant-acceleration Kalman filter (white-noise jerk of intensity q), batched over tracks."""
    from predictors.kalman import KalmanPredictor

    return KalmanPredictor(
        "ca",
        q=q,
        initial_velocity_std=initial_velocity_std,
        initial_acceleration_std=initial_acceleration_std,
        initial_velocity=initial_velocity,
    )


def random_walk(*, q: float | None = None) -> Any:
    """Position-only random-walk Kalman filter (white-noise velocity of intensity q), batched."""
    from predictors.kalman import KalmanPredictor

    return KalmanPredictor("random-walk", q=q)


def _register_builtin() -> None:
    register_predictor("kf-cv", kf_cv)
    register_predictor("kf-ca", kf_ca)
    register_predictor("random-walk", random_walk)


_register_builtin()
