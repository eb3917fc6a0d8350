"""Recalibration by one scale factor: direction, coverage after calibration, the plot."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chi2

from predictors.training.calibration import P_DES, coverage, fit_recalibration, plot_reliability, reliability
from track_envs.metrics.prediction import mahalanobis_sq


def _predictions(n: int, true_scale: float, seed: int, heavy: bool = False) -> tuple[np.ndarray, ...]:
    """Predicted N(0, diag(1, 4)) against targets of a covariance ``true_scale`` times larger."""
    rng = np.random.default_rng(seed)
    cov = np.broadcast_to(np.diag([1.0, 4.0]), (n, 2, 2)).copy()
    # Student t with 5 dof: heavier tails than the Gaussian the model claims
    z = rng.standard_t(5, size=(n, 2)) if heavy else rng.normal(size=(n, 2))
    targets = z * np.sqrt(true_scale) * np.array([1.0, 2.0])
    return np.zeros((n, 2)), cov, targets


@pytest.mark.parametrize(("true_scale", "heavy"), [(3.0, False), (0.25, False), (1.0, True)])
def test_coverage_at_p_des_after_calibration(true_scale: float, heavy: bool) -> None:
    means, covs, targets = _predictions(40_000, true_scale, seed=1, heavy=heavy)
    cal = fit_recalibration(means, covs, targets)
    if not heavy:
        assert cal.scale == pytest.approx(true_scale, rel=0.1)  # the factor undoes the misscaling
    m, c, t = _predictions(40_000, true_scale, seed=2, heavy=heavy)  # held-out test predictions
    d2 = mahalanobis_sq(m, c * cal.scale, t)
    assert abs(coverage(d2, P_DES, 2) - P_DES) <= 0.005


def test_direction_over_and_under_confident() -> None:
    over = fit_recalibration(*_predictions(20_000, 4.0, seed=0))
    under = fit_recalibration(*_predictions(20_000, 0.5, seed=0))
    assert over.scale > 1.0 > under.scale
    assert over.R(P_DES) > P_DES > under.R(P_DES)


def test_reliability_of_calibrated_predictions_is_the_diagonal() -> None:
    expected, empirical = reliability(*_predictions(50_000, 1.0, seed=3))
    assert np.max(np.abs(expected - empirical)) < 0.01


def test_closed_form_coverage() -> None:
    d2 = np.array([0.5, 1.0, chi2.ppf(0.9, 2) + 1e-9, 100.0])
    assert coverage(d2, 0.9, 2) == 0.5


def test_too_few_predictions_and_bad_level() -> None:
    with pytest.raises(ValueError, match=r"at least 100 predictions, got 10"):
        fit_recalibration(*_predictions(10, 1.0, seed=0))
    with pytest.raises(ValueError, match=r"p_des must be in \(0, 1\), got 1.0"):
        fit_recalibration(*_predictions(200, 1.0, seed=0), p_des=1.0)


def test_plot_is_written(tmp_path: Path) -> None:
    curve = reliability(*_predictions(1000, 2.0, seed=0))
    plot_reliability({"before": curve, "after": curve}, tmp_path / "r.png")
    assert (tmp_path / "r.png").stat().st_size > 5_000


def test_far_too_wide_covariances_are_narrowed_exactly() -> None:
    """A covariance 10⁴ times too wide (mc-lstm's τ⁻¹ term can do that) still calibrates at p_des."""
    means, covs, targets = _predictions(40_000, 1e-4, seed=4)
    cal = fit_recalibration(means, covs, targets)
    assert cal.scale == pytest.approx(1e-4, rel=0.1)
    m, c, t = _predictions(40_000, 1e-4, seed=5)
    assert abs(coverage(mahalanobis_sq(m, c * cal.scale, t), P_DES, 2) - P_DES) <= 0.005
