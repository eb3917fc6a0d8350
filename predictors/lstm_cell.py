"""The inference LSTM cell of every learned family (numpy and compiled; no torch at run time).

One step of an LSTM layer of ``H`` units with input ``x`` (n, In) and state ``h, c`` (n, H), in
torch's gate order ``i, f, g, o`` (the row blocks of ``weight_ih``, ``weight_hh`` and the biases):

    a  = x W_ihᵀ + h W_hhᵀ + b_ih + b_hh                 (n, 4H),  a = [a_i, a_f, a_g, a_o]
    c' = σ(a_f) ⊙ c + σ(a_i) ⊙ tanh(a_g)
    h' = σ(a_o) ⊙ tanh(c')

with the logistic sigmoid ``σ(a) = 1 / (1 + e^{−a})``, evaluated as ``σ(a) = ½ (tanh(a/2) + 1)``
(:func:`sigmoid`, :func:`sigmoid_tanh`): the same value, no overflow for large ``|a|``.

:class:`LSTMCellWeights` holds one layer built from torch-layout tensors (``weight_ih``
(4H, In), ``weight_hh`` (4H, H), ``bias_ih``, ``bias_hh`` (4H,)) in the layout the steps use:
``w_ih = W_ihᵀ`` (In, 4H), ``w_hh = W_hhᵀ`` (H, 4H) and ``b = b_ih + b_hh`` (4H,). Three steps
evaluate the equations above:

* :meth:`LSTMCellWeights.step`: batched numpy in the weights' dtype (the float64 reference of
  the belt and displacement networks), ``a = (x w_ih + h w_hh) + b``;
* :meth:`FusedLSTMCell.step` (:meth:`LSTMCellWeights.fused`): batched numpy in float32 with one
  product and one ``tanh`` per step (the belt predictors' tracking path): the fused weight
  ``W = [w_ih; w_hh; b]`` (In + H + 1, 4H) multiplies ``[x, h, 1]``, its columns reordered to
  ``i, f, o, g`` and the sigmoid gates' columns multiplied by ½, so ``tanh(xh W)`` holds
  ``tanh(a/2)`` for the three sigmoid gates and ``tanh(a_g)`` for the cell input;
* the compiled steps for kernels: :func:`cell_step` (one row, fused ``[w_ih; w_hh]``, scalar loops;
  the belt LSTMs' roll-out to the nozzle bar) and :func:`cell_step_rows` (rows, the products by
  BLAS; the displacement LSTM's particle-filter frame), both through :func:`cell_update`, the
  gates and state update of one row from its pre-activation.

Two sigmoid formulas exist in compiled code, because each compiled caller reproduces the numbers
it has always given bit for bit: :func:`sigmoid_tanh` (``½ (tanh(a/2) + 1)``, the formula of the
numpy steps and of the belt roll-out, which equals the numpy float64 belt network to rounding)
and :func:`sigmoid_exp` (``1 / (1 + e^{−a})`` for ``a ≥ 0``, ``e^{a} / (1 + e^{a})`` otherwise,
with ``tanh(a) = 2 σ(2a) − 1`` (:func:`tanh_exp`); the displacement LSTM's frame, whose results
the particle filter's metrics depend on). They agree to a few ulp.

Every step equals ``torch.nn.LSTM`` to ~1e-7 in float32 and to rounding in float64 (tested);
torch's own CPU kernel (oneDNN) rounds differently, so float32 results are not bit-equal to it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, TypeVar, cast

import numpy as np
from numpy.typing import DTypeLike, NDArray

from track_envs.compiled import njit

FloatArray = NDArray[np.floating]
#: float32 or float64: a step returns arrays of its inputs' dtype.
F = TypeVar("F", np.float32, np.float64)


def sigmoid(a: FloatArray) -> FloatArray:
    """``σ(a) = ½ (tanh(a/2) + 1)`` elementwise (numpy; no overflow warnings), in ``a``'s dtype."""
    return 0.5 * (np.tanh(0.5 * a) + 1.0)


