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

from track_envs.registry import Registry

AGENTS = Registry("agent")


def register_agent(name: str, factory: Callable[..., Any]) -> None:
    """Register ``factory`` under ``name`` (re-registering a name replaces it)."""
    AGENTS.register(name, factory)


def available_agents() -> list[str]:
    """Names accepted by :func:`make_agent`."""
    return AGENTS.names()


def agent_applies_to(name: str, position_shape: tuple[int, ...], max_targets: int | None = None) -> bool:
    """Whether agent ``name`` tracks targets with positions of ``position_shape`` (and up to
    ``max_targets`` of them at once, when given).

    An agent class declares ``position_rank``: 1 for point targets (D,), 2 for poses (17, 2);
    classes without it are point trackers. A single-target tracker declares ``max_targets = 1``.
    """
    factory = AGENTS.factory(name)
    if int(getattr(factory, "position_rank", 1)) != len(position_shape):
        return False
    limit = getattr(factory, "max_targets", None)
    return limit is None or max_targets is None or max_targets <= limit


def make_agent(name: str, **kwargs: Any) -> Any:
    """Build the agent registered as ``name`` (an unknown name raises ``ValueError`` listing them)."""
    return AGENTS.make(name, **kwargs)


def _register_builtin() -> None:
    from agents.baseline import DetectionsAgent
    from agents.gnn.agent import GnnAgent
    from agents.one_step import OneStepAgent
    from agents.particle.agent import ParticleFilterAgent
    from agents.pose.baseline import PoseBaselineAgent
    from agents.pose.smc import PoseSmcAgent

    register_agent("detections", DetectionsAgent)
    register_agent("gnn", GnnAgent)
    register_agent("pose-baseline", PoseBaselineAgent)
    register_agent("pose-smc", PoseSmcAgent)
    register_agent("pf", ParticleFilterAgent)
    register_agent("one-step", OneStepAgent)


_register_builtin()
