"""Compiled roll-out of the belt LSTMs (``lstm``, ``nll-lstm``) to a line ``x = L``, row by row.

The generic roll-out ([`agents.sorting.rollout.predict_crossings`][agents.sorting.predict_crossings]) calls
the predictor once per roll-out frame on the few tracks deleted in a frame, so numpy's per-call cost
dominates. This kernel runs the same recursion for one track at a time in compiled scalar loops: from the
standardised head output ``o`` and the last input ``z_prev`` the prediction is

    p = z_prev + size ⊙ (μ_out + σ_out ⊙ o[:D]),
    S = r · diag(exp(o[D:]) ⊙ (size ⊙ σ_out)²)   (nll-lstm)   or   r · s · I   (lstm),

the position covariance accumulates ``P ← P + S``, and the prediction is fed back as the next
input ``((u, u − u_prev) − μ_in) / σ_in`` with ``u = (p − low) / size`` through both LSTM layers
([`predictors.lstm_cell.cell_step`][predictors.lstm_cell.cell_step]) and the head. The crossing between the
frames around the line is interpolated exactly as
[`agents.sorting.rollout._crossing`][agents.sorting.rollout._crossing] does. Float64 throughout; it equals the
generic float64 roll-out to rounding (tested).
"""

from __future__ import annotations

import math

import numpy as np

from predictors.base import Crossings
from predictors.lstm_cell import cell_step
from track_envs.infra.compiled import njit


@njit(cache=True)
def _write_crossing(
    r: int,
    line: float,
    frame: float,
    dt: float,
    step: int,
    pp0: float,
    pp1: float,
    s0: float,
    s1: float,
    Q00: float,
    Q01: float,
    Q10: float,
    Q11: float,
    N00: float,
    N01: float,
    N10: float,
    N11: float,
    mean: np.ndarray,
    cov: np.ndarray,
) -> None:
    """Row ``r``'s crossing of ``x = line`` between the roll-out's frames ``step − 1`` (position
    ``pp``, covariance ``Q``) and ``step`` (``pp + s``, ``N``), interpolated as
    [`agents.sorting.rollout._crossing`][agents.sorting.rollout._crossing] does: at ``φ = (L − pp_x) / s_x``
    the time ``(frame + step − 1 + φ) dt`` and ``y = pp_y + φ s_y``; the covariance ``C = Q + w (N − Q)``
    (``w = φ`` clipped to [0, 1]) mapped to ``(t, y)`` by ``J = [[−1/v_x, 0], [−v_y/v_x, 1]]``
    (``v = s / dt``) and symmetrised."""
    phi = (line - pp0) / s0
    wgt = min(max(phi, 0.0), 1.0)
    C00 = Q00 + wgt * (N00 - Q00)
    C01 = Q01 + wgt * (N01 - Q01)
    C10 = Q10 + wgt * (N10 - Q10)
    C11 = Q11 + wgt * (N11 - Q11)
    vx, vy = s0 / dt, s1 / dt
    j00, j10 = -1.0 / vx, -vy / vx  # J = [[j00, 0], [j10, 1]]
    S00 = j00 * C00 * j00
    S01 = j00 * (C00 * j10 + C01)
    S10 = (j10 * C00 + C10) * j00
    S11 = (j10 * C00 + C10) * j10 + (j10 * C01 + C11)
    mean[r, 0] = (frame + step - 1 + phi) * dt
    mean[r, 1] = pp1 + phi * s1
    cov[r, 0, 0] = S00
    cov[r, 0, 1] = 0.5 * (S01 + S10)
    cov[r, 1, 0] = 0.5 * (S01 + S10)
    cov[r, 1, 1] = S11


