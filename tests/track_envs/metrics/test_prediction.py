"""Prediction error, NEES and reliability curves against closed forms and sampled Gaussians."""

from __future__ import annotations

import numpy as np
import pytest

from track_envs.metrics import Nees, PredictionError, Reliability, mahalanobis_sq


def random_gaussians(rng: np.random.Generator, n: int, dim: int):
    a = rng.normal(size=(n, dim, dim))
    cov = a @ a.transpose(0, 2, 1) + 0.1 * np.eye(dim)
    mean = rng.normal(scale=5.0, size=(n, dim))
    samples = mean + np.einsum("nij,nj->ni", np.linalg.cholesky(cov), rng.normal(size=(n, dim)))
    return mean, cov, samples


def test_mahalanobis_closed_forms():
    mean = np.zeros((2, 2))
    target = np.array([[3.0, 4.0], [1.0, 0.0]])
    assert mahalanobis_sq(mean, np.broadcast_to(np.eye(2), (2, 2, 2)), target) == pytest.approx([25.0, 1.0])
    cov = np.array([np.diag([9.0, 16.0]), np.diag([4.0, 1.0])])
    assert mahalanobis_sq(mean, cov, target) == pytest.approx([2.0, 0.25])
    with pytest.raises(ValueError, match="cov"):
        mahalanobis_sq(mean, np.eye(2), target)


def test_prediction_error_is_averaged_per_track_first():
    metric = PredictionError()
    # track 1: errors 1 and 3 (mean 2); track 2: error 5; a coasting row (NaN target) is skipped
    metric.update(np.zeros((2, 2)), np.array([[1.0, 0.0], [3.0, 4.0]]), np.array([1, 2]))
    metric.update(np.zeros((2, 2)), np.array([[0.0, 3.0], [np.nan, np.nan]]), np.array([1, 2]))
    out = metric.compute()
    assert out["prediction_error"] == pytest.approx((2 + 5) / 2)
    assert out["prediction_error_pooled"] == pytest.approx(3.0)
    assert out["prediction_rmse"] == pytest.approx(np.sqrt((1 + 25 + 9) / 3))
    assert (out["n_tracks"], out["n_predictions"]) == (2.0, 3.0)
    assert metric.compute() == out  # reading twice is idempotent
    metric.reset()
    assert np.isnan(metric.compute()["prediction_error"])


@pytest.mark.parametrize("dim", [2, 3])
def test_samples_from_the_prediction_are_calibrated(dim):
    rng = np.random.default_rng(dim)
    nees, rel = Nees(), Reliability()
    for _ in range(4):  # streaming: several batches
        mean, cov, samples = random_gaussians(rng, 5000, dim)
        nees.update(mean, cov, samples)
        rel.update(mean, cov, samples)
    assert nees.compute()["nees"] == pytest.approx(1.0, abs=0.03)
    expected, empirical = rel.curve()
    assert expected[[0, 9, -1]] == pytest.approx([0.05, 0.5, 0.999])
    assert np.max(np.abs(empirical - expected)) < 0.02
    out = rel.compute()
    assert out["calibration_error"] < 0.01
    assert out["reliability@0.50"] == pytest.approx(0.5, abs=0.02)
    assert out["reliability@0.999"] == pytest.approx(0.999, abs=0.003)
    assert out["nees"] == pytest.approx(nees.compute()["nees"])


def test_inflated_covariance_gives_quarter_nees_and_a_curve_above_the_diagonal():
    rng = np.random.default_rng(1)
    mean, cov, samples = random_gaussians(rng, 20000, 2)
    nees, rel = Nees(), Reliability()
    nees.update(mean, 4 * cov, samples)
    rel.update(mean, 4 * cov, samples)
    assert nees.compute()["nees"] == pytest.approx(0.25, abs=0.01)
    expected, empirical = rel.curve()
    # d² is shrunk four times: P(d²/4 <= q) = chi2_2.cdf(4 q) = 1 - (1 - p)^4 for D = 2
    assert empirical == pytest.approx(1 - (1 - expected) ** 4, abs=0.015)
    assert rel.compute()["calibration_error"] > 0.1


def test_empty_and_bad_input():
    assert np.isnan(Nees().compute()["nees"])
    with pytest.raises(ValueError, match="levels"):
        Reliability(levels=[0.5, 1.0])
    nees = Nees()
    nees.update(np.zeros((1, 2)), np.eye(2)[None], np.ones((1, 2)))
    with pytest.raises(ValueError, match="dimension"):
        nees.update(np.zeros((1, 3)), np.eye(3)[None], np.ones((1, 3)))
