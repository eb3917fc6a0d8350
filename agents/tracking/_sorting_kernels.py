"""Compiled (numba) closed-form nozzle-bar crossings of Kalman tracks (see :mod:`agents.tracking.sorting`).

For track ``i`` with state mean ``x`` and covariance ``C`` the predicted position after ``j``
frames is ``p_j = H₂ F^j x`` and its covariance ``P_j = (H₂ F^j) C (H₂ F^j)ᵀ + H₂ B_j H₂ᵀ``
(``B_j = Σ_{l<j} F^l Q F^{l⊤}``); both factors are precomputed per model. The kernel walks
``j = 1, 2, …`` until ``p_j`` is at or past the line (a crossing between ``j − 1`` and ``j``) or
stops advancing (no crossing), and maps the interpolated position Gaussian to ``(t_c, y_c)``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.compiled import njit


@njit(cache=True)
def _position_cov(HA: NDArray, HBH: NDArray, cov: NDArray, i: int, j: int, out: NDArray) -> None:
    """``out`` (2, 2) ``= HA[j] cov[i] HA[j]ᵀ + HBH[j]``."""
    s = cov.shape[1]
    for a in range(2):
        for b in range(2):
            acc = HBH[j, a, b]
            for u in range(s):
                if HA[j, a, u] == 0.0:
                    continue
                row = 0.0
                for w in range(s):
                    row += cov[i, u, w] * HA[j, b, w]
                acc += HA[j, a, u] * row
            out[a, b] = acc


@njit(cache=True)
def kalman_crossings_kernel(
    HA: NDArray[np.float64],
    HBH: NDArray[np.float64],
    mean: NDArray[np.float64],
    cov: NDArray[np.float64],
    line: float,
    frame: float,
    dt: float,
) -> tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.float64]]:
    """``ok`` (k,), ``(t̂, ŷ)`` (k, 2) and ``Σ`` (k, 2, 2) of the crossings of ``x = line``.

    Args:
        HA: (J + 1, 2, S) the position rows of ``H F^j``.
        HBH: (J + 1, 2, 2) ``H₂ B_j H₂ᵀ``.
        mean: (k, S) state means at frame ``frame``.
        cov: (k, S, S) state covariances.
        line: ``L``.
        frame: The frame of the states.
        dt: Frame period.
    """
    k, s = mean.shape
    steps = HA.shape[0] - 1
    ok = np.zeros(k, np.bool_)
    out_mean = np.full((k, 2), np.nan)
    out_cov = np.full((k, 2, 2), np.nan)
    P0 = np.empty((2, 2))
    P1 = np.empty((2, 2))
    for i in range(k):
        x_prev, y_prev = 0.0, 0.0
        for d in range(s):
            x_prev += HA[0, 0, d] * mean[i, d]
            y_prev += HA[0, 1, d] * mean[i, d]
        for j in range(1, steps + 1):
            x, y = 0.0, 0.0
            for d in range(s):
                x += HA[j, 0, d] * mean[i, d]
                y += HA[j, 1, d] * mean[i, d]
            step = x - x_prev
            if step <= 0.0:
                break
            if x >= line:
                phi = (line - x_prev) / step
                weight = min(max(phi, 0.0), 1.0)
                _position_cov(HA, HBH, cov, i, j - 1, P0)
                _position_cov(HA, HBH, cov, i, j, P1)
                pxx = P0[0, 0] + weight * (P1[0, 0] - P0[0, 0])
                pxy = 0.5 * (P0[0, 1] + P0[1, 0] + weight * (P1[0, 1] + P1[1, 0] - P0[0, 1] - P0[1, 0]))
                pyy = P0[1, 1] + weight * (P1[1, 1] - P0[1, 1])
                vx, vy = step / dt, (y - y_prev) / dt
                # Σ = J P Jᵀ with J = [[−1/vx, 0], [−vy/vx, 1]]
                a, b = -1.0 / vx, -vy / vx
                out_cov[i, 0, 0] = a * a * pxx
                out_cov[i, 0, 1] = a * (b * pxx + pxy)
                out_cov[i, 1, 0] = out_cov[i, 0, 1]
                out_cov[i, 1, 1] = b * b * pxx + 2.0 * b * pxy + pyy
                out_mean[i, 0] = (frame + j - 1 + phi) * dt
                out_mean[i, 1] = y_prev + phi * (y - y_prev)
                ok[i] = True
                break
            x_prev, y_prev = x, y
    return ok, out_mean, out_cov