@dataclass(frozen=True)
class LSTMCellWeights:
    """One LSTM layer, transposed for row-batched products (module docstring).

    Attributes:
        w_ih: ``W_ihᵀ`` (In, 4H).
        w_hh: ``W_hhᵀ`` (H, 4H).
        b: ``b_ih + b_hh`` (4H,).
    """

    w_ih: FloatArray
    w_hh: FloatArray
    b: FloatArray

    @classmethod
    def from_torch(
        cls,
        weight_ih: Any,
        weight_hh: Any,
        bias_ih: Any,
        bias_hh: Any,
        dtype: DTypeLike = np.float64,
    ) -> LSTMCellWeights:
        """From torch-layout arrays (``weight_ih`` (4H, In), ``weight_hh`` (4H, H), biases (4H,)),
        converted to ``dtype`` before the biases are summed.

        Raises:
            ValueError: shapes that do not form one layer (naming them).
        """
        w_ih, w_hh = (np.asarray(w, dtype=dtype) for w in (weight_ih, weight_hh))
        b_ih, b_hh = (np.asarray(b, dtype=dtype) for b in (bias_ih, bias_hh))
        four_h = w_hh.shape[0] if w_hh.ndim == 2 else -1
        if not (
            w_ih.ndim == 2
            and four_h % 4 == 0
            and four_h > 0
            and w_hh.shape == (four_h, four_h // 4)
            and w_ih.shape[0] == four_h
            and b_ih.shape == b_hh.shape == (four_h,)
        ):
            raise ValueError(
                "LSTM weights must be weight_ih (4H, In), weight_hh (4H, H), bias_ih and bias_hh (4H,); "
                f"got {w_ih.shape}, {w_hh.shape}, {b_ih.shape}, {b_hh.shape}"
            )
        return cls(w_ih.T.copy(), w_hh.T.copy(), b_ih + b_hh)

    @classmethod
    def from_tensors(
        cls, tensors: Mapping[str, Any], prefix: str, suffix: str = "", dtype: DTypeLike = np.float64
    ) -> LSTMCellWeights:
        """From a state dict's arrays ``{prefix}weight_ih{suffix}`` … ``{prefix}bias_hh{suffix}``:
        ``("cell1.", "")`` for an ``nn.LSTMCell`` named ``cell1``, ``("lstm.", "_l0")`` for layer 0
        of an ``nn.LSTM`` named ``lstm``.

        Raises:
            KeyError: a missing tensor (naming it and the tensors there are).
        """
        names = [f"{prefix}{kind}{suffix}" for kind in ("weight_ih", "weight_hh", "bias_ih", "bias_hh")]
        missing = [n for n in names if n not in tensors]
        if missing:
            raise KeyError(f"LSTM tensors {missing} missing; the tensors are {sorted(tensors)}")
        w_ih, w_hh, b_ih, b_hh = (tensors[n] for n in names)
        return cls.from_torch(w_ih, w_hh, b_ih, b_hh, dtype=dtype)

    @property
    def hidden(self) -> int:
        """Hidden units ``H``."""
        return int(self.w_hh.shape[0])

    @property
    def inputs(self) -> int:
        """Input width ``In``."""
        return int(self.w_ih.shape[0])

    def stacked(self) -> NDArray[np.float64]:
        """``[w_ih; w_hh]`` (In + H, 4H), C-contiguous float64: the weight of :func:`cell_step`."""
        return np.ascontiguousarray(np.vstack([self.w_ih, self.w_hh]), dtype=np.float64)

    def step(self, x: NDArray[F], h: NDArray[F], c: NDArray[F]) -> tuple[NDArray[F], NDArray[F]]:
        """New ``(h, c)`` (n, H) of rows ``x`` (n, In) with state ``h, c`` (n, H), in the dtype of the
        weights and inputs (they are the same where this is bit-reproducible)."""
        a = x @ self.w_ih + h @ self.w_hh + self.b
        H = self.hidden
        i, f, g, o = (
            sigmoid(a[:, :H]),
            sigmoid(a[:, H : 2 * H]),
            np.tanh(a[:, 2 * H : 3 * H]),
            sigmoid(a[:, 3 * H :]),
        )
        c_new = f * c + i * g
        return cast("tuple[NDArray[F], NDArray[F]]", (o * np.tanh(c_new), c_new))

    def fused(self) -> FusedLSTMCell:
        """This layer as a float32 :class:`FusedLSTMCell` (fused and reordered in this dtype, then cast)."""
        H = self.hidden
        order = np.concatenate(
            [np.arange(0, H), np.arange(H, 2 * H), np.arange(3 * H, 4 * H), np.arange(2 * H, 3 * H)]
        )
        scale = np.concatenate([np.full(3 * H, 0.5), np.ones(H)])
        w = np.vstack([self.w_ih, self.w_hh, self.b[None, :]])[:, order] * scale
        return FusedLSTMCell(w.astype(np.float32), self.inputs)


@dataclass(frozen=True)
class FusedLSTMCell:
    """An LSTM layer in float32 for few numpy calls per step (module docstring).

    Attributes:
        w: The fused weight (In + H + 1, 4H): ``[w_ih; w_hh; b]``, columns ``i, f, o, g``, the
            sigmoid gates' columns × ½.
        n_in: Input width ``In``.
    """

    w: NDArray[np.float32]
    n_in: int

    @property
    def hidden(self) -> int:
        """Hidden units ``H``."""
        return int(self.w.shape[1] // 4)

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
        gates = t[:, : 3 * H]  # ½ tanh(a/2) + ½ = σ(a), in place
        gates *= 0.5
        gates += 0.5
        c_new = gates[:, H : 2 * H] * c
        c_new += gates[:, :H] * t[:, 3 * H :]
        return gates[:, 2 * H :] * np.tanh(c_new), c_new


# -- compiled (numba) ---------------------------------------------------------------------------


@njit(cache=True, inline="always")
def sigmoid_tanh(a: float) -> float:
    """``σ(a) = ½ (tanh(a/2) + 1)`` (compiled; the numpy steps' formula)."""
    return 0.5 * (math.tanh(0.5 * a) + 1.0)


@njit(cache=True, inline="always")
def sigmoid_exp(a: float) -> float:
    """``σ(a)`` as ``1 / (1 + e^{−a})`` (``a ≥ 0``) or ``e^{a} / (1 + e^{a})`` (compiled; see the module
    docstring for why a second formula exists)."""
    if a >= 0:
        return 1.0 / (1.0 + math.exp(-a))
    e = math.exp(a)
    return e / (1.0 + e)


@njit(cache=True, inline="always")
def tanh_exp(a: float) -> float:
    """``tanh(a) = 2 σ(2a) − 1`` with :func:`sigmoid_exp` (compiled)."""
    return 2.0 * sigmoid_exp(2.0 * a) - 1.0


@njit(cache=True, inline="always")
def cell_update(a: np.ndarray, h: np.ndarray, c: np.ndarray, exp_form: bool) -> None:
    """Gates and state of one row from its pre-activation ``a`` (4H,) (bias included): updates ``h, c``
    (H,) in place. ``exp_form``: :func:`sigmoid_exp` / :func:`tanh_exp` instead of
    :func:`sigmoid_tanh` / ``tanh``."""
    H = h.shape[0]
    for j in range(H):
        if exp_form:
            i = sigmoid_exp(a[j])
            f = sigmoid_exp(a[H + j])
            g = tanh_exp(a[2 * H + j])
            o = sigmoid_exp(a[3 * H + j])
            cj = f * c[j] + i * g
            c[j] = cj
            h[j] = o * tanh_exp(cj)
        else:
            i = sigmoid_tanh(a[j])
            f = sigmoid_tanh(a[H + j])
            g = math.tanh(a[2 * H + j])
            o = sigmoid_tanh(a[3 * H + j])
            c[j] = f * c[j] + i * g
            h[j] = o * math.tanh(c[j])


@njit(cache=True, inline="always")
def cell_step(
    xh: np.ndarray, w: np.ndarray, b: np.ndarray, h: np.ndarray, c: np.ndarray, a: np.ndarray
) -> None:
    """One row: ``xh = [x, h]`` (In + H,), ``w = [w_ih; w_hh]`` (In + H, 4H)
    (:meth:`LSTMCellWeights.stacked`), ``b`` (4H,); updates ``h, c`` (H,) in place, ``a`` (4H,) is
    scratch. ``a = b + Σ_k xh_k w_k`` in order of ``k``, then :func:`cell_update` with
    :func:`sigmoid_tanh`."""
    a[:] = b
    for k in range(xh.shape[0]):
        v = xh[k]
        for g in range(a.shape[0]):
            a[g] += v * w[k, g]
    cell_update(a, h, c, False)


@njit(cache=True, inline="always")
def cell_step_rows(
    x: np.ndarray, h: np.ndarray, c: np.ndarray, w_ih: np.ndarray, w_hh: np.ndarray, b: np.ndarray
) -> None:
    """Rows ``x`` (n, In) with state ``h, c`` (n, H), updated in place: ``a = (h w_hh + x w_ih) + b``
    (the products by BLAS), then :func:`cell_update` with :func:`sigmoid_exp`."""
    a = np.dot(h, w_hh) + np.dot(x, w_ih)  # (n, 4H)
    for k in range(x.shape[0]):
        for g in range(a.shape[1]):
            a[k, g] += b[g]
        cell_update(a[k], h[k], c[k], True)


__all__ = [
    "FusedLSTMCell",
    "LSTMCellWeights",
    "cell_step",
    "cell_step_rows",
    "cell_update",
    "sigmoid",
    "sigmoid_exp",
    "sigmoid_tanh",
    "tanh_exp",
]
