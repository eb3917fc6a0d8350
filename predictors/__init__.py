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


def _register_builtin() -> None:
    from functools import partial

    from predictors.kalman import KalmanPredictor

    register_predictor("kf-cv", partial(KalmanPredictor, "cv"))
    register_predictor("kf-ca", partial(KalmanPredictor, "ca"))
    register_predictor("random-walk", partial(KalmanPredictor, "random-walk"))


_register_builtin()
