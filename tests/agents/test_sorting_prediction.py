"""The gnn agent's predicted nozzle-bar crossings: exact for a constant-velocity particle under kf-cv,
finite and scored for every belt predictor."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from agents import make_agent
from agents.sorting import predict_crossings
from predictors import available_predictors, make_predictor, predictor_applies_to
from track_envs.metrics import SortingPrediction
from track_envs.types import SensorSpec
from track_envs.wrappers import TrackingMetrics

LINE = 0.45
SPEC = SensorSpec(
    dt=0.01,
    dim=2,
    noise_std=0.0,
    p_detect=1.0,
    clutter_rate=0.0,
    region_low=(0.0, 0.0),
    region_high=(0.4, 0.18),
    max_detections=4,
    max_tracks=8,
    sorting_line=LINE,
)


def test_kf_cv_on_an_exactly_constant_velocity_particle_hits_with_zero_error():
    x0, v = np.array([0.02, 0.05]), np.array([1.3, 0.04])
    agent = make_agent("gnn", predictor="kf-cv")
    agent.reset(SPEC, seed=0)
    metric = SortingPrediction()
    predictions = []
    for k in range(60):
        z = x0 + v * k * SPEC.dt
        inside = z[0] <= SPEC.region_high[0]
        obs = {"detections": np.zeros((4, 2), np.float32), "mask": np.zeros(4, np.int8)}
        if inside:
            obs["detections"][0], obs["mask"][0] = z, 1
        report = agent.act(obs)
        live = report["sorting_mask"] == 1
        predictions += list(report["sorting_mean"][live])
        t_c = (LINE - x0[0]) / v[0]
        crossing = (k - 1) * SPEC.dt < t_c <= k * SPEC.dt
        truth = {
            "ids": np.array([0 if inside else -1, -1]),
            "positions": np.zeros((2, 2)),
            "visible": np.array([inside, False]),
            "nozzle_ids": np.array([0 if crossing else -1, -1]),
            "nozzle_times": np.array([t_c, 0.0]),
            "nozzle_lateral": np.array([x0[1] + v[1] * t_c, 0.0]),
        }
        metric.update(truth, np.array([0 if inside else -1, -1, -1, -1]), report)
    assert len(predictions) == 1
    t_c = (LINE - x0[0]) / v[0]
    # float32 detections: the particle's positions are known to ~1e-8 m
    assert predictions[0][0] == pytest.approx(t_c, abs=1e-7)
    assert predictions[0][1] == pytest.approx(x0[1] + v[1] * t_c, abs=1e-7)
    out = metric.compute()
    assert out["sorting_hit_rate"] == 1.0
    assert out["sorting_time_rmse_ms"] < 1e-4 and out["sorting_lateral_rmse_mm"] < 1e-4


def test_kalman_crossing_covariance_follows_the_first_order_map():
    predictor = make_predictor("kf-cv")
    predictor.reset(SPEC)
    state = predictor.start(
        np.array([[0.39, 0.09]]), velocity=np.array([[1.0, 0.1]]), velocity_cov=np.eye(2)[None] * 1e-4
    )
    ok, mean, cov = predict_crossings(predictor, state, LINE, frame=10, dt=SPEC.dt)
    assert ok.all()
    assert mean[0, 0] == pytest.approx(0.10 + 0.06, abs=1e-12)  # 0.06 m at 1 m/s from frame 10
    assert mean[0, 1] == pytest.approx(0.09 + 0.1 * 0.06, abs=1e-12)
    assert cov[0, 0, 0] > 0 and np.linalg.eigvalsh(cov[0]).min() > 0


def test_a_track_that_does_not_move_gets_no_prediction():
    predictor = make_predictor("random-walk")
    predictor.reset(SPEC)
    ok, mean, _ = predict_crossings(predictor, predictor.start(np.array([[0.39, 0.09]])), LINE, 0, SPEC.dt)
    assert not ok.any() and np.isnan(mean).all()


BELT_PREDICTORS = [
    p for p in available_predictors() if predictor_applies_to(p, "BeltSorter-v0") and p != "random-walk"
]


@pytest.mark.parametrize("name", BELT_PREDICTORS)
def test_every_belt_predictor_predicts_crossings(name):
    env = TrackingMetrics(gym.make("BeltSorter-v0", max_episode_steps=60, merge_touching=False))
    kwargs = {"samples": 10} if name == "mc-lstm" else {}
    agent = make_agent("gnn", predictor=name, **kwargs)
    obs, info = env.reset(seed=0)
    agent.reset(env.get_wrapper_attr("sensor_spec"), seed=0)
    rows = 0
    while True:
        report = agent.act(obs)
        live = report["sorting_mask"] == 1
        rows += int(live.sum())
        assert np.isfinite(report["sorting_mean"][live]).all()
        assert (np.diagonal(report["sorting_cov"][live], axis1=1, axis2=2) > 0).all()
        obs, _, terminated, truncated, info = env.step(report)
        if terminated or truncated:
            break
    metrics = info["episode_metrics"]
    assert rows > 50
    assert metrics["sorting_particles"] > 50
    assert metrics["sorting_predicted"] > 0.8
    assert metrics["sorting_time_p50_ms"] < 5.0 and metrics["sorting_lateral_p50_mm"] < 5.0
