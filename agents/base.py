"""The Agent protocol, what an agent declares about itself, and the agent registry.

An agent (a tracker) turns each observation of an env into a report of its tracks::

    from agents import make_agent
    agent = make_agent("gnn", predictor="kf-ca")
    agent.reset(env.unwrapped.sensor_spec, seed=0)
    report = agent.act(obs)            # the env's action: ids, positions, detection rows, mask

* [`Agent`][agents.Agent] — the core, the two calls every agent has: ``reset(spec, *, seed=None)`` binds
  it to a sensor and starts an episode (``seed`` seeds any random stream it draws from, so the
  same seed gives the same reports); ``act(obs) -> report``.
* Declared traits — one class attribute ``traits = AgentTraits(...)`` ([`AgentTraits`][agents.AgentTraits];
  a class that declares none has [`TRAIT_DEFAULTS`][agents.base.TRAIT_DEFAULTS]; read them with
  [`agent_traits`][agents.agent_traits]):

  - ``needs_truth: bool = False`` — an oracle that reads each frame's truth: the loop that runs it
    calls ``observe_truth(info)`` (the ``TRUTH_OBSERVER`` capability) before every ``act``. A
    tracker never sees ``info``.
  - ``position_rank: int = 1`` — 1 for point targets (positions (D,)), 2 for poses (17, 2).
  - ``max_targets: int | None = None`` — the most targets it tracks at once (1: a single-target
    tracker; ``None``: any number).
  - ``takes_predictor: bool = False`` — built with a ``predictor=`` argument (a registered
    Gaussian predictor's name or object, [`predictors.resolve_predictor`][predictors.resolve_predictor]): the
    bench runs it once per predictor, ``track run --predictor`` passes one.

Optional capabilities
---------------------
Anything beyond the core is a capability ([`AgentCapability`][agents.AgentCapability]), declared as a
predictor's are ([`track_envs.infra.declared`][track_envs.infra.declared]): the class attribute
``capabilities: frozenset[AgentCapability]`` (none when absent), asked for with
[`agent_capability`][agents.agent_capability], which returns the agent typed as the capability's protocol, or
``None``; [`agent_declares`][agents.base.agent_declares] asks a class or a registered factory.

* ``WARM_UP`` ([`WarmUp`][agents.base.WarmUp]) — ``warm_up()``: compile or load whatever the first frames
would
  otherwise wait for (numba kernels), before a live stream starts; [`warm_up`][agents.base.warm_up] calls it
  where an agent declares it. gnn, jpda.
* ``TRACK_COVARIANCES`` ([`TrackCovariances`][agents.base.TrackCovariances]) —
``track_covariances() -> (n, D, D)``: the
  covariances of the live rows of the last report, in row order (``run_agent(...,
  covariance=True)``). gnn, jpda.
* ``LAST_PREDICTION`` ([`LastPrediction`][agents.base.LastPrediction]) — ``last_prediction`` (the predicted
measurement
  ``Gaussian`` of the tracks of the last frame, ``None`` before any), ``last_prediction_ids`` and
  ``last_prediction_detection`` (their ids and the observation row each took, −1: none), there
  from the first ``reset`` on (ask after it). Read by
  the merge-event scores ([`agents.merge_scoring`][agents.merge_scoring]) and GateTuning-v0's diagnostics.
  gnn, jpda.
* ``SENSOR_MODEL`` ([`SensorModelSettings`][agents.base.SensorModelSettings]) — built with the keywords of a
  sensor-model estimate
  ([`agents.sensor_model.SensorModelEstimate.agent_kwargs`][agents.SensorModelEstimate.agent_kwargs]: ``q``,
  ``max_misses``, the velocity prior, ...), which ``run_agent(..., estimate_sensor_model=True)`` and
  ``track run`` pass. gnn, jpda.
* ``TRUTH_OBSERVER`` ([`TruthObserver`][agents.base.TruthObserver]) — ``observe_truth(info)``: the oracle's
truth
  channel (with ``needs_truth``). one-step.

Registry: [`make_agent`][agents.make_agent] builds an agent by name (an unknown name raises a ``ValueError``
that lists the valid ones), [`register_agent`][agents.register_agent] adds one,
[`agent_applies_to`][agents.agent_applies_to] says whether an agent fits an env's targets.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, Literal, Protocol, overload, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.declared import Declarations, declared_value
from track_envs.infra.registry import Registry
from track_envs.values.types import Gaussian, SensorSpec


@runtime_checkable
class Agent(Protocol):
    """A tracker: observations in, reports out (module docstring)."""

    def reset(self, spec: SensorSpec, *, seed: int | None = None) -> None:
        """Bind to sensor ``spec`` and start an episode with no tracks."""
        ...

    def act(self, obs: Mapping[str, NDArray[Any]]) -> dict[str, NDArray[Any]]:
        """Consume one observation (``"detections"``, ``"mask"``) and report the live tracks."""
        ...


class AgentCapability(StrEnum):
    """The optional capabilities an agent class may declare (module docstring)."""

    WARM_UP = "warm-up"
    TRACK_COVARIANCES = "track-covariances"
    LAST_PREDICTION = "last-prediction"
    SENSOR_MODEL = "sensor-model"
    TRUTH_OBSERVER = "truth-observer"


class WarmUp(Agent, Protocol):
    """``WARM_UP``: an agent with a warm-up step (module docstring)."""

    def warm_up(self) -> None:
        """Compile or load what the first frames need, leaving the agent's results unchanged."""
        ...


