"""Recalibrating predicted covariances by one scale factor (Pollithy et al. 2020, Sec. IV-E).

With ``d² = (y − ŷ)ᵀ Σ⁻¹ (y − ŷ)`` of held-out predictions, the *reliability curve* gives for each
expected confidence level ``p`` the empirical level ``p_emp(p) = P̂(d² ≤ F⁻¹(p))``, with ``F`` the
χ² CDF with ``D`` degrees of freedom
([`track_envs.metrics.prediction.Reliability`][track_envs.metrics.Reliability]). Following Kuleshov, Fenner
and Ermon ("Accurate Uncertainties for Deep Learning Using Calibrated Regression", 2018), an isotonic
regression fits the monotone map ``R: p_emp → p`` from empirical to expected levels
(``scipy.optimize.isotonic_regression``). The covariances are then scaled, keeping their shapes, by

    r = F⁻¹(R(p_des)) / F⁻¹(p_des),       Σ_cal = r Σ,

at the design level ``p_des`` (0.999: the gate probability of the tracker). Direction check: an
over-confident model has ``p_emp(p) < p``, so the level whose empirical coverage is ``p_des`` is
``R(p_des) > p_des`` and ``r > 1`` widens the covariances — after scaling, the empirical coverage
at ``p_des`` is ``p_des`` (up to the curve's resolution, which is why the grid is dense near 1).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import isotonic_regression
from scipy.stats import chi2

from track_envs.infra.atomic import save_figure
from track_envs.metrics.prediction import Reliability

FloatArray = NDArray[np.float64]
#: The design confidence level of the scale factor (the tracker's gate probability).
P_DES = 0.999


def calibration_levels() -> FloatArray:
    """Expected levels of the curve: 0.01 … 0.99, then 1 − 10⁻² … 1 − 10⁻¹⁴ densely (the tail).

    The tail matters: learned models have heavy-tailed errors (a track's first prediction), so the
    empirical level reaches ``p_des = 0.999`` only far out in the χ² tail.
    """
    body = np.round(np.arange(1, 100) * 0.01, 10)
    tail = 1.0 - np.logspace(-2, -14, 241)
    return np.unique(np.concatenate([body, tail]))


@dataclass(frozen=True)
class Recalibration:
    """A fitted recalibration: the curve it was fitted on, the map ``R`` and the factor ``r``.

    Attributes:
        expected: Expected levels of the curve (k,).
        empirical: Empirical levels before recalibration (k,).
        mapped: ``R`` at each empirical level: the isotonic fit of ``expected`` on ``empirical`` (k,).
        p_des: The design level.
        scale: The factor ``r``.
        dim: Degrees of freedom ``D``.
    """

    expected: FloatArray
    empirical: FloatArray
    mapped: FloatArray
    p_des: float
    scale: float
    dim: int

    def R(self, p: float) -> float:
        """The expected level whose empirical coverage is ``p`` (linear between curve points)."""
        order = np.argsort(self.empirical, kind="stable")
        return float(np.interp(p, self.empirical[order], self.mapped[order]))


def reliability(
    means: FloatArray, covs: FloatArray, targets: FloatArray, levels: FloatArray | None = None
) -> tuple[FloatArray, FloatArray]:
    """Expected and empirical levels of predictions ``N(means, covs)`` against ``targets``."""
    r = Reliability(calibration_levels() if levels is None else levels)
    r.update(means, covs, targets)
    return r.curve()


def fit_recalibration(
    means: FloatArray, covs: FloatArray, targets: FloatArray, p_des: float = P_DES
) -> Recalibration:
    """Fit ``R`` and ``r`` on predictions of data the model was not trained on (calibration data;
    see the module docstring). Coverage measured on these same predictions is not held out.

    Raises:
        ValueError: for ``p_des`` outside (0, 1) or fewer than 100 predictions (too few to fit
            a curve that reaches ``p_des``).
    """
    if not 0.0 < p_des < 1.0:
        raise ValueError(f"p_des must be in (0, 1), got {p_des!r}")
    if len(means) < 100:
        raise ValueError(f"calibration needs at least 100 predictions, got {len(means)}")
    dim = means.shape[1]
    d2 = Reliability()._d2(means, covs, targets)
    # the grid plus the expected levels of the empirical quantiles around p_des, so the curve has
    # points exactly where R(p_des) is read, however badly scaled the covariances are
    near = chi2.cdf(np.quantile(d2, np.clip(p_des + np.array([-2e-3, -1e-3, 0.0, 1e-3]), 0.0, 1.0)), dim)
    near = near[(near > 0.0) & (near < 1.0)]
    levels = np.unique(np.concatenate([calibration_levels(), near]))
    expected, empirical = reliability(means, covs, targets, levels)
    order = np.argsort(empirical, kind="stable")
    fitted = np.empty_like(expected)
    fitted[order] = isotonic_regression(expected[order], increasing=True).x
    cal = Recalibration(expected, empirical, fitted, p_des, 1.0, dim)
    if empirical.max() >= p_des and empirical.min() <= p_des:
        scale = float(chi2.ppf(cal.R(p_des), dim) / chi2.ppf(p_des, dim))
    else:
        # the curve does not reach p_des inside (0, 1) in floating point: F⁻¹(R(p_des)) is then the
        # empirical p_des-quantile of d² itself (the curve's continuous limit)
        scale = float(np.quantile(d2, p_des) / chi2.ppf(p_des, dim))
    return Recalibration(expected, empirical, fitted, p_des, scale, dim)


def coverage(d2: FloatArray, p: float, dim: int) -> float:
    """Fraction of squared Mahalanobis distances inside the χ²_D region of level ``p``."""
    d2 = np.asarray(d2, dtype=np.float64)
    return float(np.mean(d2 <= chi2.ppf(p, dim))) if len(d2) else float("nan")


def plot_reliability(
    curves: dict[str, tuple[FloatArray, FloatArray]], path: str | os.PathLike[str], title: str = ""
) -> None:
    """Write reliability diagrams (expected vs empirical level) of several curves as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 6))
    ax.plot([0, 1], [0, 1], color="0.6", linestyle="--", label="calibrated")
    for label, (expected, empirical) in curves.items():
        ax.plot(expected, empirical, marker=".", label=label)
    ax.set_xlabel("expected confidence level")
    ax.set_ylabel("empirical confidence level")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.set_title(title or "reliability (χ² of squared Mahalanobis distances)")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), fontsize=8, frameon=False)
    fig.tight_layout()
    try:
        save_figure(fig, path, dpi=120)
    finally:
        plt.close(fig)
