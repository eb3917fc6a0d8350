"""Tests of the batched Kalman predictors against filterpy and of their protocol behaviour.

Tolerance of the filterpy oracle (``TOL = 1e-9``), scale-free so it means the same at belt scale
(variances ~1e-8 m²) and at unit scale: a covariance entry agrees when
``|P_ij − P_ref_ij| <= TOL · sqrt(P_ref_ii · P_ref_jj)`` and a mean entry when
``|x_i − x_ref_i| <= TOL · (|x_ref_i| + sqrt(P_ref_ii))``.
"""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.common import Q_continuous_white_noise
from filterpy.kalman import KalmanFilter
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from predictors import available_predictors, make_predictor
from predictors.base import Predictor
from predictors.kalman.predictor import (
    R_FLOOR,
    KalmanPredictor,
    KalmanState,
    ca_model,
    cv_model,
    kf_update,
    random_walk_model,
)
from track_envs.values.types import SensorSpec

TOL = 1e-9


def make_spec(dim: int = 2, dt: float = 0.01, noise_std: float = 1e-4) -> SensorSpec:
    return SensorSpec(
        dt=dt,
        dim=dim,
        noise_std=noise_std,
        p_detect=1.0,
        clutter_rate=0.0,
        region_low=(0.0,) * dim,
        region_high=(1.0,) * dim,
        max_detections=16,
        max_tracks=16,
    )


def assert_gaussian_close(
    mean: NDArray[np.float64],
    cov: NDArray[np.float64],
    ref_mean: NDArray[np.float64],
    ref_cov: NDArray[np.float64],
    what: str,
) -> None:
    std = np.sqrt(np.diagonal(ref_cov, axis1=-2, axis2=-1))
    cov_err = np.abs(cov - ref_cov) / (std[..., :, None] * std[..., None, :])
    mean_err = np.abs(mean - ref_mean) / (np.abs(ref_mean) + std)
    assert cov_err.max(initial=0.0) <= TOL, f"{what}: cov error {cov_err.max()}"
    assert mean_err.max(initial=0.0) <= TOL, f"{what}: mean error {mean_err.max()}"


ORACLE_CASES = [
    ("cv", 2, 0.1, 0.5, 1.0),
    ("ca", 2, 0.1, 0.5, 1.0),
    ("random-walk", 2, 0.1, 0.5, 1.0),
    ("ca", 3, 0.1, 0.5, 2.0),
    ("cv", 2, 0.01, 1e-4, None),  # belt scale, default q
    ("ca", 2, 0.01, 1e-4, None),
]


@pytest.mark.parametrize(("model", "dim", "dt", "noise", "q"), ORACLE_CASES)
def test_matches_filterpy(model: str, dim: int, dt: float, noise: float, q: float | None) -> None:
    K, T, p_miss = 20, 50, 0.3
    rng = np.random.default_rng(ORACLE_CASES.index((model, dim, dt, noise, q)))
    kwargs = {} if model == "random-walk" else {"initial_velocity": rng.normal(size=dim)}
    pred = KalmanPredictor(model, q=q, **kwargs)  # type: ignore[arg-type]
    pred.reset(make_spec(dim, dt, noise))
    truth = np.cumsum(rng.normal(scale=1.0, size=(T + 1, K, dim)) * dt, axis=0) + rng.uniform(size=(K, dim))
    zs = truth + rng.normal(scale=noise, size=truth.shape)
    seen_all = rng.random((T, K)) >= p_miss

    state = pred.start(zs[0])
    S = pred.state_dim
    filters = []
    for i in range(K):
        kf = KalmanFilter(dim_x=S, dim_z=dim)
        kf.F, kf.Q, kf.H, kf.R = pred.F.copy(), pred.Q.copy(), pred.H.copy(), pred.R.copy()
        kf.x = state.mean[i].reshape(S, 1).copy()
        kf.P = state.cov[i].copy()
        filters.append(kf)

    for t in range(T):
        state, meas = pred.predict(state)
        for kf in filters:
            kf.predict()
        ref_mean = np.stack([kf.x[:, 0] for kf in filters])
        ref_cov = np.stack([kf.P for kf in filters])
        assert_gaussian_close(state.mean, state.cov, ref_mean, ref_cov, f"predict {t}")
        H, R = pred.H, pred.R
        assert_gaussian_close(meas.mean, meas.cov, ref_mean @ H.T, H @ ref_cov @ H.T + R, f"meas {t}")

        z = zs[t + 1].copy()
        seen = seen_all[t]
        z[~seen] = np.nan
        state = pred.update(state, z, seen)
        for row in np.flatnonzero(seen):
            filters[row].update(z[row].reshape(dim, 1))
        ref_mean = np.stack([kf.x[:, 0] for kf in filters])
        ref_cov = np.stack([kf.P for kf in filters])
        assert_gaussian_close(state.mean, state.cov, ref_mean, ref_cov, f"update {t}")


