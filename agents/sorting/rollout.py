"""Predicted nozzle-bar crossings: roll a predictor forward without measurements until the line.

When a belt tracker sees a track for the last time it must tell the sorter when and where across
the belt the particle will pass the nozzle bar ``x = L`` downstream of the camera (Pfaff et al.,
"TrackSort: Predictive Tracking for Sorting Uncooperative Bulk Materials", 2015). With any
predictor of the [`Predictor`][predictors.Predictor] protocol this is a roll-out: frame after
frame ``predict`` then ``update`` with ``seen=False`` (which, for a Kalman filter, is the
filter's own time update, and for the learned predictors feeds their prediction back as the next
input; a predictor that declares the ``COAST`` capability, ``coast(state) -> (state,
prediction)``, does both in one call), until the predicted position ``p_j = (x_j, y_j)`` passes
the line. Between the two frames around the line, at ``x_{j−1} < L <= x_j``, the crossing is interpolated:

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
  the network takes its fed-back prediction for a measurement; they declare the ``LINE_ROLLOUT``
  capability with ``rollout_covariance = "accumulate"``): ``P_j = P_{j−1} + S_j``, the one-step
  predicted covariances ``S_j`` of the roll-out summed, as for independent errors per step.

A track whose predicted ``x`` stops advancing, or that has not reached the line after
``max_steps`` frames, gets no prediction.

A predictor that declares ``LINE_ROLLOUT`` ([`LineRollout`][predictors.base.LineRollout]) is first asked
for the same crossings in one compiled pass (``rollout_crossings``): the Kalman filters in closed
form ([`predictors.kalman.rollout`][predictors.kalman.rollout]), the belt LSTMs in one compiled loop over the
tracks; where it answers ``None`` the roll-out runs frame by frame as above. A predictor with only the core
methods is rolled frame by frame.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from predictors.base import Capability, Crossings, Predictor, capability

#: Most frames a track is rolled forward (2 s at 100 Hz).
MAX_STEPS = 200


def predict_crossings(
    predictor: Predictor,
    state: Any,
    line: float,
    frame: int,
    dt: float,
    max_steps: int = MAX_STEPS,
) -> Crossings:
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
        return Crossings(ok, mean, cov)
    compiled = capability(predictor, Capability.LINE_ROLLOUT)  # the same roll-out, compiled
    if compiled is not None:
        result = compiled.rollout_crossings(state, line, frame, dt, max_steps)
        if result is not None:
            return result
    accumulate = compiled is not None and compiled.rollout_covariance == "accumulate"
    estimate = predictor.estimate(state)
    p_prev = np.asarray(estimate.mean, dtype=np.float64)[:, :2]
    P_prev = np.asarray(estimate.cov, dtype=np.float64)[:, :2, :2]
    rows = np.arange(k)  # the tracks still rolled, as rows of the original batch
    coasting = capability(predictor, Capability.COAST)  # predict + update(seen=False) in one call
    for j in range(1, max_steps + 1):
        if coasting is not None:
            state, prediction = coasting.coast(state)
        else:
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
            out = rows[c]
            ok[out] = True
            mean[out], cov[out] = _crossing(p_prev[c], p[c], P_prev[c], P[c], line, frame + j - 1, dt)
        done = crossed | stalled
        if done.all():
            break
        if done.any():
            going = ~done
            state = state.take(going)
            rows, p, P = rows[going], p[going], P[going]
        p_prev, P_prev = p, P
    return Crossings(ok, mean, cov)


def _crossing(
    p_prev: NDArray[np.float64],
    p: NDArray[np.float64],
    P_prev: NDArray[np.float64],
    P: NDArray[np.float64],
    line: float,
    frame: float | NDArray[np.float64],
    dt: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The crossing Gaussian ``(t̂, ŷ)``, ``Σ = J P Jᵀ`` between positions ``p_prev`` at frame
    ``frame`` and ``p`` one frame later (``x_prev < L <= x``; see the module docstring)."""
    step = p - p_prev
    phi = (line - p_prev[:, 0]) / step[:, 0]
    weight = np.clip(phi, 0.0, 1.0)[:, None, None]
    P_c = P_prev + weight * (P - P_prev)
    v = step / dt
    J = np.zeros((len(p), 2, 2))
    J[:, 0, 0] = -1.0 / v[:, 0]
    J[:, 1, 0] = -v[:, 1] / v[:, 0]
    J[:, 1, 1] = 1.0
    mean = np.stack([(frame + phi) * dt, p_prev[:, 1] + phi * step[:, 1]], axis=1)
    sigma = J @ P_c @ np.swapaxes(J, 1, 2)
    return mean, 0.5 * (sigma + np.swapaxes(sigma, 1, 2))
