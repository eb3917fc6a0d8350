"""One declaration mechanism (track_envs.infra.declared) for agents, displacement models, pose motions,
tuning policies and predictors: what is declared is used, what is not is never probed."""

from __future__ import annotations

from enum import StrEnum
from typing import Protocol

import numpy as np
import pytest

from agents import AGENTS, available_agents, make_agent
from agents.base import (
    AGENT_DECLARATIONS,
    AgentCapability,
    AgentTraits,
    agent_capability,
    agent_declares,
    agent_traits,
    warm_up,
)
from agents.files.points import run_agent, takes_sensor_model
from agents.particle.agent import BatchParticleFilter
from agents.pose.tracker import PoseTracker
from agents.sensor_model.estimate import FALLBACK_PREDICTOR, kinematics, tracking_model
from predictors import make_predictor
from predictors.base import Capability, capability
from predictors.displacement import (
    Brownian,
    DisplacementCapability,
    displacement_capability,
    make_displacement_model,
)
from predictors.kalman.predictor import _kinematic_model
from predictors.pose import POSE_MOTION_DECLARATIONS, ConstantVelocityPose
from track_apps.tuning.policy import FixedPolicy, PolicyCapability, SettingChooser, policy_capability
from track_envs.infra.declared import Declarations, declared_value
from track_envs.values.detections import Detections, detection_sensor_spec


class Color(StrEnum):
    LOUD = "loud"


class Core(Protocol):
    def play(self) -> None: ...


class Loud(Core, Protocol):
    volume: float

    def shout(self) -> str: ...


TABLE = Declarations(Color, {Color.LOUD: Loud}, core=Core)


class Quiet:
    def play(self) -> None: ...

    def shout(self) -> str:
        raise AssertionError("never called: not declared")


class Shouting(Quiet):
    capabilities = frozenset({Color.LOUD})
    volume = 3.0

    def shout(self) -> str:
        return "!"


class Hollow(Quiet):
    capabilities = frozenset({Color.LOUD})
    shout = None  # type: ignore[assignment]


def test_the_generic_declarations_read_the_class_and_check_members_once():
    assert TABLE.declared(Quiet()) == frozenset() and TABLE.get(Quiet(), Color.LOUD) is None
    loud = Shouting()
    assert TABLE.get(loud, Color.LOUD) is loud and TABLE.has(loud, Color.LOUD)
    assert TABLE.declares(Shouting, Color.LOUD) and not TABLE.declares(Quiet, Color.LOUD)
    with pytest.raises(TypeError, match=r"Hollow declares capability LOUD but lacks \['shout', 'volume'\]"):
        TABLE.get(Hollow(), Color.LOUD)
    with pytest.raises(TypeError, match=r"capability must be one of \['LOUD'\], got 'loud!'"):
        TABLE.get(loud, "loud!")  # type: ignore[arg-type]

    class Bad(Quiet):
        capabilities = frozenset({"loud"})

    with pytest.raises(
        TypeError, match=r"Bad\.capabilities must be a frozenset of .*Color members \['LOUD'\]"
    ):
        TABLE.declared(Bad())
    with pytest.raises(ValueError, match=r"missing \['LOUD'\]"):
        Declarations(Color, {}, core=Core)


def test_declared_values_default_and_are_type_checked():
    class Traited:
        traits = AgentTraits(max_targets=3)

    class Wrong:
        traits = ("max_targets", 3)

    assert declared_value(Traited(), "traits", AgentTraits, AgentTraits()).max_targets == 3
    assert declared_value(Quiet, "traits", AgentTraits, AgentTraits()) == AgentTraits()
    with pytest.raises(TypeError, match=r"Wrong\.traits must be a agents\.base\.AgentTraits"):
        agent_traits(Wrong)


def test_every_registered_agent_declares_what_its_consumers_ask():
    declared = {a: AGENT_DECLARATIONS.declared(AGENTS.factory(a)) for a in available_agents()}
    tracker = {
        AgentCapability.WARM_UP,
        AgentCapability.TRACK_COVARIANCES,
        AgentCapability.LAST_PREDICTION,
        AgentCapability.SENSOR_MODEL,
    }
    assert declared["gnn"] == declared["jpda"] == tracker
    assert declared["one-step"] == {AgentCapability.TRUTH_OBSERVER}
    assert all(not declared[a] for a in ("detections", "pf", "pose-baseline", "pose-smc"))
    for name in available_agents():  # a truth observer is exactly an agent that needs truth
        truth = AgentCapability.TRUTH_OBSERVER in declared[name]
        assert truth == agent_traits(AGENTS.factory(name)).needs_truth
    assert [a for a in available_agents() if takes_sensor_model(a)] == ["gnn", "jpda"]
    assert agent_declares(AGENTS.factory("gnn"), AgentCapability.WARM_UP)
    gnn = make_agent("gnn")
    assert agent_capability(gnn, AgentCapability.TRACK_COVARIANCES) is gnn
    assert agent_capability(make_agent("detections"), AgentCapability.WARM_UP) is None


