"""The declared predictor contract: a predictor with only the core methods works in gnn, one-step
and the sorting roll-out; a declared capability is used; trackers never probe for one."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from agents import AGENTS, agent_applies_to, available_agents, make_agent, register_agent
from agents.base import Agent, agent_traits
from agents.gnn.agent import GnnAgent
from agents.one_step import OneStepAgent
from agents.sorting.rollout import predict_crossings
from agents.tracking.knobs import LIVE_KNOBS
from predictors import make_predictor, resolve_predictor
from predictors.base import BatchState, Capability, capability, declared_capabilities, has_capability
from predictors.kalman.predictor import KalmanPredictor
from track_envs.infra.registry import UnknownArgumentError
from track_envs.values.types import Gaussian, SensorSpec

#: The belt's sensor, with its nozzle bar at ``x = LINE``.
SPEC: SensorSpec = gym.make("BeltSorter-v0").unwrapped.sensor_spec  # type: ignore[attr-defined]
LINE = float(SPEC.sorting_line)  # type: ignore[arg-type]
EDGE = SPEC.region_high[0]


@dataclass(frozen=True)
class PointState(BatchState):
    z: np.ndarray  # (n, D) position
    P: np.ndarray  # (n, D, D) its covariance


class DriftingPoint:
    """Only the five core methods: a position that drifts by a known velocity per second (zero:
    a constant-position model), random-walk noise ``q dt I`` per frame, measured directly."""

    def __init__(self, velocity: tuple[float, float] = (0.0, 0.0), q: float = 0.02) -> None:
        self.velocity, self.q = np.asarray(velocity, dtype=np.float64), q

    def reset(self, spec: SensorSpec) -> None:
        self.dt, self.R = spec.dt, np.eye(spec.dim) * max(spec.noise_std**2, 1e-12)

    def start(self, z: np.ndarray) -> PointState:
        z = np.asarray(z, dtype=np.float64)
        return PointState(z.copy(), np.broadcast_to(self.R, (len(z), *self.R.shape)).copy())

    def predict(self, s: PointState) -> tuple[PointState, Gaussian]:
        moved = PointState(s.z + self.velocity * self.dt, s.P + self.q * self.dt * np.eye(s.z.shape[1]))
        return moved, Gaussian(moved.z.copy(), moved.P + self.R)

    def update(self, s: PointState, z: np.ndarray, seen: np.ndarray) -> PointState:
        S = s.P + self.R
        K = s.P @ np.linalg.inv(S)
        innovation = np.where(seen[:, None], np.asarray(z, dtype=np.float64) - s.z, 0.0)
        z_new = s.z + np.einsum("nij,nj->ni", K, innovation)
        P_new = np.where(seen[:, None, None], s.P - K @ s.P, s.P)
        return PointState(z_new, P_new)

    def estimate(self, s: PointState) -> Gaussian:
        return Gaussian(s.z.copy(), s.P.copy())


class Recording(DriftingPoint):
    """The same model declaring the capabilities that give the core's numbers, recording their use."""

    capabilities = frozenset(
        {
            Capability.MEAN_ONLY_ESTIMATE,
            Capability.COAST,
            Capability.FUSED_SURVIVORS_BIRTHS,
            Capability.NOISE_SCALE,
        }
    )

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.calls: list[str] = []

    def set_noise_scale(self, scale: float) -> None:
        self.calls.append(f"set_noise_scale({scale})")

    def estimate_mean(self, s: PointState) -> np.ndarray:
        self.calls.append("estimate_mean")
        return s.z.copy()

    def coast(self, s: PointState) -> tuple[PointState, Gaussian]:
        self.calls.append("coast")
        moved, prediction = self.predict(s)
        return self.update(moved, np.zeros_like(moved.z), np.zeros(len(moved), bool)), prediction

    def survivors_and_births(self, s, keep, n_keep, z, velocity=None, velocity_cov=None) -> PointState:
        self.calls.append("survivors_and_births")
        if not len(z):
            return s.take(keep)
        born = self.start(z)
        return born if n_keep == 0 else PointState.concat([s.take(keep), born])


