"""Trackers that turn observations into reports (the Agent protocol).

Registry: :func:`make_agent` builds an agent by name; an unknown name raises a ``ValueError``
that lists the valid ones::

    from agents import make_agent
    agent = make_agent("detections")
    agent.reset(env.unwrapped.sensor_spec, seed=0)
    report = agent.act(obs)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

_REGISTRY: dict[str, Callable[..., Any]] = {}


def register_agent(name: str, factory: Callable[..., Any]) -> None:
    """Register ``factory`` under ``name`` (re-registering a name replaces it)."""
    _REGISTRY[name] = factory


def available_agents() -> list[str]:
    """Names accepted by :func:`make_agent`."""
    return sorted(_REGISTRY)


def make_agent(name: str, **kwargs: Any) -> Any:
    """Build the agent registered as ``name``.

    Raises:
        ValueError: for an unknown name, listing the valid names.
    """
    if name not in _REGISTRY:
        raise ValueError(f"unknown agent {name!r}; valid names are {available_agents()}")
    return _REGISTRY[name](**kwargs)


def _register_builtin() -> None:
    from agents.baseline import DetectionsAgent

    register_agent("detections", DetectionsAgent)


_register_builtin()