class Undeclared:
    """A point agent with the capability methods of gnn but no declaration: never probed."""

    def reset(self, spec, *, seed=None) -> None:
        self.inner = make_agent("detections")
        self.inner.reset(spec, seed=seed)

    def act(self, obs):
        return self.inner.act(obs)

    def track_covariances(self):
        raise AssertionError("an undeclared capability was used")

    warm_up = track_covariances


def test_undeclared_agent_methods_are_never_called():
    frames = [np.array([[0.1, 0.2]]), np.array([[0.15, 0.2], [0.5, 0.5]])]
    spec = detection_sensor_spec(Detections.from_frames(frames), dt=0.1)
    agent = Undeclared()
    warm_up(agent)  # type: ignore[arg-type]
    tracks = run_agent(agent, frames, spec, covariance=True)
    assert tracks.cov is None and len(tracks) == 3


class DriftOnly:
    """``displacement`` and ``std`` without the declaration: the filter's numpy path."""

    def __init__(self) -> None:
        self.inner = Brownian(1.0)
        self.std = self.inner.std

    def displacement(self, history):
        raise AssertionError("an undeclared capability was used")

    def propose(self, particles, history, rng):
        return self.inner.propose(particles, history, rng)


def test_displacement_models_run_the_compiled_path_only_where_declared():
    for model in (Brownian(), make_displacement_model("cv", 1.0, 0.2)):
        assert displacement_capability(model, DisplacementCapability.COMMON_DISPLACEMENT) is model
    pf = BatchParticleFilter(1, 5, DriftOnly(), sigma_m=0.1, sigma_0=0.1, rng=np.random.default_rng(0))
    assert not pf.fused
    pf.step(np.zeros((1, 2)), np.ones(1, bool))
    pf.step(np.zeros((1, 2)), np.ones(1, bool))

    class Hollow(Brownian):
        displacement = None  # type: ignore[assignment]

    with pytest.raises(
        TypeError, match=r"Hollow declares capability COMMON_DISPLACEMENT but lacks \['displacement'\]"
    ):
        BatchParticleFilter(1, 5, Hollow(), sigma_m=0.1, sigma_0=0.1, rng=np.random.default_rng(0))
    with pytest.raises(ValueError, match=r"or have propose\(\)"):
        make_displacement_model(object(), 1.0, 0.2)  # type: ignore[arg-type]


def test_pose_motions_declare_nothing_and_a_malformed_declaration_is_named():
    assert POSE_MOTION_DECLARATIONS.declared(ConstantVelocityPose()) == frozenset()

    class Bad(ConstantVelocityPose):
        capabilities = frozenset({"particles"})

    with pytest.raises(TypeError, match=r"Bad\.capabilities must be a frozenset of .*PoseMotionCapability"):
        PoseTracker(Bad())


def test_the_kalman_filters_declare_their_kinematic_model_for_the_self_calibration():
    for name, order in (("random-walk", 1), ("kf-cv", 2), ("kf-ca", 3)):
        model = capability(make_predictor(name), Capability.KINEMATIC_MODEL)
        assert model is not None and model.order == order and kinematics(name) is not None
        for got, want in zip(
            model.kinematic_model(2, 0.01, 3.0), _kinematic_model(order, 2, 0.01, 3.0), strict=True
        ):
            np.testing.assert_array_equal(got, want)
        assert tracking_model(name)[0] == name
    assert kinematics("nll-lstm") is None  # a predictor without one calibrates with the fallback's
    assert tracking_model("nll-lstm")[0] == FALLBACK_PREDICTOR
    with pytest.raises(ValueError, match="unknown predictor 'kf-xx'"):
        kinematics("kf-xx")


def test_tuning_policies_declare_their_knobs_or_their_binding():
    fixed = FixedPolicy()
    assert policy_capability(fixed, PolicyCapability.KNOB_RANGES) is fixed
    assert policy_capability(fixed, PolicyCapability.BINDS_ENV) is None

    class Chooser(SettingChooser):
        def choose(self, env):
            return 0

    chooser = Chooser([{"p_gate": 0.99}])
    assert policy_capability(chooser, PolicyCapability.BINDS_ENV) is chooser
    assert policy_capability(chooser, PolicyCapability.KNOB_RANGES) is None
    assert policy_capability(object(), PolicyCapability.KNOB_RANGES) is None  # an SB3 model: core only