def _belt(agent, steps: int, seed: int = 0, truth: bool = False) -> list[dict[str, np.ndarray]]:
    env = gym.make("BeltSorter-v0", merge_touching=False)
    obs, info = env.reset(seed=seed)
    agent.reset(env.unwrapped.sensor_spec, seed=seed)  # type: ignore[attr-defined]
    reports = []
    for _ in range(steps):
        if truth:
            agent.observe_truth(info)
        report = agent.act(obs)
        reports.append(report)
        obs, _, _, _, info = env.step(report)
    return reports


def test_the_core_predictor_declares_nothing():
    assert declared_capabilities(DriftingPoint()) == frozenset()
    assert all(capability(DriftingPoint(), c) is None for c in Capability)


def test_a_core_only_predictor_tracks_and_sorts_in_gnn():
    agent = GnnAgent(predictor=DriftingPoint((1.2, 0.0)))
    reports = _belt(agent, 60)
    assert agent.n_tracks > 10
    assert (reports[-1]["detection"][reports[-1]["mask"] == 1] >= 0).mean() > 0.5
    sorted_rows = np.concatenate([r["sorting_mean"][r["sorting_mask"] == 1] for r in reports])
    assert len(sorted_rows) > 0 and np.isfinite(sorted_rows).all()


def test_a_core_only_predictor_is_scored_by_one_step():
    agent = OneStepAgent(predictor=DriftingPoint((1.2, 0.0)))
    _belt(agent, 30, truth=True)
    metrics = agent.episode_metrics()
    assert metrics["calibration_scale"] == 1.0  # no CALIBRATION declared: r = 1
    assert np.isfinite(metrics["nees"])


def test_the_frame_by_frame_roll_out_of_a_core_only_predictor_is_exact():
    predictor = DriftingPoint((1.5, 0.2), q=1e-3)
    predictor.reset(SPEC)
    z = np.array([[EDGE - 0.1, 0.05], [EDGE - 0.02, 0.10]])
    ok, mean, cov = predict_crossings(predictor, predictor.start(z), LINE, frame=5, dt=SPEC.dt)
    assert ok.all()
    t = 5 * SPEC.dt + (LINE - z[:, 0]) / 1.5
    np.testing.assert_allclose(mean[:, 0], t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(mean[:, 1], z[:, 1] + 0.2 * (t - 5 * SPEC.dt), rtol=0, atol=1e-12)
    assert (np.linalg.eigvalsh(cov) > 0).all()
    still = DriftingPoint()  # constant position: never reaches the line
    still.reset(SPEC)
    assert not predict_crossings(still, still.start(z), LINE, 0, SPEC.dt)[0].any()


def test_declared_capabilities_are_used_and_give_the_core_numbers():
    recording = Recording((1.2, 0.0))
    declaring = GnnAgent(predictor=recording)
    assert recording.calls == ["set_noise_scale(1.0)"]  # the gnn's noise_scale knob, at construction
    reports = [_belt(GnnAgent(predictor=DriftingPoint((1.2, 0.0))), 40), _belt(declaring, 40)]
    for a, b in zip(*reports, strict=True):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])
    assert {"estimate_mean", "survivors_and_births", "coast"} <= set(recording.calls)
    with pytest.raises(ValueError, match="needs a predictor with set_noise_scale"):
        GnnAgent(predictor=DriftingPoint(), noise_scale=2.0)
    GnnAgent(predictor=Recording(), noise_scale=2.0)


