"""The Kalman filters' PDA update (update_mixture) against the moment-matched mixture of explicit
filterpy updates, one per hypothesis (an independent oracle)."""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from predictors import make_predictor
from predictors.kalman.predictor import KalmanPredictor
from track_envs.values.types import SensorSpec

SPEC = SensorSpec(
    dt=0.01, dim=2, noise_std=1e-3, p_detect=0.9, clutter_rate=1.0,
    region_low=(0.0, 0.0), region_high=(1.0, 1.0), max_detections=8, max_tracks=8,
)  # fmt: skip


def _oracle(kf: KalmanPredictor, x: np.ndarray, P: np.ndarray, zs: np.ndarray, betas: np.ndarray):
    """Mixture of 'missed' (weight 1 − Σβ, the prediction) and one filterpy update per detection
    (weight β_j), reduced to its mean and covariance."""
    comps = [(1.0 - betas.sum(), x, P)]
    for z, b in zip(zs, betas, strict=True):
        f = KalmanFilter(dim_x=len(x), dim_z=2)
        f.x, f.P, f.H, f.R = x.copy(), P.copy(), kf.H, kf.R
        f.update(z)
        comps.append((b, f.x.copy(), f.P.copy()))
    mean = sum(w * m for w, m, _ in comps)
    cov = sum(w * (C + np.outer(m - mean, m - mean)) for w, m, C in comps)
    return mean, cov


@pytest.mark.parametrize("model", ["kf-cv", "kf-ca", "random-walk"])
def test_update_mixture_is_the_moment_matched_mixture_of_updates(model: str) -> None:
    rng = np.random.default_rng(5)
    kf = make_predictor(model)
    kf.reset(SPEC)
    state = kf.start(rng.uniform(0, 1, (6, 2)))
    state, pred = kf.predict(kf.predict(state)[0])
    z_mean, z_spread, p = np.zeros((6, 2)), np.zeros((6, 2, 2)), np.zeros(6)
    hyps = []
    for i in range(6):
        k = i % 4  # 0..3 detections in the gate
        zs = pred.mean[i] + rng.normal(0, 2e-3, (k, 2))
        betas = rng.dirichlet(np.ones(k + 1))[:k] if k else np.zeros(0)
        if i == 5:
            betas = betas / betas.sum()  # detected for sure
        hyps.append((zs, betas))
        p[i] = betas.sum()
        if k:
            z_mean[i] = betas @ zs / p[i]
            d = zs - z_mean[i]
            z_spread[i] = (betas[:, None, None] * d[:, :, None] * d[:, None, :]).sum(0) / p[i]
    got = kf.update_mixture(state, z_mean, z_spread, np.clip(p, 0, 1))
    for i, (zs, betas) in enumerate(hyps):
        mean, cov = _oracle(kf, state.mean[i], state.cov[i], zs, betas)
        np.testing.assert_allclose(got.mean[i], mean, rtol=0, atol=1e-12)
        np.testing.assert_allclose(got.cov[i], cov, rtol=1e-9, atol=1e-18)
    # p = 0 coasts exactly; p = 1 with no spread is the plain update
    np.testing.assert_array_equal(got.mean[0], state.mean[0])
    np.testing.assert_array_equal(got.cov[0], state.cov[0])
    one = kf.update_mixture(state, pred.mean + 1e-3, np.zeros((6, 2, 2)), np.ones(6))
    plain = kf.update(state, pred.mean + 1e-3, np.ones(6, dtype=bool))
    np.testing.assert_allclose(one.mean, plain.mean, rtol=0, atol=1e-13)
    np.testing.assert_allclose(one.cov, plain.cov, rtol=1e-9, atol=1e-18)


def test_update_mixture_names_bad_arguments() -> None:
    kf = make_predictor("kf-cv")
    kf.reset(SPEC)
    state = kf.start(np.zeros((2, 2)))
    ok = (np.zeros((2, 2)), np.zeros((2, 2, 2)), np.full(2, 0.5))
    with pytest.raises(ValueError, match="p_seen"):
        kf.update_mixture(state, ok[0], ok[1], np.array([0.5, 1.5]))
    with pytest.raises(ValueError, match="z_spread"):
        kf.update_mixture(state, ok[0], np.zeros((2, 3, 3)), ok[2])
    with pytest.raises(ValueError, match="z_mean must have shape"):
        kf.update_mixture(state, np.zeros((3, 2)), ok[1], ok[2])
    with pytest.raises(ValueError, match="finite"):
        kf.update_mixture(state, np.full((2, 2), np.nan), ok[1], ok[2])
