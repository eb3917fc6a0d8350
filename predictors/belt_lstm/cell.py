"""The belt LSTMs' float32 step: [`FusedLSTMCell`][predictors.lstm_cell.FusedLSTMCell]'s, with compiled gates.

One step of ``n`` rows (tracks, or Monte Carlo sample rows) computes, as
[`FusedLSTMCell.step`][predictors.lstm_cell.FusedLSTMCell.step] does,

    t = tanh([x, h, 1] W)                       (n, 4H), columns i, f, o, g (sigmoid gates × ½)
    σ_q = ½ t_q + ½  (q = i, f, o),   c' = σ_f ⊙ c + σ_i ⊙ t_g,   h' = σ_o ⊙ tanh(c')

with the same product (numpy's ``matmul`` of the same (n, In + H + 1) by (In + H + 1, 4H)
arrays) and the same ``np.tanh`` calls, so the results are the same bits (tested). Only the
glue around them is compiled: packing ``[x, h, 1]`` and the gate arithmetic (each operation in
the dtype numpy uses, no fused multiply-add), one pass each instead of about ten numpy calls on
column blocks. For 150 tracks that is about a third of the step.

[`RowsLSTMCell`][predictors.belt_lstm.cell.RowsLSTMCell] is the cell of
[`FastLSTMWeights`][predictors.belt_lstm.inference.FastLSTMWeights]; its products run on whatever BLAS threads
the caller allows (the predictor limits them to one,
[`track_envs.infra.blas_threads.frame_blas`][track_envs.infra.blas_threads.frame_blas]).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from predictors.lstm_cell import FusedLSTMCell
from track_envs.infra.compiled import njit


@njit(cache=True)
def pack_inputs(x: np.ndarray, h: np.ndarray, xh: np.ndarray) -> None:
    """``xh = [x, h, 1]`` (n, In + H + 1), converted to ``xh``'s dtype (float32)."""
    n, k = x.shape
    H = h.shape[1]
    for r in range(n):
        for j in range(k):
            xh[r, j] = x[r, j]
        for j in range(H):
            xh[r, k + j] = h[r, j]
        xh[r, k + H] = 1.0


@njit(cache=True)
def cell_state(t: np.ndarray, c: np.ndarray, c_out: np.ndarray) -> None:
    """The sigmoid gates in place (``t[:, :3H] = ½ t + ½``, float32) and
    ``c_out = σ_f ⊙ c + σ_i ⊙ t_g`` (in ``c_out``'s dtype; ``σ_i t_g`` rounded to float32 first,
    as numpy's float32 loop does)."""
    n, H = c.shape
    half = np.float32(0.5)
    for r in range(n):
        for j in range(3 * H):
            t[r, j] = t[r, j] * half + half
        for j in range(H):
            ig = t[r, j] * t[r, 3 * H + j]
            c_out[r, j] = t[r, H + j] * c[r, j] + ig


@njit(cache=True)
def cell_output(t: np.ndarray, tanh_c: np.ndarray, h_out: np.ndarray) -> None:
    """``h_out = σ_o ⊙ tanh(c')`` from ``t``'s σ_o block and ``tanh(c')``."""
    n, H = h_out.shape
    for r in range(n):
        for j in range(H):
            h_out[r, j] = t[r, 2 * H + j] * tanh_c[r, j]


@dataclass(frozen=True)
class RowsLSTMCell(FusedLSTMCell):
    """[`FusedLSTMCell`][predictors.lstm_cell.FusedLSTMCell] whose
    [`step`][predictors.belt_lstm.cell.RowsLSTMCell.step] compiles the gates (module docstring); ``matmul`` is
    numpy's."""

    @classmethod
    def of(cls, cell: FusedLSTMCell) -> RowsLSTMCell:
        """The same weights (numpy products).

        Raises:
            ValueError: ``cell`` runs its products on another
                [`matmul`][predictors.belt_lstm.cell.RowsLSTMCell.matmul].
        """
        if cell.matmul != "numpy":
            raise ValueError(f"RowsLSTMCell runs numpy's products; the cell's matmul is {cell.matmul!r}")
        return cls(cell.w, cell.n_in)

    def step(
        self, x: NDArray[np.floating], h: NDArray[np.floating], c: NDArray[np.floating]
    ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """New ``(h, c)`` of rows ``x`` (n, In) with state ``h, c`` (n, H): the bits of
        [`FusedLSTMCell.step`][predictors.lstm_cell.FusedLSTMCell.step] (float32, or the
        state's dtype where it is wider)."""
        H, k = self.hidden, self.n_in
        n = len(x)
        xh = np.empty((n, k + H + 1), dtype=np.float32)
        pack_inputs(x, h, xh)
        t = np.matmul(xh, self.w)
        np.tanh(t, out=t)
        c = np.asarray(c)
        dtype = np.result_type(np.float32, c.dtype)
        c_new = np.empty((n, H), dtype)
        cell_state(t, c, c_new)
        tanh_c = np.tanh(c_new)
        h_new = np.empty((n, H), dtype)
        cell_output(t, tanh_c, h_new)
        return h_new, c_new


__all__ = ["RowsLSTMCell", "cell_output", "cell_state", "pack_inputs"]