class TrackCovariances(Agent, Protocol):
    """``TRACK_COVARIANCES``: the covariances of the reported positions."""

    def track_covariances(self) -> NDArray[np.float64]:
        """(n, D, D) covariances of the live rows of the last report, in row order."""
        ...


class LastPrediction(Agent, Protocol):
    """``LAST_PREDICTION``: the tracker-side prediction of the last frame."""

    #: The predicted measurement of the tracks of the last frame with tracks (``None`` before).
    last_prediction: Gaussian | None
    #: Their ids (n,).
    last_prediction_ids: NDArray[np.int64]
    #: The observation row each took in that frame (n,), −1 for none.
    last_prediction_detection: NDArray[np.int64]


class SensorModelSettings(Agent, Protocol):
    """``SENSOR_MODEL``: built with the keywords of a sensor-model estimate (a promise on the
    factory's keywords; nothing to check on the object)."""


class TruthObserver(Agent, Protocol):
    """``TRUTH_OBSERVER``: an oracle (``needs_truth``) that reads each frame's truth before ``act``."""

    def observe_truth(self, info: Mapping[str, Any]) -> None:
        """Take the ``info`` of the frame the next ``act`` answers."""
        ...

    def episode_metrics(self) -> dict[str, float]:
        """The oracle's own figures of the episode so far (joined to the env's metrics)."""
        ...


#: The protocol of every agent capability.
AGENT_PROTOCOLS: dict[AgentCapability, type] = {
    AgentCapability.WARM_UP: WarmUp,
    AgentCapability.TRACK_COVARIANCES: TrackCovariances,
    AgentCapability.LAST_PREDICTION: LastPrediction,
    AgentCapability.SENSOR_MODEL: SensorModelSettings,
    AgentCapability.TRUTH_OBSERVER: TruthObserver,
}

#: The capabilities of agents ([`track_envs.infra.declared`][track_envs.infra.declared]).
AGENT_DECLARATIONS: Declarations[AgentCapability] = Declarations(AgentCapability, AGENT_PROTOCOLS, core=Agent)


@overload
def agent_capability(agent: object, which: Literal[AgentCapability.WARM_UP]) -> WarmUp | None: ...
@overload
def agent_capability(
    agent: object, which: Literal[AgentCapability.TRACK_COVARIANCES]
) -> TrackCovariances | None: ...
@overload
def agent_capability(
    agent: object, which: Literal[AgentCapability.LAST_PREDICTION]
) -> LastPrediction | None: ...
@overload
def agent_capability(
    agent: object, which: Literal[AgentCapability.SENSOR_MODEL]
) -> SensorModelSettings | None: ...
@overload
def agent_capability(
    agent: object, which: Literal[AgentCapability.TRUTH_OBSERVER]
) -> TruthObserver | None: ...
@overload
def agent_capability(agent: object, which: AgentCapability) -> Any: ...
def agent_capability(agent: object, which: AgentCapability) -> Any:
    """``agent``, typed as the protocol of capability ``which``, when its class declares it; else
    ``None``. The one way to ask an agent for an optional capability (module docstring).

    Raises:
        TypeError: if the class declares ``which`` but lacks a member of its protocol (named), or
            ``which`` is not an [`AgentCapability`][agents.AgentCapability].
    """
    return AGENT_DECLARATIONS.get(agent, which)


def agent_declares(agent: object, which: AgentCapability) -> bool:
    """Whether ``agent`` (an instance, a class or a registered factory) declares ``which``; nothing
    is built or checked (a factory that is not a class declares nothing)."""
    return AGENT_DECLARATIONS.declares(agent, which)


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


#: The traits of a class that declares none.
TRAIT_DEFAULTS = AgentTraits()


def agent_traits(agent: object) -> AgentTraits:
    """The traits an agent (an instance, a class or a registered factory) declares in its class
    attribute ``traits``, `TRAIT_DEFAULTS` where it declares none.

    Raises:
        TypeError: if the class's ``traits`` is not an [`AgentTraits`][agents.AgentTraits].
    """
    return declared_value(agent, "traits", AgentTraits, TRAIT_DEFAULTS)


def warm_up(agent: Agent) -> None:
    """``agent.warm_up()`` where the agent declares ``WARM_UP``; nothing otherwise."""
    warming = agent_capability(agent, AgentCapability.WARM_UP)
    if warming is not None:
        warming.warm_up()


AGENTS = Registry("agent")


def register_agent(name: str, factory: Callable[..., Agent]) -> None:
    """Register ``factory`` (usually an agent class) under ``name`` (re-registering replaces it)."""
    AGENTS.register(name, factory)


def available_agents() -> list[str]:
    """Names accepted by [`make_agent`][agents.make_agent]."""
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