@njit(cache=True)
def _feed_back(
    p0: float,
    p1: float,
    zp0: float,
    zp1: float,
    low: np.ndarray,
    size: np.ndarray,
    in_mean: np.ndarray,
    in_std: np.ndarray,
    h1: np.ndarray,
    c1: np.ndarray,
    h2: np.ndarray,
    c2: np.ndarray,
    w1: np.ndarray,
    b1: np.ndarray,
    w2: np.ndarray,
    b2: np.ndarray,
    head_w: np.ndarray,
    head_b: np.ndarray,
    xh1: np.ndarray,
    xh2: np.ndarray,
    a1: np.ndarray,
    a2: np.ndarray,
    out: np.ndarray,
) -> None:
    """One roll-out step of the network fed its own prediction ``p`` (previous input ``zp``):
    the standardised input ``((u, u − u_prev) − μ_in) / σ_in`` with ``u = (p − low) / size``
    through both LSTM layers (``h1, c1, h2, c2`` in place) and the head into ``out``
    (``xh1, xh2, a1, a2`` scratch)."""
    H1, H2 = h1.shape[0], h2.shape[0]
    u0, u1 = (p0 - low[0]) / size[0], (p1 - low[1]) / size[1]
    xh1[0] = (u0 - in_mean[0]) / in_std[0]
    xh1[1] = (u1 - in_mean[1]) / in_std[1]
    xh1[2] = (u0 - (zp0 - low[0]) / size[0] - in_mean[2]) / in_std[2]
    xh1[3] = (u1 - (zp1 - low[1]) / size[1] - in_mean[3]) / in_std[3]
    xh1[4:] = h1
    cell_step(xh1, w1, b1, h1, c1, a1)
    xh2[:H1] = h1
    xh2[H1:] = h2
    cell_step(xh2, w2, b2, h2, c2, a2)
    out[:] = head_b
    for q in range(H2):
        v = h2[q]
        for m in range(out.shape[0]):
            out[m] += v * head_w[q, m]


@njit(cache=True)
def lstm_crossings_kernel(
    out0: np.ndarray,
    h1_0: np.ndarray,
    c1_0: np.ndarray,
    h2_0: np.ndarray,
    c2_0: np.ndarray,
    z0: np.ndarray,
    z_prev0: np.ndarray,
    P0: np.ndarray,
    w1: np.ndarray,
    b1: np.ndarray,
    w2: np.ndarray,
    b2: np.ndarray,
    head_w: np.ndarray,
    head_b: np.ndarray,
    low: np.ndarray,
    size: np.ndarray,
    in_mean: np.ndarray,
    in_std: np.ndarray,
    out_mean: np.ndarray,
    out_std: np.ndarray,
    nll: bool,
    cov_scale: float,
    calibration: float,
    line: float,
    frame: float,
    dt: float,
    max_steps: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Crossings ``(ok, mean (k, 2) = (t̂, ŷ), cov (k, 2, 2))`` of ``k`` 2-D tracks (module docstring)."""
    k = out0.shape[0]
    H1, H2 = h1_0.shape[1], h2_0.shape[1]
    ok = np.zeros(k, dtype=np.bool_)
    mean = np.full((k, 2), np.nan)
    cov = np.full((k, 2, 2), np.nan)
    xh1 = np.empty(4 + H1)
    xh2 = np.empty(H1 + H2)
    a1 = np.empty(4 * H1)
    a2 = np.empty(4 * H2)
    out = np.empty(head_b.shape[0])
    var = np.empty(2)
    for r in range(k):
        h1, c1 = h1_0[r].copy(), c1_0[r].copy()
        h2, c2 = h2_0[r].copy(), c2_0[r].copy()
        out[:] = out0[r]
        zp0, zp1 = z_prev0[r, 0], z_prev0[r, 1]
        pp0, pp1 = z0[r, 0], z0[r, 1]
        Q00, Q01, Q10, Q11 = P0[r, 0, 0], P0[r, 0, 1], P0[r, 1, 0], P0[r, 1, 1]
        for j in range(1, max_steps + 1):
            p0 = zp0 + size[0] * (out_mean[0] + out_std[0] * out[0])
            p1 = zp1 + size[1] * (out_mean[1] + out_std[1] * out[1])
            for d in range(2):
                if nll:
                    var[d] = calibration * math.exp(out[2 + d]) * (size[d] * out_std[d]) ** 2
                else:
                    var[d] = calibration * cov_scale
            N00, N01, N10, N11 = Q00 + var[0], Q01, Q10, Q11 + var[1]
            s0, s1 = p0 - pp0, p1 - pp1
            if p0 >= line and s0 > 0:
                ok[r] = True
                _write_crossing(
                    r, line, frame, dt, j, pp0, pp1, s0, s1, Q00, Q01, Q10, Q11, N00, N01, N10, N11, mean, cov
                )
                break
            if s0 <= 0:
                break
            _feed_back(
                p0, p1, zp0, zp1, low, size, in_mean, in_std, h1, c1, h2, c2,
                w1, b1, w2, b2, head_w, head_b, xh1, xh2, a1, a2, out,
            )  # fmt: skip
            zp0, zp1 = p0, p1
            pp0, pp1 = p0, p1
            Q00, Q01, Q10, Q11 = N00, N01, N10, N11
    return Crossings(ok, mean, cov)
