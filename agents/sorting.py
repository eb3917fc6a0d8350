"""Predicted nozzle-bar crossings: roll a predictor forward without measurements until the line.

When a belt tracker sees a track for the last time it must tell the sorter when and where across
the belt the particle will pass the nozzle bar ``x = L`` downstream of the camera (Pfaff et al.,
"TrackSort: Predictive Tracking for Sorting Uncooperative Bulk Materials", 2015). With any
predictor of the :class:`~predictors.base.Predictor` protocol this is a roll-out: frame after
frame ``predict`` then ``update`` with ``seen=False`` (which, for a Kalman filter, is the
filter's own time update, and for the learned predictors feeds their prediction back as the next
input), until the predicted position ``p_j = (x_j, y_j)`` passes the line. Between the two frames
around the line, at ``x_{j−1} < L <= x_j``, the crossing is interpolated:

.. math::

    φ = \\frac{L − x_{j−1}}{x_j − x_{j−1}}, \\quad t̂ = (k + j − 1 + φ)\\,dt, \\quad
    m = p_{j−1} + φ\\,(p_j − p_{j−1}), \\quad P = P_{j−1} + φ\\,(P_j − P_{j−1})

(``k`` the current frame). The position Gaussian ``N(m, P)`` at the predicted time becomes a
Gaussian of the crossing ``(t_c, y_c)`` to first order: with velocity ``v = (p_j − p_{j−1}) / dt``
a position error ``(δx, δy)`` shifts the crossing by ``δt = −δx / v_x`` and moves it across the
belt to ``δy − (v_y / v_x)\\,δx``, so

.. math::

    Σ = J P J^\\top, \\qquad J = \\begin{pmatrix} −1/v_x & 0 \\\\ −v_y/v_x & 1 \\end{pmatrix}.

``P`` is the predictor's own uncertainty of the position (not of a measurement):

* Kalman filters: ``estimate()`` after each coasting step, ``H P Hᵀ`` of the analytically
  propagated state covariance (``F P Fᵀ + Q`` per frame), so ``P`` carries the velocity and
  acceleration uncertainty forward;
* predictors whose ``estimate()`` after coasting is only the one-step prediction (the belt LSTMs:
  the network takes its fed-back prediction for a measurement; they set the class attribute
  ``rollout_covariance = "accumulate"``): ``P_j = P_{j−1} + S_j``, the one-step predicted
  covariances ``S_j`` of the roll-out summed, as for independent errors per step.

A track whose predicted ``x`` stops advancing, or that has not reached the line after
``max_steps`` frames, gets no prediction.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

#: Most frames a track is rolled forward (2 s at 100 Hz).
MAX_STEPS = 200


def predict_crossings(
    predictor: Any,
    state: Any,
    line: float,
    frame: int,
    dt: float,
    max_steps: int = MAX_STEPS,
) -> tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.float64]]:
    """Predicted crossings of the line ``x = line`` of every track of ``state`` (see the module docstring).

    Args:
        predictor: The tracker's predictor.
        state: Predictor state of the ``k`` tracks, at frame ``frame``.
        line: ``L``, the line's ``x``.
        frame: The frame the state belongs to (its time is ``frame · dt``).
        dt: Frame period.
        max_steps: Most frames to roll forward.

    Returns:
        ``ok`` (k,) whether a crossing was found, ``mean`` (k, 2) ``(t̂, ŷ)`` and ``cov`` (k, 2, 2)
        (NaN where not ``ok``).
    """
    k = len(state)
    ok = np.zeros(k, dtype=bool)
    mean = np.full((k, 2), np.nan)
    cov = np.full((k, 2, 2), np.nan)
    if k == 0:
        return ok, mean, cov
    accumulate = getattr(predictor, "rollout_covariance", "state") == "accumulate"
    estimate = predictor.estimate(state)
    p_prev = np.asarray(estimate.mean, dtype=np.float64)[:, :2]
    P_prev = np.asarray(estimate.cov, dtype=np.float64)[:, :2, :2]
    rows = np.arange(k)  # the tracks still rolled, as rows of the original batch
    for j in range(1, max_steps + 1):
        state, prediction = predictor.predict(state)
        state = predictor.update(
            state, np.zeros((len(rows), prediction.mean.shape[1])), np.zeros(len(rows), bool)
        )
        if accumulate:
            p = np.asarray(prediction.mean, dtype=np.float64)[:, :2]
            P = P_prev + np.asarray(prediction.cov, dtype=np.float64)[:, :2, :2]
        else:
            now = predictor.estimate(state)
            p = np.asarray(now.mean, dtype=np.float64)[:, :2]
            P = np.asarray(now.cov, dtype=np.float64)[:, :2, :2]
        step = p - p_prev
        # at j = 1 a track already at or past the line is extrapolated back (φ <= 0)
        crossed = (p[:, 0] >= line) & (step[:, 0] > 0)
        stalled = step[:, 0] <= 0
        if crossed.any():
            c = np.flatnonzero(crossed)
            phi = (line - p_prev[c, 0]) / step[c, 0]
            weight = np.clip(phi, 0.0, 1.0)[:, None, None]
            P_c = P_prev[c] + weight * (P[c] - P_prev[c])
            v = step[c] / dt
            J = np.zeros((len(c), 2, 2))
            J[:, 0, 0] = -1.0 / v[:, 0]
            J[:, 1, 0] = -v[:, 1] / v[:, 0]
            J[:, 1, 1] = 1.0
            out = rows[c]
            ok[out] = True
            mean[out, 0] = (frame + j - 1 + phi) * dt
            mean[out, 1] = p_prev[c, 1] + phi * step[c, 1]
            sigma = J @ P_c @ np.swapaxes(J, 1, 2)
            cov[out] = 0.5 * (sigma + np.swapaxes(sigma, 1, 2))
        done = crossed | stalled
        if done.all():
            break
        if done.any():
            going = ~done
            state = state.take(going)
            rows, p, P = rows[going], p[going], P[going]
        p_prev, P_prev = p, P
    return ok, mean, cov