def test_start_state() -> None:
    pred = KalmanPredictor(
        "ca", initial_velocity_std=0.5, initial_acceleration_std=3.0, initial_velocity=[1, 2]
    )
    pred.reset(make_spec(noise_std=0.01))
    z = np.array([[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]])
    state = pred.start(z)
    np.testing.assert_array_equal(state.mean, [[*row, 1, 2, 0, 0] for row in z])
    P0 = np.diag([1e-4, 1e-4, 0.25, 0.25, 9.0, 9.0])
    np.testing.assert_allclose(state.cov, np.broadcast_to(P0, (3, 6, 6)), rtol=1e-15)
    cv = KalmanPredictor("cv")
    cv.reset(make_spec(noise_std=0.0))
    s = cv.start(z)
    np.testing.assert_array_equal(s.mean[:, 2:], 0.0)
    np.testing.assert_array_equal(s.cov[0], np.diag([R_FLOOR, R_FLOOR, 1.0, 1.0]))


@pytest.mark.parametrize(("dt", "q"), [(0.01, 1.0), (0.1, 3.0), (1.0, 0.5)])
def test_model_matrices_closed_form(dt: float, q: float) -> None:
    D = 2
    F, Q, H = cv_model(D, dt, q)
    np.testing.assert_allclose(Q[::D, ::D], Q_continuous_white_noise(dim=2, dt=dt, spectral_density=q))
    np.testing.assert_allclose(Q, Q_continuous_white_noise(2, dt, q, block_size=D, order_by_dim=False))
    np.testing.assert_allclose(Q[:D, :D], q * dt**3 / 3 * np.eye(D))
    np.testing.assert_allclose(Q[:D, D:], q * dt**2 / 2 * np.eye(D))
    np.testing.assert_allclose(Q[D:, D:], q * dt * np.eye(D))
    np.testing.assert_array_equal(F, np.kron([[1, dt], [0, 1]], np.eye(D)))
    np.testing.assert_array_equal(H, np.hstack([np.eye(D), np.zeros((D, D))]))

    F, Q, H = ca_model(D, dt, q)
    np.testing.assert_allclose(Q[::D, ::D], Q_continuous_white_noise(dim=3, dt=dt, spectral_density=q))
    np.testing.assert_allclose(Q, Q_continuous_white_noise(3, dt, q, block_size=D, order_by_dim=False))
    block = q * np.array(
        [[dt**5 / 20, dt**4 / 8, dt**3 / 6], [dt**4 / 8, dt**3 / 3, dt**2 / 2], [dt**3 / 6, dt**2 / 2, dt]]
    )
    np.testing.assert_allclose(Q, np.kron(block, np.eye(D)), rtol=1e-14)
    np.testing.assert_allclose(F, np.kron([[1, dt, dt**2 / 2], [0, 1, dt], [0, 0, 1]], np.eye(D)))
    np.testing.assert_array_equal(H, np.hstack([np.eye(D), np.zeros((D, 2 * D))]))

    F, Q, H = random_walk_model(3, dt, q)
    np.testing.assert_array_equal(F, np.eye(3))
    np.testing.assert_allclose(Q, q * dt * np.eye(3))
    np.testing.assert_array_equal(H, np.eye(3))


def _predictor(model: str = "cv", dim: int = 2, noise: float = 1e-3) -> KalmanPredictor:
    pred = KalmanPredictor(model)  # type: ignore[arg-type]
    pred.reset(make_spec(dim, 0.01, noise))
    return pred


