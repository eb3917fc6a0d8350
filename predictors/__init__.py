"""Motion models with uncertainty, batched over tracks (the Predictor protocol).

Registry: :func:`make_predictor` builds a predictor by name; an unknown name raises a
``ValueError`` that lists the valid ones.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

_REGISTRY: dict[str, Callable[..., Any]] = {}


def register_predictor(name: str, factory: Callable[..., Any]) -> None:
    """Register ``factory`` under ``name`` (re-registering a name replaces it)."""
    _REGISTRY[name] = factory


def available_predictors() -> list[str]:
    """Names accepted by :func:`make_predictor`."""
    return sorted(_REGISTRY)


def make_predictor(name: str, **kwargs: Any) -> Any:
    """Build the predictor registered as ``name``.

    Raises:
        ValueError: for an unknown name, listing the valid names.
    """
    if name not in _REGISTRY:
        raise ValueError(f"unknown predictor {name!r}; valid names are {available_predictors()}")
    return _REGISTRY[name](**kwargs)
