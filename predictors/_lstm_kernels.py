"""Compiled (numba) step of the two-layer belt LSTM: one BLAS product per layer, gates in one pass.

For rows ``r`` (tracks, or tracks × Monte Carlo samples), with the layer's fused weight
``W = [W_ih; W_hh]`` of shape (In + H, 4H) (torch's gate order i, f, g, o along the columns):

    a = [x, h] W + b,    c' = σ(a_f) c + σ(a_i) tanh(a_g),    h' = σ(a_o) tanh(c')

:func:`lstm2_step` runs both layers and the linear head in one call, so a frame of 150 tracks is
three matrix products plus one fused loop per layer instead of ~40 numpy operations. It computes
in the dtype of its inputs (float32 for speed, float64 in tests) and equals
:meth:`predictors.lstm_inference.LSTMWeights.step` (tested).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def _sigmoid(a: float) -> float:
    return 0.5 * (math.tanh(0.5 * a) + 1.0)


@njit(cache=True)
def _layer(xh: np.ndarray, c: np.ndarray, w: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One LSTM layer for every row of ``xh = [x, h]`` with cell state ``c``."""
    a = np.dot(xh, w)
    n, hidden = c.shape
    h_new = np.empty_like(c)
    c_new = np.empty_like(c)
    for r in range(n):
        for j in range(hidden):
            i = _sigmoid(a[r, j] + b[j])
            f = _sigmoid(a[r, hidden + j] + b[hidden + j])
            g = math.tanh(a[r, 2 * hidden + j] + b[2 * hidden + j])
            o = _sigmoid(a[r, 3 * hidden + j] + b[3 * hidden + j])
            cell = f * c[r, j] + i * g
            c_new[r, j] = cell
            h_new[r, j] = o * math.tanh(cell)
    return h_new, c_new


@njit(cache=True)
def lstm2_step(
    x: np.ndarray,
    h1: np.ndarray,
    c1: np.ndarray,
    h2: np.ndarray,
    c2: np.ndarray,
    w1: np.ndarray,
    b1: np.ndarray,
    w2: np.ndarray,
    b2: np.ndarray,
    wh: np.ndarray,
    bh: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Both layers and the head for rows ``x`` (n, In); returns ``(out, h1, c1, h2, c2)``."""
    n = x.shape[0]
    xh = np.empty((n, x.shape[1] + h1.shape[1]), dtype=x.dtype)
    xh[:, : x.shape[1]] = x
    xh[:, x.shape[1] :] = h1
    h1n, c1n = _layer(xh, c1, w1, b1)
    hh = np.empty((n, h1n.shape[1] + h2.shape[1]), dtype=x.dtype)
    hh[:, : h1n.shape[1]] = h1n
    hh[:, h1n.shape[1] :] = h2
    h2n, c2n = _layer(hh, c2, w2, b2)
    out = np.dot(h2n, wh)
    for r in range(n):
        for k in range(out.shape[1]):
            out[r, k] += bh[k]
    return out, h1n, c1n, h2n, c2n