def test_protocol_and_take_concat_round_trip() -> None:
    pred = _predictor("ca")
    assert isinstance(pred, Predictor)
    rng = np.random.default_rng(1)
    state, _ = pred.predict(pred.start(rng.uniform(size=(5, 2))))
    state = pred.update(state, rng.uniform(size=(5, 2)), np.array([True, False, True, True, False]))
    mask = np.array([True, False, True, False, True])
    joined = KalmanState.concat([state.take(mask), state.take(~mask)])
    order = np.concatenate([np.flatnonzero(mask), np.flatnonzero(~mask)])
    expected = state.take(order)
    assert len(joined) == 5
    np.testing.assert_array_equal(joined.mean, expected.mean)
    np.testing.assert_array_equal(joined.cov, expected.cov)
    back = joined.take(np.argsort(order))
    np.testing.assert_array_equal(back.mean, state.mean)
    np.testing.assert_array_equal(back.cov, state.cov)
    # predicting a concatenation is concatenating the predictions
    p_joined, m_joined = pred.predict(joined)
    p_a, m_a = pred.predict(state.take(mask))
    np.testing.assert_array_equal(p_joined.mean[:3], p_a.mean)
    np.testing.assert_array_equal(m_joined.cov[:3], m_a.cov)
    with pytest.raises(ValueError, match="at least one"):
        KalmanState.concat([])


@pytest.mark.parametrize("model", ["cv", "ca", "random-walk"])
def test_unseen_rows_untouched_and_nan_ignored(model: str) -> None:
    pred = _predictor(model)
    rng = np.random.default_rng(2)
    state, _ = pred.predict(pred.start(rng.uniform(size=(6, 2))))
    mean_before, cov_before = state.mean.copy(), state.cov.copy()
    seen = np.array([False, True, False, True, True, False])
    z = rng.uniform(size=(6, 2))
    z_nan = z.copy()
    z_nan[~seen] = np.nan
    z_nan[0] = np.inf
    out = pred.update(state, z_nan, seen)
    np.testing.assert_array_equal(out.mean[~seen], state.mean[~seen])
    np.testing.assert_array_equal(out.cov[~seen], state.cov[~seen])
    assert np.all(np.isfinite(out.mean)) and np.all(np.isfinite(out.cov))
    assert not np.array_equal(out.mean[seen], state.mean[seen])
    other = pred.update(state, z, seen)  # finite values in the unseen rows change nothing
    np.testing.assert_array_equal(other.mean, out.mean)
    np.testing.assert_array_equal(other.cov, out.cov)
    np.testing.assert_array_equal(state.mean, mean_before)  # the input is not mutated
    np.testing.assert_array_equal(state.cov, cov_before)
    none = pred.update(state, z_nan, np.zeros(6, dtype=bool))
    np.testing.assert_array_equal(none.mean, state.mean)


@pytest.mark.parametrize("model", ["cv", "ca", "random-walk"])
@pytest.mark.parametrize("noise", [0.0, 1e-6])
def test_covariance_stays_spd_after_many_updates(model: str, noise: float) -> None:
    pred = _predictor(model, noise=noise)
    rng = np.random.default_rng(3)
    n = 4
    pos = rng.uniform(size=(n, 2))
    vel = np.array([1.3, 0.05])
    state = pred.start(pos + rng.normal(scale=noise, size=pos.shape))
    for _ in range(1000):
        pos = pos + vel * 0.01
        state, meas = pred.predict(state)
        state = pred.update(state, pos + rng.normal(scale=noise, size=pos.shape), np.ones(n, dtype=bool))
    for cov in (state.cov, meas.cov):
        np.testing.assert_array_equal(cov, np.swapaxes(cov, 1, 2))
        assert np.all(np.linalg.eigvalsh(cov) > 0)
        np.linalg.cholesky(cov)  # raises if not positive definite
    assert np.all(np.isfinite(state.mean))
    np.testing.assert_allclose(state.mean[:, :2], pos, atol=max(10 * noise, 1e-5))
    if model != "random-walk":
        np.testing.assert_allclose(state.mean[:, 2:4], np.broadcast_to(vel, (n, 2)), atol=1e-2)