class Prior(DriftingPoint):
    """Declares VELOCITY_PRIOR, CALIBRATION and RANDOM_STREAM and records what it is given."""

    capabilities = frozenset({Capability.VELOCITY_PRIOR, Capability.CALIBRATION, Capability.RANDOM_STREAM})
    calibration_scale = 2.5

    def __init__(self) -> None:
        super().__init__((1.2, 0.0))
        self.velocities: list[np.ndarray] = []
        self.streams: list[float] = []

    def reset(self, spec: SensorSpec, *, rng: np.random.Generator | None = None) -> None:
        super().reset(spec)
        self.streams.append(float(rng.random()) if rng is not None else float("nan"))

    def start(self, z, velocity=None, velocity_cov=None) -> PointState:
        if velocity is not None:
            self.velocities.append(np.asarray(velocity))
        return super().start(z)


@pytest.mark.parametrize("agent_class", [GnnAgent, OneStepAgent])
def test_velocity_prior_calibration_and_random_stream_are_used(agent_class):
    predictor = Prior()
    agent = agent_class(predictor=predictor)
    _belt(agent, 30, seed=3, truth=agent_class is OneStepAgent)
    _belt(agent, 1, seed=3, truth=agent_class is OneStepAgent)
    assert predictor.velocities and np.isfinite(predictor.streams).all()
    assert predictor.streams[0] == predictor.streams[1]  # the same seed, the same stream
    if agent_class is OneStepAgent:
        assert agent.episode_metrics()["calibration_scale"] == 2.5


class Undeclared(DriftingPoint):
    """Has capability methods but declares none: they are never called."""

    def estimate_mean(self, s):
        raise AssertionError("an undeclared capability was used")

    coast = survivors_and_births = set_noise_scale = estimate_mean


def test_undeclared_methods_are_never_probed():
    _belt(GnnAgent(predictor=Undeclared((1.2, 0.0))), 20)


class Broken(DriftingPoint):
    capabilities = frozenset({Capability.COAST, Capability.LINE_ROLLOUT})


def test_a_declared_capability_without_its_members_is_named():
    with pytest.raises(TypeError, match=r"Broken declares capability COAST but lacks \['coast'\]"):
        capability(Broken(), Capability.COAST)
    with pytest.raises(TypeError, match=r"lacks \['rollout_crossings', 'rollout_covariance'\]"):
        has_capability(Broken(), Capability.LINE_ROLLOUT)

    class Bad(DriftingPoint):
        capabilities = frozenset({"coast"})

    with pytest.raises(TypeError, match=r"must be a frozenset of predictors\.base\.Capability"):
        capability(Bad(), Capability.COAST)


def test_the_kalman_filters_and_belt_lstms_declare_their_capabilities():
    kf = make_predictor("kf-ca")
    assert declared_capabilities(kf) == {
        Capability.NOISE_SCALE,
        Capability.VELOCITY_PRIOR,
        Capability.MEAN_ONLY_ESTIMATE,
        Capability.FUSED_SURVIVORS_BIRTHS,
        Capability.LINE_ROLLOUT,
        Capability.MIXTURE_UPDATE,
        Capability.TRANSLATE,
        Capability.KINEMATIC_MODEL,
    }
    lstm = make_predictor("nll-lstm")
    assert declared_capabilities(lstm) == {
        Capability.RANDOM_STREAM,
        Capability.CALIBRATION,
        Capability.COAST,
        Capability.LINE_ROLLOUT,
        Capability.FUSED_SURVIVORS_BIRTHS,
        Capability.TRANSLATE,
    }
    for predictor in (kf, lstm):
        for which in declared_capabilities(predictor):
            assert capability(predictor, which) is predictor  # every member present


def test_resolve_predictor_builds_names_and_checks_objects():
    assert isinstance(resolve_predictor("kf-cv", q=3.0), KalmanPredictor)
    point = DriftingPoint()
    assert resolve_predictor(point) is point
    with pytest.raises(ValueError, match=r"unknown predictor 'kf-xx'; valid names are \["):
        resolve_predictor("kf-xx")
    with pytest.raises(UnknownArgumentError, match="predictor 'kf-cv' has no argument 'gate'"):
        resolve_predictor("kf-cv", gate=3)
    with pytest.raises(UnknownArgumentError, match="configure a predictor object before passing it"):
        resolve_predictor(point, q=3.0)
    core = r"\['reset', 'start', 'predict', 'update', 'estimate'\]"
    with pytest.raises(ValueError, match=rf"object lacks {core}"):
        resolve_predictor(object())  # type: ignore[arg-type]


