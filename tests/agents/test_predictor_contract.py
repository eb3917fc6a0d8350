"""gnn against the predictor contract: optional capabilities, the random stream, a live p_gate."""

from __future__ import annotations

from dataclasses import dataclass

import gymnasium as gym
import numpy as np
import pytest
import torch

import track_envs  # noqa: F401
from agents.gnn.agent import GnnAgent
from predictors.base import BatchState, Capability, has_capability
from track_envs.values.types import Gaussian, SensorSpec


@dataclass(frozen=True)
class LastState(BatchState):
    z: np.ndarray
    v: np.ndarray


class LastVelocity:
    """A minimal non-Kalman predictor: constant velocity from the last two measurements, plain start(z),
    and a random stream from reset."""

    capabilities = frozenset({Capability.RANDOM_STREAM})

    def __init__(self) -> None:
        self.draws: list[float] = []

    def reset(self, spec: SensorSpec, *, rng: np.random.Generator | None = None) -> None:
        self.spec = spec
        self.draws.append(float(rng.random()) if rng is not None else float("nan"))

    def start(self, z: np.ndarray) -> LastState:
        return LastState(np.asarray(z, float).copy(), np.zeros_like(z, dtype=float))

    def predict(self, s: LastState) -> tuple[LastState, Gaussian]:
        mean = s.z + s.v
        # a new track (no velocity yet) may move up to ~15 mm in a frame
        var = np.where((s.v == 0).all(axis=1), 2e-4, (3 * self.spec.noise_std) ** 2 + 1e-8)
        cov = var[:, None, None] * np.eye(2)
        return LastState(mean, s.v), Gaussian(mean, cov)

    def update(self, s: LastState, z: np.ndarray, seen: np.ndarray) -> LastState:
        z_new = np.where(seen[:, None], z, s.z)
        return LastState(z_new, np.where(seen[:, None], z_new - (s.z - s.v), s.v))

    def estimate(self, s: LastState) -> Gaussian:
        return Gaussian(s.z.copy(), np.broadcast_to(np.eye(2) * 1e-8, (len(s), 2, 2)).copy())


def _run(agent: GnnAgent, steps: int = 60, seed: int = 0) -> list[dict[str, np.ndarray]]:
    env = gym.make("BeltSorter-v0", merge_touching=False)
    obs, _ = env.reset(seed=seed)
    agent.reset(env.unwrapped.sensor_spec, seed=seed)  # type: ignore[attr-defined]
    reports = []
    for _ in range(steps):
        report = agent.act(obs)
        reports.append(report)
        obs, *_ = env.step(report)
    return reports


def test_a_predictor_with_plain_start_tracks_in_gnn() -> None:
    predictor = LastVelocity()
    assert not has_capability(predictor, Capability.VELOCITY_PRIOR)
    agent = GnnAgent(predictor=predictor)
    reports = _run(agent)
    assert agent.n_tracks > 20
    last, earlier = (r["ids"][r["mask"] == 1] for r in (reports[-1], reports[-11]))
    assert (reports[-1]["detection"][reports[-1]["mask"] == 1] >= 0).mean() > 0.8  # tracks are updated
    assert np.isin(last, earlier).mean() > 0.25  # and many keep their ids over 10 frames (0 without tracking)


def test_the_predictor_gets_a_stream_derived_from_the_seed() -> None:
    predictor = LastVelocity()
    agent = GnnAgent(predictor=predictor)
    spec = gym.make("BeltSorter-v0").unwrapped.sensor_spec  # type: ignore[attr-defined]
    for seed in (3, 3, 4):
        agent.reset(spec, seed=seed)
    assert predictor.draws[0] == predictor.draws[1] != predictor.draws[2]


def test_p_gate_can_be_changed_between_frames() -> None:
    agent = GnnAgent(predictor="kf-ca")
    _run(agent, steps=5)
    wide = agent._gate
    agent.p_gate = 0.9
    assert agent.p_gate == 0.9 and agent._gate < wide
    assert agent._gate == pytest.approx(-2 * np.log(0.1))  # χ²₂ quantile in closed form
    for bad in (0.0, 1.0, -0.5, "0.9", True):
        with pytest.raises(ValueError, match="p_gate must be a probability in \\(0, 1\\)"):
            agent.p_gate = bad  # type: ignore[assignment]
    assert agent.p_gate == 0.9


def test_p_gate_changes_what_is_associated() -> None:
    def ids_after(p: float | None) -> list[int]:
        agent = GnnAgent(predictor="kf-ca", recovery_inflation=1.0)
        env = gym.make("BeltSorter-v0", merge_touching=False, noise_std=3e-4)
        obs, _ = env.reset(seed=1)
        agent.reset(env.unwrapped.sensor_spec, seed=1)  # type: ignore[attr-defined]
        for t in range(60):
            if t == 40 and p is not None:
                agent.p_gate = p
            report = agent.act(obs)
            obs, *_ = env.step(report)
        return sorted(report["ids"][report["mask"] == 1].tolist())

    same, tight = ids_after(None), ids_after(1e-4)
    assert same == ids_after(0.999)  # setting the value it had changes nothing
    assert max(tight) > max(same)  # a tight gate breaks tracks: new ids are started


@dataclass(frozen=True)
class Mixed(BatchState):
    a: torch.Tensor
    b: np.ndarray


def test_take_and_concat_keep_torch_and_numpy_fields() -> None:
    s = Mixed(torch.arange(6.0).reshape(3, 2), np.arange(3))
    t = s.take(np.array([2, 0]))
    assert isinstance(t.a, torch.Tensor) and isinstance(t.b, np.ndarray)
    assert t.a.tolist() == [[4.0, 5.0], [0.0, 1.0]] and t.b.tolist() == [2, 0]
    both = Mixed.concat([t, s.take(np.array([True, False, False]))])
    assert isinstance(both.a, torch.Tensor) and both.a[:, 0].tolist() == [4.0, 0.0, 0.0]
    with pytest.raises(TypeError, match="mixing"):
        Mixed.concat([t, Mixed(np.zeros((1, 2)), np.zeros(1))])  # type: ignore[arg-type]


@dataclass(frozen=True)
class Plain(BatchState):
    a: np.ndarray
    b: np.ndarray


@pytest.mark.parametrize(
    "rows", [np.array([True, False, True, True]), np.array([3, 0]), np.array([], dtype=np.int64)]
)
def test_take_and_append_equals_take_then_concat(rows) -> None:
    s = Plain(np.arange(8.0, dtype=np.float32).reshape(4, 2), np.arange(4))
    born = Plain(np.full((2, 2), -1.0, dtype=np.float32), np.array([7.5, 8.5]))  # b: another dtype
    want, got = Plain.concat([s.take(rows), born]), s.take_and_append(rows, born)
    for name in ("a", "b"):
        assert getattr(got, name).dtype == getattr(want, name).dtype
        assert getattr(got, name).tolist() == getattr(want, name).tolist()
    mixed = Mixed(torch.arange(8.0).reshape(4, 2), np.arange(4)).take_and_append(
        rows, Mixed(torch.zeros(2, 2), np.zeros(2, dtype=np.int64))
    )
    assert isinstance(mixed.a, torch.Tensor) and len(mixed) == len(want)
    with pytest.raises(IndexError):
        s.take_and_append(np.array([4]), born)  # a row out of range is refused, not clipped
