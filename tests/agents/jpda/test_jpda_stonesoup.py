"""β against Stone Soup's JPDA (enumeration) and JPDAwithEHM on the same predicted Gaussians,
detections, clutter density and p_D (Stone Soup 1.9.1, a reference the ``dev`` extra installs)."""

from __future__ import annotations

import datetime

import numpy as np
import pytest
from scipy.stats import chi2
from stonesoup.dataassociator.probability import JPDA, JPDAwithEHM, JPDAwithLBP
from stonesoup.hypothesiser.probability import PDAHypothesiser
from stonesoup.models.measurement.linear import LinearGaussian
from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
from stonesoup.predictor.kalman import KalmanPredictor
from stonesoup.types.detection import Detection
from stonesoup.types.state import GaussianState
from stonesoup.types.track import Track
from stonesoup.updater.kalman import KalmanUpdater

from agents.jpda.lbp import lbp_marginals
from agents.jpda.marginals import jpda_marginals
from agents.jpda.weights import gaussian_log_likelihood
from track_envs.values.types import Gaussian

Q, R, DT = 0.3, 0.5, 1.0
F1 = np.array([[1.0, DT], [0.0, 1.0]])
Q1 = Q * np.array([[DT**3 / 3, DT**2 / 2], [DT**2 / 2, DT]])
F = np.kron(np.eye(2), F1)
QQ = np.kron(np.eye(2), Q1)
H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])


def frame(rng: np.random.Generator, n: int, side: float):
    """Tracks (state x = [x, vx, y, vy]) and detections: 0.9 detected near their prediction plus
    Poisson(2) uniform clutter."""
    x = np.column_stack(
        [rng.uniform(0, side, n), rng.normal(0, 1, n), rng.uniform(0, side, n), rng.normal(0, 1, n)]
    )
    P = np.stack([np.diag(rng.uniform(0.2, 1.5, 4)) for _ in range(n)])
    y = (x @ F.T) @ H.T
    seen = rng.random(n) < 0.9
    z = np.concatenate(
        [y[seen] + rng.normal(0, 1.5, (int(seen.sum()), 2)), rng.uniform(0, side, (rng.poisson(2), 2))]
    )
    return x, P, rng.permutation(z)


def ours(x: np.ndarray, P: np.ndarray, z: np.ndarray, p_d: float, lam: float, p_g: float):
    S = H @ (F @ P @ F.T + QQ) @ H.T + R * np.eye(2)
    log_g, d2 = gaussian_log_likelihood(Gaussian((x @ F.T) @ H.T, S), z)
    return jpda_marginals(log_g, d2 <= chi2.ppf(p_g, 2), p_d, lam, p_g)


def stone_soup(x, P, z, p_d, lam, p_g, associator_cls):
    t0 = datetime.datetime(2020, 1, 1)
    t1 = t0 + datetime.timedelta(seconds=DT)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(Q), ConstantVelocity(Q)])
    measurement = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=R * np.eye(2))
    hyp = PDAHypothesiser(
        predictor=KalmanPredictor(transition),
        updater=KalmanUpdater(measurement),
        clutter_spatial_density=lam,
        prob_detect=p_d,
        prob_gate=p_g,
    )
    tracks = [Track([GaussianState(xi[:, None], Pi, timestamp=t0)]) for xi, Pi in zip(x, P, strict=True)]
    dets = [Detection(zj[:, None], timestamp=t1, measurement_model=measurement) for zj in z]
    out = associator_cls(hyp).associate(set(tracks), set(dets), t1)
    beta = np.zeros((len(tracks), len(dets) + 1))
    index = {id(d): j for j, d in enumerate(dets)}
    for i, track in enumerate(tracks):
        for h in out[track]:
            j = index[id(h.measurement)] if h.measurement else len(dets)
            beta[i, j] = float(h.probability)
    return beta


@pytest.mark.parametrize("associator", [JPDA, JPDAwithEHM])
def test_beta_equals_stone_soup(associator) -> None:
    rng = np.random.default_rng(11)
    worst = 0.0
    cases = 25 if associator is JPDA else 40
    for _ in range(cases):
        n = int(rng.integers(1, 5 if associator is JPDA else 8))
        x, P, z = frame(rng, n, side=8.0)
        p_d, lam, p_g = rng.uniform(0.5, 0.99), rng.uniform(0.005, 0.2), rng.uniform(0.9, 0.999)
        got = ours(x, P, z, p_d, lam, p_g).beta
        want = stone_soup(x, P, z, p_d, lam, p_g, associator)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-6)
        worst = max(worst, float(np.abs(got - want).max()))
    assert worst < 1e-12  # measured 4.4e-16 (JPDA), 3.9e-16 (JPDAwithEHM), clusters up to 7 tracks


def test_lbp_equals_stone_soup_lbp() -> None:
    """Our loopy belief propagation and Stone Soup's, converged, on the same weights."""
    rng = np.random.default_rng(12)
    for _ in range(20):
        n, m = int(rng.integers(2, 7)), int(rng.integers(2, 8))
        log_pair = rng.normal(0, 1.5, (n, m))
        log_pair[rng.random((n, m)) < 0.3] = -np.inf
        log_miss = rng.normal(-1, 0.5, n)
        ratio = np.exp(log_pair - log_miss[:, None])
        ref = JPDAwithLBP._loopy_belief_propagation(np.column_stack([np.ones(n), ratio]), 1, 1e-12)
        pairs, miss, _ = lbp_marginals(log_pair, log_miss)
        np.testing.assert_allclose(pairs, ref[:, 1:], rtol=0, atol=1e-6)
        np.testing.assert_allclose(miss, ref[:, 0], rtol=0, atol=1e-6)


def test_the_compiled_frame_equals_stone_soup() -> None:
    """The jpda tracker's own pass (agents.jpda._kernels.jpda_frame, merge model off): every
    track's detection probability 1 − β_i∅ and its mixture's mean Σ_j β_ij z_j / (1 − β_i∅)."""
    import math

    from agents.jpda._kernels import jpda_frame

    rng = np.random.default_rng(5)
    worst = 0.0
    for _ in range(30):
        n = int(rng.integers(1, 8))
        x, P, z = frame(rng, n, side=8.0)
        p_d, lam, p_g = rng.uniform(0.5, 0.99), rng.uniform(0.005, 0.2), rng.uniform(0.9, 0.999)
        S = H @ (F @ P @ F.T + QQ) @ H.T + R * np.eye(2)
        y = np.ascontiguousarray((x @ F.T) @ H.T)
        got = jpda_frame(
            y, np.ascontiguousarray(S), np.ascontiguousarray(z), float(chi2.ppf(p_g, 2)), math.log(p_d / lam),
            math.log(1 - p_d * p_g), 0.0, R * np.eye(2), 0.0, 0.0, 12, np.ones(n, np.bool_),
        )  # fmt: skip
        want = stone_soup(x, P, z, p_d, lam, p_g, JPDAwithEHM)
        p = 1.0 - want[:, -1]
        worst = max(worst, float(np.abs(got.p_seen - p).max()))
        seen = p > 1e-9
        zbar = want[seen, :-1] @ z / p[seen, None]
        np.testing.assert_allclose(got.z_mean[seen], zbar, rtol=0, atol=1e-9)
    assert worst < 1e-12
