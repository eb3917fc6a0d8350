"""Trackers that turn observations into reports (the Agent protocol, `agents.base`).

Registry: [`make_agent`][agents.make_agent] builds an agent by name; an unknown name raises a ``ValueError``
that lists the valid ones::

    from agents import make_agent
    agent = make_agent("detections")
    agent.reset(env.unwrapped.sensor_spec, seed=0)
    report = agent.act(obs)

The episode loop: [`run_episode`][agents.run_episode] runs an agent on one episode of an env and returns its
metrics ([`EpisodeResult`][agents.EpisodeResult]).
"""

from __future__ import annotations

from agents.base import (
    AGENTS,
    Agent,
    AgentCapability,
    AgentTraits,
    agent_applies_to,
    agent_capability,
    agent_traits,
    available_agents,
    make_agent,
    register_agent,
)
from agents.episode import EpisodeResult, run_episode
from agents.files import run_agent, run_pose_agent
from agents.sensor_model import SensorModelEstimate, estimate_sensor_model
from agents.tracking import (
    Association,
    Associator,
    AssociatorCapability,
    FrameContext,
    PointTracker,
    available_associators,
    make_associator,
    register_associator,
)
from track_envs.infra.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)


def _register_builtin() -> None:
    from agents.detections_agent import DetectionsAgent
    from agents.gnn.agent import GnnAgent
    from agents.jpda.agent import JpdaAgent
    from agents.jpda.associator import JpdaAssociator
    from agents.one_step import OneStepAgent
    from agents.particle.agent import ParticleFilterAgent
    from agents.pose.smc import PoseSmcAgent
    from agents.pose.tracker import PoseBaselineAgent
    from agents.tracking.gated import GatedAssignment
    from agents.tracking.merges import SharedBlobs

    register_agent("detections", DetectionsAgent)
    register_agent("gnn", GnnAgent)
    register_agent("jpda", JpdaAgent)
    register_agent("pose-baseline", PoseBaselineAgent)
    register_agent("pose-smc", PoseSmcAgent)
    register_agent("pf", ParticleFilterAgent)
    register_agent("one-step", OneStepAgent)
    # the association components of the point trackers (agents.tracking.associator)
    register_associator("gnn", GatedAssignment)
    register_associator("shared-blobs", SharedBlobs)
    register_associator("jpda", JpdaAssociator)


_register_builtin()
