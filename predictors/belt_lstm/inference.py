"""Inference of the belt LSTM network in numpy, from the weights of a model file (no torch).

One step of an LSTM layer with input ``x``, state ``(h, c)`` and torch's gate order ``i, f, g, o``:

    a = x W_ihᵀ + b_ih + h W_hhᵀ + b_hh          (4H,)
    c' = σ(a_f) ⊙ c + σ(a_i) ⊙ tanh(a_g)
    h' = σ(a_o) ⊙ tanh(c')

Two such layers and the linear head ``y = h₂ Wᵀ + b`` make one step of
:class:`~predictors.belt_lstm.network.BeltLSTMNet`; :class:`LSTMWeights` runs it for a batch of rows
(tracks, or tracks × Monte Carlo samples) in float64, with optional variational dropout masks on
the same five places as the torch network. It equals the torch network to ~1e-6 (tested).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
#: The per-row recurrent state ``(h1, c1, h2, c2)``.
LSTMState = tuple[FloatArray, FloatArray, FloatArray, FloatArray]


def _sigmoid(a: FloatArray) -> FloatArray:
    return 0.5 * (np.tanh(0.5 * a) + 1.0)  # = 1 / (1 + exp(-a)), without overflow warnings


@dataclass(frozen=True)
class LSTMLayer:
    """One LSTM layer's weights: ``w_ih`` (In, 4H), ``w_hh`` (H, 4H) (transposed), ``b`` (4H,)."""

    w_ih: FloatArray
    w_hh: FloatArray
    b: FloatArray

    @property
    def hidden(self) -> int:
        """Hidden units ``H``."""
        return self.w_hh.shape[0]

    def step(self, x: FloatArray, h: FloatArray, c: FloatArray) -> tuple[FloatArray, FloatArray]:
        """New ``(h, c)`` of rows ``x`` (n, In) with state ``h, c`` (n, H)."""
        a = x @ self.w_ih + h @ self.w_hh + self.b
        H = self.hidden
        i, f, g, o = (
            _sigmoid(a[:, :H]),
            _sigmoid(a[:, H : 2 * H]),
            np.tanh(a[:, 2 * H : 3 * H]),
            _sigmoid(a[:, 3 * H :]),
        )
        c_new = f * c + i * g
        return o * np.tanh(c_new), c_new


def two_layer_step(net: Any, x: Any, state: Any, masks: Any = None) -> tuple[Any, Any]:
    """Both layers and the head of ``net`` (:class:`LSTMWeights` or :class:`FastLSTMWeights`).

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

    layer1: LSTMLayer
    layer2: LSTMLayer
    head_w: FloatArray  # (H2, outputs)
    head_b: FloatArray  # (outputs,)

    @classmethod
    def from_tensors(cls, t: Mapping[str, NDArray[np.floating]]) -> LSTMWeights:
        """From the state-dict arrays of :class:`~predictors.belt_lstm.network.BeltLSTMNet`."""

        def layer(name: str) -> LSTMLayer:
            return LSTMLayer(
                np.asarray(t[f"{name}.weight_ih"], dtype=np.float64).T.copy(),
                np.asarray(t[f"{name}.weight_hh"], dtype=np.float64).T.copy(),
                np.asarray(t[f"{name}.bias_ih"], dtype=np.float64)
                + np.asarray(t[f"{name}.bias_hh"], dtype=np.float64),
            )

        return cls(
            layer("cell1"),
            layer("cell2"),
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
        layer-2 input and state and the head input, as :meth:`BeltLSTMNet.step` applies them.
        """
        return two_layer_step(self, x, state, masks)


@dataclass(frozen=True)
class FastLSTMLayer:
    """An LSTM layer prepared for few numpy calls per step (float32).

    The fused weight ``W = [W_ih; W_hh; b]`` (In + H + 1, 4H) multiplies ``[x, h, 1]``, so the
    bias comes with the product. Its gate columns are reordered to ``i, f, o, g`` and the sigmoid
    gates' columns pre-multiplied by ½, so one ``tanh`` over the whole pre-activation gives
    ``tanh(a/2)`` for the three sigmoid gates (``σ(a) = ½ tanh(a/2) + ½``) and ``tanh(a_g)`` for the
    cell input.
    """

    w: NDArray[np.float32]
    n_in: int

    @classmethod
    def from_layer(cls, layer: LSTMLayer) -> FastLSTMLayer:
        """From a float64 :class:`LSTMLayer`."""
        H = layer.hidden
        order = np.concatenate(
            [np.arange(0, H), np.arange(H, 2 * H), np.arange(3 * H, 4 * H), np.arange(2 * H, 3 * H)]
        )
        scale = np.concatenate([np.full(3 * H, 0.5), np.ones(H)])
        w = np.vstack([layer.w_ih, layer.w_hh, layer.b[None, :]])[:, order] * scale
        return cls(w.astype(np.float32), layer.w_ih.shape[0])

    @property
    def hidden(self) -> int:
        """Hidden units ``H``."""
        return self.w.shape[1] // 4

    def step(
        self, x: NDArray[np.floating], h: NDArray[np.floating], c: NDArray[np.floating]
    ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """New ``(h, c)`` (float32) of rows ``x`` (n, In) with state ``h, c`` (n, H)."""
        H, k = self.hidden, self.n_in
        xh = np.empty((len(x), k + H + 1), dtype=np.float32)
        xh[:, :k] = x
        xh[:, k : k + H] = h
        xh[:, k + H] = 1.0
        t = np.tanh(xh @ self.w)
        gates = t[:, : 3 * H]
        gates *= 0.5
        gates += 0.5
        c_new = gates[:, H : 2 * H] * c
        c_new += gates[:, :H] * t[:, 3 * H :]
        return gates[:, 2 * H :] * np.tanh(c_new), c_new


@dataclass(frozen=True)
class FastLSTMWeights:
    """:class:`LSTMWeights` in float32 with :class:`FastLSTMLayer` layers (the tracking path).

    Equals the float64 reference to float32 rounding (≈1e-7 on standardised outputs, tested) and
    torch's float32 network to 1e-6.
    """

    layer1: FastLSTMLayer
    layer2: FastLSTMLayer
    head_w: NDArray[np.float32]
    head_b: NDArray[np.float32]

    @classmethod
    def from_weights(cls, w: LSTMWeights) -> FastLSTMWeights:
        """From the float64 reference weights."""
        return cls(
            FastLSTMLayer.from_layer(w.layer1),
            FastLSTMLayer.from_layer(w.layer2),
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
        """One step, as :meth:`LSTMWeights.step`, in float32."""
        return two_layer_step(self, x, state, masks)
