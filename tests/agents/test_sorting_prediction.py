"""The gnn agent's predicted nozzle-bar crossings: exact for a constant-velocity particle under kf-cv,
finite and scored for every belt predictor."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import track_envs  # noqa: F401
from agents import make_agent
from agents.sorting.rollout import predict_crossings
from predictors import available_predictors, make_predictor, predictor_applies_to
from predictors.base import Capability, Crossings
from track_envs.metrics import SortingPrediction
from track_envs.values.types import SensorSpec
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


class _Wrapped:
    """A Kalman predictor behind a plain object, so that the generic roll-out runs."""

    def __init__(self, inner):
        self.inner = inner

    def __getattr__(self, name):
        return getattr(self.inner, name)


@pytest.mark.parametrize("name", ["kf-cv", "kf-ca"])
def test_kalman_closed_form_equals_the_frame_by_frame_roll_out(name):
    predictor = make_predictor(name)
    predictor.reset(SPEC)
    rng = np.random.default_rng(0)
    z = np.column_stack([rng.uniform(0.3, 0.4, 12), rng.uniform(0.0, 0.18, 12)])
    v = np.column_stack([rng.uniform(0.6, 1.5, 12), rng.normal(0, 0.05, 12)])
    v[3, 0] = -0.2  # moving backwards: no crossing
    state = predictor.start(z, velocity=v, velocity_cov=np.broadcast_to(np.eye(2) * 1e-3, (12, 2, 2)))
    for _ in range(2):  # a few frames of coasting give the filters their full covariance
        state, _ = predictor.predict(state)
    closed = predict_crossings(predictor, state, LINE, 7, SPEC.dt)
    generic = predict_crossings(_Wrapped(predictor), state, LINE, 7, SPEC.dt)
    assert type(closed) is Crossings and type(generic) is Crossings  # compiled pass and frame by frame
    np.testing.assert_array_equal(closed[0], generic[0])
    assert not closed[0][3] and closed[0].sum() == 11
    np.testing.assert_allclose(closed[1], generic[1], rtol=1e-12, equal_nan=True)
    np.testing.assert_allclose(closed[2], generic[2], rtol=1e-9, atol=1e-18, equal_nan=True)


def test_kalman_crossing_covariance_matches_monte_carlo():
    # a constant-velocity state with small uncertainty and no process noise: the crossing of
    # each sample is exact, t = (L - x) / v_x, y_c = y + v_y t
    predictor = make_predictor("kf-cv", q=1e-12)
    predictor.reset(SPEC)
    mean = np.array([[0.38, 0.09, 1.2, 0.05]])
    cov = np.diag([4e-8, 9e-8, 1e-4, 4e-5])[None]
    from predictors.kalman.predictor import KalmanState

    ok, m, c = predict_crossings(predictor, KalmanState(mean, cov), LINE, 0, SPEC.dt)
    assert ok.all()
    samples = np.random.default_rng(1).multivariate_normal(mean[0], cov[0], 200_000)
    t = (LINE - samples[:, 0]) / samples[:, 2]
    y = samples[:, 1] + samples[:, 3] * t
    assert m[0] == pytest.approx([t.mean(), y.mean()], rel=1e-3)
    sample = np.cov(np.stack([t, y]))
    np.testing.assert_allclose(np.diag(c[0]), np.diag(sample), rtol=0.02)
    scale = np.sqrt(np.outer(np.diag(sample), np.diag(sample)))
    np.testing.assert_allclose(c[0] / scale, sample / scale, atol=0.01)  # correlations


def test_predict_sorting_false_skips_the_channel_and_keeps_the_tracks():
    def run(**kwargs):
        env = gym.make("BeltSorter-v0", max_episode_steps=40, merge_touching=False)
        agent = make_agent("gnn", predictor="nll-lstm", **kwargs)
        obs, _ = env.reset(seed=0)
        agent.reset(env.unwrapped.sensor_spec, seed=0)
        reports, sorted_rows = [], 0
        for _ in range(40):
            report = agent.act(obs)
            reports.append(report)
            sorted_rows += int(report.get("sorting_mask", np.zeros(1)).sum())
            obs, *_ = env.step(report)
        return reports, sorted_rows

    on, rows_on = run()
    off, rows_off = run(predict_sorting=False)
    assert rows_on > 0 and rows_off == 0
    assert all("sorting_mask" not in r for r in off)
    for a, b in zip(on, off, strict=True):
        for key in ("ids", "positions", "detection", "mask"):
            np.testing.assert_array_equal(a[key], b[key])
    with pytest.raises(ValueError, match="predict_sorting"):
        make_agent("gnn", predict_sorting="no")


class _Generic:
    """A belt LSTM without its compiled roll-out, so that the frame-by-frame roll-out runs."""

    capabilities = frozenset({Capability.COAST, Capability.LINE_ROLLOUT})  # with its covariance mode

    def __init__(self, inner):
        self.inner = inner

    def rollout_crossings(self, *args):
        return None  # no compiled pass: roll frame by frame

    def __getattr__(self, name):
        return getattr(self.inner, name)


@pytest.mark.parametrize("name", ["lstm", "nll-lstm"])
@pytest.mark.parametrize("precision", ["float64", "float32"])
def test_compiled_lstm_roll_out_equals_the_frame_by_frame_one(name, precision):
    from predictors.belt_lstm.predictor import LSTMPredictor

    env = gym.make("BeltSorter-v0")
    spec = env.unwrapped.sensor_spec
    predictor = LSTMPredictor(name, make_predictor(name).model, precision=precision)
    predictor.reset(spec, rng=np.random.default_rng(0))
    rng = np.random.default_rng(1)
    low, high = np.asarray(spec.region_low), np.asarray(spec.region_high)
    start = np.stack(
        [high[0] - 0.05 - 0.03 * rng.random(12), low[1] + (high[1] - low[1]) * rng.random(12)], 1
    )
    step = np.array([1.44 * spec.dt, 0.0]) + 1e-4 * rng.standard_normal((12, 2))
    state = predictor.start(start)
    for k in range(1, 9):  # measured frames, then two coasting ones (as gnn deletes a track)
        state, _ = predictor.predict(state)
        state = predictor.update(
            state, start + k * step, np.arange(12) % 3 > 0 if k > 6 else np.ones(12, bool)
        )
    line = float(spec.sorting_line)
    fast = predict_crossings(predictor, state, line, 40, spec.dt, 60)
    slow = predict_crossings(_Generic(predictor), state, line, 40, spec.dt, 60)
    assert type(fast) is Crossings and type(slow) is Crossings
    np.testing.assert_array_equal(fast[0], slow[0])
    assert fast[0].sum() >= 10
    tol = 1e-12 if precision == "float64" else 1e-5
    np.testing.assert_allclose(fast[1], slow[1], rtol=tol, atol=tol * 1e-3)
    np.testing.assert_allclose(fast[2], slow[2], rtol=tol * 10, atol=tol * 1e-9)
