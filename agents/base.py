"""The Agent protocol, what an agent declares about itself, and the agent registry.

An agent (a tracker) turns each observation of an env into a report of its tracks::

    from agents import make_agent
    agent = make_agent("gnn", predictor="kf-ca")
    agent.reset(env.unwrapped.sensor_spec, seed=0)
    report = agent.act(obs)            # the env's action: ids, positions, detection rows, mask

* :class:`Agent` — the two calls every agent has: ``reset(spec, *, seed=None)`` binds it to a
  sensor and starts an episode (``seed`` seeds any random stream it draws from, so the same seed
  gives the same reports); ``act(obs) -> report``.
* :class:`WarmUp` — optional ``warm_up()``: compile or load whatever the first frames would
  otherwise wait for (numba kernels), before a live stream starts; :func:`warm_up` calls it where
  an agent has it.
* Declared traits — class attributes an agent class may set, each with one default
  (:data:`TRAIT_DEFAULTS`; read them with :func:`agent_traits`):

  - ``needs_truth: bool = False`` — an oracle that reads each frame's truth: the loop that runs it
    calls ``observe_truth(info)`` (:class:`TruthObserver`) before every ``act``. A tracker never
    sees ``info``.
  - ``position_rank: int = 1`` — 1 for point targets (positions (D,)), 2 for poses (17, 2).
  - ``max_targets: int | None = None`` — the most targets it tracks at once (1: a single-target
    tracker; ``None``: any number).
  - ``takes_predictor: bool = False`` — built with a ``predictor=`` argument (a registered
    Gaussian predictor's name or object, :func:`predictors.resolve_predictor`): the bench runs it
    once per predictor, ``track run --predictor`` passes one.

Registry: :func:`make_agent` builds an agent by name (an unknown name raises a ``ValueError`` that
lists the valid ones), :func:`register_agent` adds one, :func:`agent_applies_to` says whether an
agent fits an env's targets.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from typing import Any, Protocol, runtime_checkable

from numpy.typing import NDArray

from track_envs.infra.registry import Registry
from track_envs.values.types import SensorSpec


@runtime_checkable
class Agent(Protocol):
    """A tracker: observations in, reports out (module docstring)."""

    def reset(self, spec: SensorSpec, *, seed: int | None = None) -> None:
        """Bind to sensor ``spec`` and start an episode with no tracks."""
        ...

    def act(self, obs: Mapping[str, NDArray[Any]]) -> dict[str, NDArray[Any]]:
        """Consume one observation (``"detections"``, ``"mask"``) and report the live tracks."""
        ...


@runtime_checkable
class WarmUp(Protocol):
    """An agent with a warm-up step (module docstring)."""

    def warm_up(self) -> None:
        """Compile or load what the first frames need, leaving the agent's results unchanged."""
        ...


class TruthObserver(Protocol):
    """An oracle agent (``needs_truth = True``) that reads each frame's truth before ``act``."""

    def observe_truth(self, info: Mapping[str, Any]) -> None:
        """Take the ``info`` of the frame the next ``act`` answers."""
        ...


@dataclass(frozen=True)
class AgentTraits:
    """What an agent class declares about itself (module docstring); the defaults are the
    values of a class that declares nothing.

    Attributes:
        needs_truth: Reads each frame's truth through ``observe_truth(info)``.
        position_rank: 1 for point targets (D,), 2 for poses (17, 2).
        max_targets: The most targets tracked at once, ``None`` for any number.
        takes_predictor: Built with a ``predictor=`` argument.
    """

    needs_truth: bool = False
    position_rank: int = 1
    max_targets: int | None = None
    takes_predictor: bool = False


#: The default of each declared trait.
TRAIT_DEFAULTS = AgentTraits()


def agent_traits(agent: object) -> AgentTraits:
    """The traits an agent (an instance, a class or a registered factory) declares, the default
    (:data:`TRAIT_DEFAULTS`) for each one it does not."""
    return AgentTraits(
        **{f.name: getattr(agent, f.name, getattr(TRAIT_DEFAULTS, f.name)) for f in fields(AgentTraits)}
    )


def warm_up(agent: Agent) -> None:
    """``agent.warm_up()`` where the agent has one (:class:`WarmUp`); nothing otherwise."""
    if isinstance(agent, WarmUp):
        agent.warm_up()


AGENTS = Registry("agent")


def register_agent(name: str, factory: Callable[..., Agent]) -> None:
    """Register ``factory`` (usually an agent class) under ``name`` (re-registering replaces it)."""
    AGENTS.register(name, factory)


def available_agents() -> list[str]:
    """Names accepted by :func:`make_agent`."""
    return AGENTS.names()


def agent_applies_to(name: str, position_shape: tuple[int, ...], max_targets: int | None = None) -> bool:
    """Whether agent ``name`` tracks targets with positions of ``position_shape`` (and up to
    ``max_targets`` of them at once, when given), by its declared ``position_rank`` and
    ``max_targets``."""
    traits = agent_traits(AGENTS.factory(name))
    if int(traits.position_rank) != len(position_shape):
        return False
    limit = traits.max_targets
    return limit is None or max_targets is None or max_targets <= limit


def agent_takes_predictor(name: str) -> bool:
    """Whether agent ``name`` declares ``takes_predictor`` (is built with ``predictor=``)."""
    return agent_traits(AGENTS.factory(name)).takes_predictor


def make_agent(name: str, **kwargs: Any) -> Agent:
    """Build the agent registered as ``name``.

    Raises:
        ValueError: for an unknown name, listing the valid ones.
        UnknownArgumentError: for a keyword the agent does not take, listing those it takes.
    """
    agent: Agent = AGENTS.make(name, **kwargs)
    return agent
