"""Nozzle-bar crossings of Kalman tracks in closed form: the Kalman filters' ``LINE_ROLLOUT`` capability.

The generic roll-out ([`agents.sorting.rollout.predict_crossings`][agents.sorting.predict_crossings]) steps a
predictor frame by frame without measurements until the predicted position passes the line ``x = L``. For a
linear Kalman filter the ``j``-step roll-out is known in closed form,

.. math::

    x_j = F^j x, \\qquad P_j = F^j P F^{j⊤} + B_j, \\qquad B_j = \\sum_{i<j} F^i Q F^{i⊤},

so the powers ``H₂ F^j`` and ``H₂ B_j H₂ᵀ`` (``H₂`` the first two rows of ``H``) are computed once
per model and roll-out length, and one compiled pass over the tracks
([`predictors.kalman._kernels.kalman_crossings_kernel`][predictors.kalman._kernels.kalman_crossings_kernel])
finds every crossing and maps its interpolated position Gaussian to ``(t̂, ŷ)`` exactly as the generic
roll-out does: the same numbers, without a predictor call per frame.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from predictors.base import Crossings
from predictors.kalman._kernels import kalman_crossings_kernel


class LinearGaussianModel(Protocol):
    """What the closed-form roll-out reads of a Kalman filter
    ([`KalmanPredictor`][predictors.kalman.predictor.KalmanPredictor]): its transition ``F`` (S, S), process
    noise ``Q`` (S, S) and measurement matrix ``H`` (D, S)."""

    F: NDArray[Any]
    Q: NDArray[Any]
    H: NDArray[Any]


class GaussianStates(Protocol):
    """What it reads of a batch of Kalman tracks
    ([`KalmanState`][predictors.kalman.predictor.KalmanState]): means (k, S) and covariances (k, S, S)."""

    @property
    def mean(self) -> ArrayLike: ...

    @property
    def cov(self) -> ArrayLike: ...


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
    predictor: LinearGaussianModel,
    state: GaussianStates,
    line: float,
    frame: int,
    dt: float,
    max_steps: int,
) -> Crossings:
    """The crossings of ``x = line`` of the tracks of ``state`` (at frame ``frame``) within
    ``max_steps`` frames: ``H F^j x`` and ``H (F^j P F^{j⊤} + B_j) Hᵀ`` from factors precomputed
    per model, one compiled pass over the tracks (module docstring).

    Returns:
        ``ok`` (k,), ``(t̂, ŷ)`` (k, 2) and ``Σ`` (k, 2, 2) (NaN where not ``ok``).
    """
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