def test_registry() -> None:
    names = available_predictors()
    assert {"kf-cv", "kf-ca", "random-walk"} <= set(names)
    for name, model in [("kf-cv", "cv"), ("kf-ca", "ca"), ("random-walk", "random-walk")]:
        pred = make_predictor(name)
        assert isinstance(pred, KalmanPredictor) and pred.model == model
    assert make_predictor("kf-ca", q=5.0, initial_acceleration_std=1.0).q == 5.0
    with pytest.raises(ValueError, match=r"unknown predictor 'nope'.*kf-ca.*kf-cv.*random-walk"):
        make_predictor("nope")


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match=r"unknown model 'cj'.*\['ca', 'cv', 'random-walk'\]"):
        KalmanPredictor("cj")  # type: ignore[arg-type]
    for q in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="q must be"):
            KalmanPredictor("cv", q=q)
    with pytest.raises(ValueError, match="initial_velocity_std must be"):
        KalmanPredictor("cv", initial_velocity_std=-1.0)
    with pytest.raises(ValueError, match="initial_acceleration_std must be"):
        KalmanPredictor("ca", initial_acceleration_std=float("nan"))
    with pytest.raises(ValueError, match="initial_acceleration_std needs model 'ca'"):
        KalmanPredictor("cv", initial_acceleration_std=1.0)
    with pytest.raises(ValueError, match="initial_velocity_std and initial_velocity"):
        KalmanPredictor("random-walk", initial_velocity=[1.0, 0.0])
    with pytest.raises(ValueError, match="initial_velocity must be a finite"):
        KalmanPredictor("cv", initial_velocity=[[1.0, 0.0]])  # type: ignore[list-item]
    with pytest.raises(ValueError, match="initial_velocity must have length D=2"):
        KalmanPredictor("cv", initial_velocity=[1.0, 0.0, 0.0]).reset(make_spec())
    with pytest.raises(RuntimeError, match="reset"):
        KalmanPredictor("cv").start(np.zeros((1, 2)))
    with pytest.raises(ValueError, match="dim must be"):
        cv_model(0, 0.01, 1.0)
    with pytest.raises(ValueError, match="dt must be"):
        ca_model(2, 0.0, 1.0)
    with pytest.raises(ValueError, match="q must be"):
        random_walk_model(2, 0.01, -1.0)

    pred = _predictor("cv")
    with pytest.raises(ValueError, match=r"z must have shape \(n, D=2\)"):
        pred.start(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="z must be finite"):
        pred.start(np.full((1, 2), np.nan))
    state, _ = pred.predict(pred.start(np.zeros((3, 2))))
    with pytest.raises(ValueError, match=r"z must have shape \(3, D=2\)"):
        pred.update(state, np.zeros((2, 2)), np.ones(3, dtype=bool))
    with pytest.raises(ValueError, match=r"seen must be a boolean array of shape \(3,\)"):
        pred.update(state, np.zeros((3, 2)), np.ones(2, dtype=bool))
    with pytest.raises(ValueError, match="seen must be a boolean"):
        pred.update(state, np.zeros((3, 2)), np.ones(3, dtype=int))
    with pytest.raises(ValueError, match="finite in the rows where seen"):
        pred.update(state, np.full((3, 2), np.nan), np.array([True, False, False]))
    with pytest.raises(ValueError, match=r"state must have mean \(n, 6\).*got \(3, 4\)"):
        _predictor("ca").predict(state)


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(0, 6),
    model=st.sampled_from(["cv", "ca", "random-walk"]),
    seed=st.integers(0, 2**32 - 1),
    data=st.data(),
)
def test_property_batched_equals_per_track(n: int, model: str, seed: int, data: st.DataObject) -> None:
    seen = np.array(data.draw(st.lists(st.booleans(), min_size=n, max_size=n)), dtype=bool)
    pred = _predictor(model, noise=1e-3)
    rng = np.random.default_rng(seed)
    state = pred.start(rng.uniform(size=(n, 2)))
    assert len(state) == n
    state, meas = pred.predict(state)
    assert meas.mean.shape == (n, 2) and meas.cov.shape == (n, 2, 2)
    z = rng.uniform(size=(n, 2))
    z[~seen] = np.nan
    out = pred.update(state, z, seen)
    assert out.mean.shape == state.mean.shape and out.cov.shape == state.cov.shape
    np.testing.assert_array_equal(out.mean[~seen], state.mean[~seen])
    np.testing.assert_array_equal(out.cov[~seen], state.cov[~seen])
    for i in np.flatnonzero(seen):  # each seen row as a batch of one, with the textbook inverse
        x, P = state.mean[i], state.cov[i]
        H, R = pred.H, pred.R
        K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
        A = np.eye(len(x)) - K @ H
        ref_P = A @ P @ A.T + K @ R @ K.T
        assert_gaussian_close(out.mean[i], out.cov[i], x + K @ (z[i] - H @ x), ref_P, f"row {i}")
        one = kf_update(x[None], P[None], z[i][None], H, R)
        np.testing.assert_allclose(one[0][0], out.mean[i], rtol=1e-12, atol=0)
    if n:
        joined = KalmanState.concat([out, out.take(np.arange(n)[::-1])])
        assert len(joined) == 2 * n
