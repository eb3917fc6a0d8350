"""Measurement and process noise of a Kalman model from labelled detections (autocovariance least squares).

A track's detections ``z_t = p_t + e_t`` at consecutive frames, with white measurement noise
``e_t ~ N(0, r I)`` and a position ``p_t`` that is an ``m``-fold integrator of continuous white
noise of intensity ``q`` per axis (``m = 1``: random walk, ``2``: constant velocity, ``3``:
constant acceleration — the models of [`predictors.kalman.predictor`][predictors.kalman.predictor]), are made
stationary by the ``m``-th difference ``d_t = Δ^m z_t``. Its autocovariance at lag ``k`` is linear in the two
unknowns:

.. math::

    c_k = E[d_t d_{t+k}] = r \\, (-1)^k \\binom{2m}{m+k}
          + q \\, dt^{2m-1} \\, β_{2m-1}(k), \\qquad k = 0..m,

where ``β_{2m-1}`` is the centred cardinal B-spline of degree ``2m − 1`` (the ``m``-th difference
of an ``m``-fold integrator is white noise filtered by the ``m``-fold convolution of a box of one
frame; its autocorrelation is the ``2m``-fold one): for constant velocity ``c_0 = 6 r + ⅔ q dt³``,
``c_1 = −4 r + q dt³ / 6``, ``c_2 = r``. The sample autocovariances of many tracks, pooled over
axes, give ``(r, q)`` by non-negative least squares: the autocovariance least-squares idea of
Odelson, Rajamani and Rawlings ("A new autocovariance least-squares method for estimating noise
covariances", Automatica 42, 2006), applied to the differenced measurements instead of a filter's
innovations, so that the estimate does not depend on the filter settings it is meant to give.

Differences that a wrong association made (a jump onto another target) are outliers: every
difference beyond ``OUTLIER_SIGMAS`` robust standard deviations (1.4826 × median absolute value)
is dropped with the products it takes part in. Every quantity is a second moment of positions, so
the estimate scales with the data: positions × k give ``r`` × k² and ``q`` × k².
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: A difference further than this many robust standard deviations from 0 is taken for a wrong association.
OUTLIER_SIGMAS = 6.0


@dataclass(frozen=True)
class NoiseEstimate:
    """Measurement variance ``r`` and process-noise intensity ``q`` per axis, in the input's units.

    Attributes:
        r: Measurement noise variance per axis (units²).
        q: White-noise intensity of the model's driving derivative (units² / s^(2m − 1)).
        order: ``m``: 1 random walk, 2 constant velocity, 3 constant acceleration.
        n_differences: ``m``-th differences the estimate rests on (after outliers).
        n_outliers: Differences dropped as wrong associations.
        autocovariance: ``c_0..c_m`` pooled over axes.
    """

    r: float
    q: float
    order: int
    n_differences: int
    n_outliers: int
    autocovariance: tuple[float, ...]


def bspline_at_integers(degree: int, lags: int) -> NDArray[np.float64]:
    """The centred cardinal B-spline of odd ``degree`` at ``k = 0..lags``:
    ``β_n(k) = (1/n!) Σ_j (−1)^j C(n+1, j) (k + (n+1)/2 − j)_+^n``."""
    n = degree
    out = np.zeros(lags + 1)
    for k in range(lags + 1):
        s = 0.0
        for j in range(n + 2):
            x = k + (n + 1) / 2 - j
            if x > 0:
                s += (-1) ** j * math.comb(n + 1, j) * x**n
        out[k] = s / math.factorial(n)
    return out


def design_matrix(order: int) -> NDArray[np.float64]:
    """(m + 1, 2) coefficients of ``r`` and ``q dt^(2m−1)`` in ``c_0..c_m`` (module docstring)."""
    m = order
    noise = np.array([(-1) ** k * math.comb(2 * m, m + k) for k in range(m + 1)], dtype=np.float64)
    return np.stack([noise, bspline_at_integers(2 * m - 1, m)], axis=1)


def track_differences(
    points: NDArray[np.float64], frames: NDArray[np.int64], labels: NDArray[np.int64], order: int
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The ``order``-th differences of every run of consecutive frames of each label.

    Args:
        points: (N, D) detections.
        frames: (N,) frame of each detection.
        labels: (N,) track label of each detection (−1: none, skipped).
        order: ``m``.

    Returns:
        ``(d, run)``: (K, D) differences in frame order within each run, and (K,) an integer that is
            the same for differences of one run and whose consecutive entries are consecutive frames
            (``run[i + 1] == run[i]`` means ``d[i + 1]`` is the next frame's difference of the same run).
    """
    keep = labels >= 0
    idx = np.flatnonzero(keep)
    idx = idx[np.lexsort((frames[idx], labels[idx]))]
    z, f, lab = points[idx], frames[idx], labels[idx]
    if len(z) <= order:
        return np.zeros((0, points.shape[1])), np.zeros(0, np.int64)
    step = (lab[1:] == lab[:-1]) & (f[1:] == f[:-1] + 1)  # link i -> i+1
    run_id = np.cumsum(np.concatenate([[True], ~step]))  # a run = consecutive linked rows
    d = z
    for _ in range(order):
        d = d[1:] - d[:-1]
    # d[i] spans rows i..i+order: valid when those rows are one run
    same = run_id[order:] == run_id[: len(run_id) - order]
    return d[same], run_id[: len(run_id) - order][same]


def estimate_noise(
    points: NDArray[np.float64],
    frames: NDArray[np.int64],
    labels: NDArray[np.int64],
    dt: float,
    order: int,
) -> NoiseEstimate | None:
    """``(r, q)`` by least squares on the pooled autocovariances of the ``order``-th differences
    (module docstring); None when fewer than ``4 (order + 1)`` usable difference pairs exist."""
    d, run = track_differences(points, frames, labels, order)
    if len(d) < 4 * (order + 1):
        return None
    scale = 1.4826 * np.median(np.abs(d), axis=0)
    scale = np.where(scale > 0, scale, np.max(scale))
    bad = np.any(np.abs(d) > OUTLIER_SIGMAS * scale, axis=1) if np.max(scale) > 0 else np.zeros(len(d), bool)
    # a dropped difference splits its run
    run = run + np.cumsum(bad)
    d, run = d[~bad], run[~bad]
    m = order
    c = np.zeros(m + 1)
    for k in range(m + 1):
        if len(d) <= k:
            return None
        pair = run[k:] == run[: len(run) - k]
        # products whose two differences are k frames apart within a run: the run ids match and the
        # k rows between are all of it (rows of one run are consecutive frames)
        if not pair.any():
            return None
        c[k] = float(np.mean(np.sum(d[k:][pair] * d[: len(d) - k][pair], axis=1))) / d.shape[1]
    A = design_matrix(m)
    r, qd = _nnls2(A, c)
    return NoiseEstimate(
        r=r,
        q=qd / dt ** (2 * m - 1),
        order=m,
        n_differences=len(d),
        n_outliers=int(bad.sum()),
        autocovariance=tuple(float(v) for v in c),
    )


def _nnls2(A: NDArray[np.float64], c: NDArray[np.float64]) -> tuple[float, float]:
    """Non-negative least squares in two unknowns (``scipy.optimize.nnls``)."""
    from scipy.optimize import nnls

    x, _ = nnls(A, c)
    return float(x[0]), float(x[1])