#: The tracker modules and the commands (the applications on top of the trackers excluded).
TRACKERS = Path(__file__).resolve().parents[2] / "agents"
TRACKER_MODULES = sorted(
    p for p in TRACKERS.rglob("*.py") if p.relative_to(TRACKERS).parts[0] not in ("bench", "tuning")
)
PROBES = [r"getattr\(\s*(self\.)?predictor", r"inspect\.signature", r"isinstance\([^)]*KalmanPredictor"]


def test_no_tracker_probes_its_predictor():
    assert len(TRACKER_MODULES) > 10
    found = [
        f"{p.relative_to(TRACKERS.parent)}: {m.group(0)}"
        for p in TRACKER_MODULES
        for pattern in PROBES
        for m in re.finditer(pattern, p.read_text())
    ]
    assert found == []
    assert not (TRACKERS / "tracking" / "_sorting_kernels.py").exists()


def test_agents_are_typed_and_declare_their_traits():
    agent = make_agent("gnn")
    assert isinstance(agent, Agent)
    assert agent_traits(AGENTS.factory("one-step")).needs_truth
    assert not agent_traits(AGENTS.factory("gnn")).needs_truth
    assert agent_traits(AGENTS.factory("pf")).max_targets == 1
    assert agent_traits(AGENTS.factory("pose-smc")).position_rank == 2
    takers = [a for a in available_agents() if agent_traits(AGENTS.factory(a)).takes_predictor]
    assert takers == ["gnn", "jpda", "one-step"]
    assert agent_applies_to("gnn", (2,)) and not agent_applies_to("gnn", (17, 2))
    assert "gnn" in available_agents() and callable(register_agent)


def test_the_gnn_defaults_are_the_tuning_defaults():
    from track_apps.tuning.policy import FixedPolicy

    agent = GnnAgent()
    assert {k: getattr(agent, k) for k in LIVE_KNOBS} == dict(FixedPolicy.GNN_DEFAULTS)


def test_warm_up_runs_the_sorting_roll_out_and_leaves_the_results_unchanged(monkeypatch):
    import agents.tracking.tracker as gnn_module

    rolled: list[int] = []

    def counting(predictor, state, *args, **kwargs):
        rolled.append(len(state))
        return predict_crossings(predictor, state, *args, **kwargs)

    monkeypatch.setattr(gnn_module, "predict_crossings", counting)
    env = gym.make("BeltSorter-v0", merge_touching=False)

    def run(warm: bool) -> list[dict[str, np.ndarray]]:
        agent = GnnAgent(predictor="kf-ca", p_gate=0.99)
        obs, _ = env.reset(seed=2)
        agent.reset(env.unwrapped.sensor_spec, seed=2)  # type: ignore[attr-defined]
        reports = []
        for t in range(50):
            if warm and t == 25:
                agent.warm_up()
            report = agent.act(obs)
            reports.append(report)
            obs, *_ = env.step(report)
        return reports

    plain = run(False)
    before = len(rolled)
    warmed = run(True)
    for a, b in zip(plain, warmed, strict=True):
        assert a.keys() == b.keys()
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])
    assert len(rolled) - before > before  # the warm-up's deletions were rolled to its nozzle bar

    rolled.clear()
    GnnAgent(predictor="kf-ca", predict_sorting=False).warm_up()
    assert rolled == []  # no sorting: no roll-out
    rolled.clear()
    GnnAgent(predictor="kf-ca").warm_up()
    assert rolled
