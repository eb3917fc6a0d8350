"""Inference of the belt LSTM network in numpy, from the weights of a model file (no torch).

Two LSTM layers (the one cell of [`predictors.lstm_cell`][predictors.lstm_cell]) and the linear head
``y = h₂ Wᵀ + b`` make one step of [`BeltLSTMNet`][predictors.belt_lstm.network.BeltLSTMNet];
[`LSTMWeights`][predictors.belt_lstm.inference.LSTMWeights] runs it for a batch of rows (tracks, or tracks ×
Monte Carlo samples) in float64 ([`LSTMCellWeights`][predictors.LSTMCellWeights] layers),
[`FastLSTMWeights`][predictors.belt_lstm.inference.FastLSTMWeights] in float32
([`RowsLSTMCell`][predictors.belt_lstm.cell.RowsLSTMCell] layers: the fused cell with compiled gates), with
optional variational dropout masks on the same five places as the torch network. It equals the torch network
to ~1e-6 (tested).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from predictors.belt_lstm.cell import RowsLSTMCell
from predictors.lstm_cell import FusedLSTMCell, LSTMCellWeights

FloatArray = NDArray[np.float64]
#: The per-row recurrent state ``(h1, c1, h2, c2)``.
LSTMState = tuple[FloatArray, FloatArray, FloatArray, FloatArray]


def two_layer_step(net: Any, x: Any, state: Any, masks: Any = None) -> tuple[Any, Any]:
    """Both layers and the head of ``net`` ([`LSTMWeights`][predictors.belt_lstm.inference.LSTMWeights] or
    [`FastLSTMWeights`][predictors.belt_lstm.inference.FastLSTMWeights]).

    ``masks``: ``None``, or five arrays ``(m_x, m_h1, m_x2, m_h2, m_head)`` multiplying the
    layer-1 input and state, the layer-2 input and state and the head input.
    """
    h1, c1, h2, c2 = state
    if masks is None:
        h1, c1 = net.layer1.step(x, h1, c1)
        h2, c2 = net.layer2.step(h1, h2, c2)
        return h2 @ net.head_w + net.head_b, (h1, c1, h2, c2)
    m_x, m_h1, m_x2, m_h2, m_head = masks
    h1, c1 = net.layer1.step(x * m_x, h1 * m_h1, c1)
    h2, c2 = net.layer2.step(h1 * m_x2, h2 * m_h2, c2)
    return (h2 * m_head) @ net.head_w + net.head_b, (h1, c1, h2, c2)


@dataclass(frozen=True)
class LSTMWeights:
    """The two layers and the head of a belt network, ready for numpy inference."""

    layer1: LSTMCellWeights
    layer2: LSTMCellWeights
    head_w: FloatArray  # (H2, outputs)
    head_b: FloatArray  # (outputs,)

    @classmethod
    def from_tensors(cls, t: Mapping[str, NDArray[np.floating]]) -> LSTMWeights:
        """From the state-dict arrays of [`BeltLSTMNet`][predictors.belt_lstm.network.BeltLSTMNet]."""

        return cls(
            LSTMCellWeights.from_tensors(t, "cell1."),
            LSTMCellWeights.from_tensors(t, "cell2."),
            np.asarray(t["head.weight"], dtype=np.float64).T.copy(),
            np.asarray(t["head.bias"], dtype=np.float64),
        )

    def zero_state(self, n: int) -> LSTMState:
        """Zero ``(h1, c1, h2, c2)`` for ``n`` rows."""
        h1, h2 = self.layer1.hidden, self.layer2.hidden
        return (np.zeros((n, h1)), np.zeros((n, h1)), np.zeros((n, h2)), np.zeros((n, h2)))

    def step(
        self, x: FloatArray, state: LSTMState, masks: tuple[FloatArray, ...] | None = None
    ) -> tuple[FloatArray, LSTMState]:
        """One step of ``n`` rows: input ``x`` (n, In) → head output (n, outputs), new state.

        ``masks``: five (n, width) arrays (keep / (1 − p)) for the layer-1 input and state, the
        layer-2 input and state and the head input, as
        [`BeltLSTMNet.step`][predictors.belt_lstm.network.BeltLSTMNet.step] applies them.
        """
        return two_layer_step(self, x, state, masks)


@dataclass(frozen=True)
class FastLSTMWeights:
    """[`LSTMWeights`][predictors.belt_lstm.inference.LSTMWeights] in float32 with
    [`FusedLSTMCell`][predictors.lstm_cell.FusedLSTMCell] layers (tracking).

    Equals the float64 reference to float32 rounding (≈1e-7 on standardised outputs, tested) and
    torch's float32 network to 1e-6.
    """

    layer1: FusedLSTMCell
    layer2: FusedLSTMCell
    head_w: NDArray[np.float32]
    head_b: NDArray[np.float32]

    @classmethod
    def from_weights(cls, w: LSTMWeights) -> FastLSTMWeights:
        """From the float64 reference weights."""
        return cls(
            RowsLSTMCell.of(w.layer1.fused()),
            RowsLSTMCell.of(w.layer2.fused()),
            w.head_w.astype(np.float32),
            w.head_b.astype(np.float32),
        )

    def zero_state(self, n: int) -> tuple[NDArray[np.float32], ...]:
        """Zero ``(h1, c1, h2, c2)`` for ``n`` rows."""
        h1, h2 = self.layer1.hidden, self.layer2.hidden
        z = np.zeros
        return (
            z((n, h1), np.float32),
            z((n, h1), np.float32),
            z((n, h2), np.float32),
            z((n, h2), np.float32),
        )

    def step(
        self,
        x: NDArray[np.floating],
        state: tuple[NDArray[np.floating], ...],
        masks: tuple[NDArray[np.floating], ...] | None = None,
    ) -> tuple[NDArray[np.float32], tuple[NDArray[np.float32], ...]]:
        """One step, as [`LSTMWeights.step`][predictors.belt_lstm.inference.LSTMWeights.step], in float32."""
        return two_layer_step(self, x, state, masks)
