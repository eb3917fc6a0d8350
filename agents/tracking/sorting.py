"""Predicted nozzle-bar crossings: roll a predictor forward without measurements until the line.

When a belt tracker sees a track for the last time it must tell the sorter when and where across
the belt the particle will pass the nozzle bar ``x = L`` downstream of the camera (Pfaff et al.,
"TrackSort: Predictive Tracking for Sorting Uncooperative Bulk Materials", 2015). With any
predictor of the :class:`~predictors.base.Predictor` protocol this is a roll-out: frame after
frame ``predict`` then ``update`` with ``seen=False`` (which, for a Kalman filter, is the
filter's own time update, and for the learned predictors feeds their prediction back as the next
input; a predictor with a ``coast(state) -> (state, prediction)`` method does both in one
call), until the predicted position ``p_j = (x_j, y_j)`` passes the line. Between the two frames
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

For the Kalman predictors (:class:`~predictors.kalman.predictor.KalmanPredictor`) the roll-out is done in
closed form for all tracks at once, ``x_j = F^j x`` and ``P_j = F^j P F^{j⊤} + \\sum_{i<j} F^i Q
F^{i⊤}`` with the powers precomputed per model (:func:`kalman_crossings`): the same numbers as
the frame-by-frame roll-out, without a predictor call per frame.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.tracking._sorting_kernels import kalman_crossings_kernel
from predictors.kalman.predictor import KalmanPredictor, KalmanState

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
    if isinstance(predictor, KalmanPredictor) and isinstance(state, KalmanState):
        return kalman_crossings(predictor, state, line, frame, dt, max_steps)
    compiled = getattr(predictor, "rollout_crossings", None)  # the same roll-out, compiled
    if compiled is not None:
        result = compiled(state, line, frame, dt, max_steps)
        if result is not None:
            return result
    accumulate = getattr(predictor, "rollout_covariance", "state") == "accumulate"
    estimate = predictor.estimate(state)
    p_prev = np.asarray(estimate.mean, dtype=np.float64)[:, :2]
    P_prev = np.asarray(estimate.cov, dtype=np.float64)[:, :2, :2]
    rows = np.arange(k)  # the tracks still rolled, as rows of the original batch
    coast = getattr(predictor, "coast", None)  # predict + update(seen=False) in one call
    for j in range(1, max_steps + 1):
        if coast is not None:
            state, prediction = coast(state)
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
    return ok, mean, cov


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


@lru_cache(maxsize=16)
def _powers(
    F_bytes: bytes, Q_bytes: bytes, H_bytes: bytes, s: int, steps: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The position rows ``H₂ F^j`` (J + 1, 2, S) and ``H₂ B_j H₂ᵀ`` (J + 1, 2, 2), with
    ``B_j = Σ_{i<j} F^i Q F^{i⊤}``, for ``j = 0 … steps`` (``H₂`` the first two rows of ``H``)."""
    F = np.frombuffer(F_bytes).reshape(s, s)
    Q = np.frombuffer(Q_bytes).reshape(s, s)
    H = np.frombuffer(H_bytes).reshape(-1, s)[:2]
    A = np.empty((steps + 1, s, s))
    B = np.empty((steps + 1, s, s))
    A[0], B[0] = np.eye(s), 0.0
    for j in range(1, steps + 1):
        A[j] = F @ A[j - 1]
        B[j] = F @ B[j - 1] @ F.T + Q  # Σ_{i<j} F^i Q F^iᵀ = F (Σ_{i<j-1} …) Fᵀ + Q
    return H @ A, H @ B @ H.T


def kalman_crossings(
    predictor: KalmanPredictor,
    state: KalmanState,
    line: float,
    frame: int,
    dt: float,
    max_steps: int = MAX_STEPS,
) -> tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`predict_crossings` of a Kalman filter in closed form (see the module docstring):
    ``H F^j x`` and ``H (F^j P F^{j⊤} + B_j) Hᵀ`` from factors precomputed per model, one
    compiled pass over the tracks (:func:`agents.tracking._sorting_kernels.kalman_crossings_kernel`)."""
    mean, cov = np.asarray(state.mean, dtype=np.float64), np.asarray(state.cov, dtype=np.float64)
    HA, HBH = _powers(
        *(
            np.ascontiguousarray(m, dtype=np.float64).tobytes()
            for m in (predictor.F, predictor.Q, predictor.H)
        ),
        mean.shape[1],
        max_steps,
    )
    return kalman_crossings_kernel(
        HA, HBH, np.ascontiguousarray(mean), np.ascontiguousarray(cov), float(line), float(frame), float(dt)
    )
