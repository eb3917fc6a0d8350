"""The inference LSTM cell of every learned family (numpy and compiled; torch only if asked for).

One step of an LSTM layer of ``H`` units with input ``x`` (n, In) and state ``h, c`` (n, H), in
torch's gate order ``i, f, g, o`` (the row blocks of ``weight_ih``, ``weight_hh`` and the biases):

    a  = x W_ihᵀ + h W_hhᵀ + b_ih + b_hh                 (n, 4H),  a = [a_i, a_f, a_g, a_o]
    c' = σ(a_f) ⊙ c + σ(a_i) ⊙ tanh(a_g)
    h' = σ(a_o) ⊙ tanh(c')

with the logistic sigmoid ``σ(a) = 1 / (1 + e^{−a})``, evaluated as ``σ(a) = ½ (tanh(a/2) + 1)``
([`sigmoid`][predictors.lstm_cell.sigmoid], [`sigmoid_tanh`][predictors.lstm_cell.sigmoid_tanh]): the same
value, no overflow for large ``|a|``.

[`LSTMCellWeights`][predictors.LSTMCellWeights] holds one layer built from torch-layout tensors (``weight_ih``
(4H, In), ``weight_hh`` (4H, H), ``bias_ih``, ``bias_hh`` (4H,)) in the layout the steps use:
``w_ih = W_ihᵀ`` (In, 4H), ``w_hh = W_hhᵀ`` (H, 4H) and ``b = b_ih + b_hh`` (4H,). Three steps
evaluate the equations above:

* [`LSTMCellWeights.step`][predictors.LSTMCellWeights.step]: batched numpy in the weights' dtype (the float64
reference of
  the belt and displacement networks), ``a = (x w_ih + h w_hh) + b``;
* [`FusedLSTMCell.step`][predictors.lstm_cell.FusedLSTMCell.step]
([`LSTMCellWeights.fused`][predictors.LSTMCellWeights.fused]): batched numpy in float32 with one
  product and one ``tanh`` per step (the belt predictors' tracking path): the fused weight
  ``W = [w_ih; w_hh; b]`` (In + H + 1, 4H) multiplies ``[x, h, 1]``, its columns reordered to
  ``i, f, o, g`` and the sigmoid gates' columns multiplied by ½, so ``tanh(xh W)`` holds
  ``tanh(a/2)`` for the three sigmoid gates and ``tanh(a_g)`` for the cell input;
  [`FusedLSTMCell.sequence`][predictors.lstm_cell.FusedLSTMCell.sequence] runs the same step (the same gates,
  [`_gates`][predictors.lstm_cell._gates]) over whole sequences, a block of rows at a time in the transposed
  layout ``aᵀ = Wᵀ [x, h, 1]ᵀ`` (the pose predictor's windows). Its products are numpy's (the default) or,
  with ``matmul="torch"``, ``torch.matmul`` on views of the same arrays
  ([`MATMULS`][predictors.lstm_cell.MATMULS]; the pose predictor's, since torch's GEMM follows
  ``torch.set_num_threads`` and gives the same bits at any thread count);
* the compiled steps for kernels: [`cell_step`][predictors.lstm_cell.cell_step] (one row, fused
``[w_ih; w_hh]``, scalar loops;
  the belt LSTMs' roll-out to the nozzle bar) and [`cell_step_rows`][predictors.lstm_cell.cell_step_rows]
  (rows, the products by BLAS; the displacement LSTM's particle-filter frame), both through
  [`cell_update`][predictors.lstm_cell.cell_update], the gates and state update of one row from its
  pre-activation.

Two sigmoid formulas exist in compiled code, because each compiled caller reproduces the numbers
it has always given bit for bit: [`sigmoid_tanh`][predictors.lstm_cell.sigmoid_tanh] (``½ (tanh(a/2) + 1)``,
the formula of the numpy steps and of the belt roll-out, which equals the numpy float64 belt network to
rounding) and [`sigmoid_exp`][predictors.lstm_cell.sigmoid_exp] (``1 / (1 + e^{−a})`` for ``a ≥ 0``,
``e^{a} / (1 + e^{a})`` otherwise, with ``tanh(a) = 2 σ(2a) − 1``
([`tanh_exp`][predictors.lstm_cell.tanh_exp]); the displacement LSTM's frame, whose results the particle
filter's metrics depend on). They agree to a few ulp.

Every step equals ``torch.nn.LSTM`` to ~1e-7 in float32 and to rounding in float64 (tested);
torch's own CPU kernel (oneDNN) rounds differently, so float32 results are not bit-equal to it.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import Any, TypeVar, cast

import numpy as np
from numpy.typing import DTypeLike, NDArray

from predictors.ordered_product import MIN_MACS_PER_THREAD, gathered_product, ordered_product, thread_pool
from track_envs.infra.compiled import njit

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
        """``[w_ih; w_hh]`` (In + H, 4H), C-contiguous float64: the weight of
        `cell_step`."""
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

    def fused(self, matmul: str = "numpy") -> FusedLSTMCell:
        """This layer as a float32 `FusedLSTMCell` (fused and reordered
        in this dtype, then cast) whose products run on ``matmul``
        (`MATMULS`)."""
        H = self.hidden
        order = np.concatenate(
            [np.arange(0, H), np.arange(H, 2 * H), np.arange(3 * H, 4 * H), np.arange(2 * H, 3 * H)]
        )
        scale = np.concatenate([np.full(3 * H, 0.5), np.ones(H)])
        w = np.vstack([self.w_ih, self.w_hh, self.b[None, :]])[:, order] * scale
        return FusedLSTMCell(w.astype(np.float32), self.inputs, matmul)


#: The products a [`FusedLSTMCell`][predictors.lstm_cell.FusedLSTMCell] can run on: numpy's ``matmul`` (its
#: BLAS), ``torch.matmul``
#: on zero-copy views of the same arrays (torch's BLAS, which follows ``torch.set_num_threads``), or
#: ``"ordered"``, [`predictors.ordered_product.ordered_product`][predictors.ordered_product.ordered_product]
#: (compiled; every element summed
#: in the order of ``k``, so its bits do not depend on the shapes, the layout or the threads).
MATMULS = ("numpy", "torch", "ordered")


def _torch_matmul(a: NDArray[np.float32], b: NDArray[np.float32], out: NDArray[np.float32]) -> None:
    """``out = a b`` by ``torch.matmul`` on views of the numpy arrays (no copies)."""
    import torch

    torch.matmul(torch.from_numpy(a), torch.from_numpy(b), out=torch.from_numpy(out))


def _gates(
    t: NDArray[np.float32],
    c: NDArray[np.floating],
    c_out: NDArray[np.floating],
    h_out: NDArray[np.floating],
    tmp: NDArray[np.floating],
    axis: int = 1,
) -> None:
    """The gates and state update of [`FusedLSTMCell`][predictors.lstm_cell.FusedLSTMCell], in place.

    ``t = tanh(xh W)`` with the gates ``i, f, o, g`` along ``axis`` (the sigmoid gates' blocks hold
    ``tanh(a/2)``): (n, 4H) rows of the state (``axis=1``) or its transpose (4H, n) (``axis=0``,
    where every block is contiguous). Its first 3H become ``σ = ½ tanh(a/2) + ½``; then
    ``c_out = σ_f ⊙ c + σ_i ⊙ tanh(a_g)`` (``c_out`` may be ``c``) and ``h_out = σ_o ⊙ tanh(c_out)``,
    laid out as ``t``'s blocks; ``tmp`` is scratch of their shape.
    """
    H = c.shape[axis]

    def block(j: int, width: int = 1) -> NDArray[np.float32]:
        return t[:, j * H : (j + width) * H] if axis == 1 else t[j * H : (j + width) * H]

    gates = block(0, 3)  # ½ tanh(a/2) + ½ = σ(a), in place
    gates *= 0.5
    gates += 0.5
    np.multiply(block(1), c, out=c_out)
    np.multiply(block(0), block(3), out=tmp)
    c_out += tmp
    np.tanh(c_out, out=tmp)  # of a contiguous array, as every tanh here
    np.multiply(block(2), tmp, out=h_out)


@njit(cache=True, nogil=True)
def _cell_state_gathered(t: np.ndarray, c_prev: np.ndarray, parents: np.ndarray, c: np.ndarray) -> None:
    """The first part of [`_gates`][predictors.lstm_cell._gates] (``axis=0``) with the previous cell states
    gathered: the sigmoid blocks of ``t`` (4H, n) become ``½ t + ½`` in place and ``c[:, j] = σ_f ⊙ c_prev[:,
    parents_j] + σ_i ⊙ tanh(a_g)`` (``c_prev`` (H, 0): the zero state), each an IEEE float32
    operation in the order [`_gates`][predictors.lstm_cell._gates] does them, so the same bits."""
    H, n = c.shape
    half = np.float32(0.5)
    zero_state = c_prev.shape[1] == 0
    for r in range(3 * H):
        row = t[r]
        for j in range(n):
            row[j] = row[j] * half + half
    for u in range(H):
        i_row, f_row, g_row, out = t[u], t[H + u], t[3 * H + u], c[u]
        if zero_state:
            for j in range(n):
                out[j] = f_row[j] * np.float32(0.0) + i_row[j] * g_row[j]
        else:
            prev = c_prev[u]
            for j in range(n):
                out[j] = f_row[j] * prev[parents[j]] + i_row[j] * g_row[j]


@dataclass(frozen=True)
class FusedLSTMCell:
    """An LSTM layer in float32 for few numpy calls per step (module docstring).

    Attributes:
        w: The fused weight (In + H + 1, 4H): ``[w_ih; w_hh; b]``, columns ``i, f, o, g``, the
            sigmoid gates' columns × ½.
        n_in: Input width ``In``.
        matmul: What computes the products ([`MATMULS`][predictors.lstm_cell.MATMULS]): ``"numpy"``,
            ``"torch"`` (needs torch) or ``"ordered"``. They sum in different orders, so they agree to float32
            rounding, not bit for bit; the gates are numpy either way.
        threads: Threads of the ``"ordered"`` products (the others follow their library's setting).

    Raises:
        ValueError: ``matmul`` not in [`MATMULS`][predictors.lstm_cell.MATMULS].
    """

    w: NDArray[np.float32]
    n_in: int
    matmul: str = "numpy"
    threads: int = 1

    def __post_init__(self) -> None:
        if self.matmul not in MATMULS:
            raise ValueError(f"matmul must be one of {MATMULS}, got {self.matmul!r}")
        if not (isinstance(self.threads, int) and self.threads >= 1):
            raise ValueError(f"threads must be an integer >= 1, got {self.threads!r}")

    @property
    def hidden(self) -> int:
        """Hidden units ``H``."""
        return int(self.w.shape[1] // 4)

    @cached_property
    def w_t(self) -> NDArray[np.float32]:
        """``Wᵀ`` (4H, In + H + 1), C-contiguous: the weight of
        [`sequence`][predictors.lstm_cell.FusedLSTMCell.sequence]'s products."""
        return np.ascontiguousarray(self.w.T)

    def _product(
        self,
        a: NDArray[np.float32],
        b: NDArray[np.float32],
        out: NDArray[np.float32],
        threads: int | None = None,
    ) -> NDArray[np.float32]:
        """``out = a b`` on [`matmul`][predictors.lstm_cell.FusedLSTMCell.matmul] (``"ordered"`` on
        ``threads``, default [`threads`][predictors.lstm_cell.FusedLSTMCell.threads])."""
        if self.matmul == "torch":
            _torch_matmul(a, b, out)
        elif self.matmul == "ordered":
            ordered_product(a, b, out, self.threads if threads is None else threads)
        else:
            np.matmul(a, b, out=out)
        return out

    def step(
        self, x: NDArray[np.floating], h: NDArray[np.floating], c: NDArray[np.floating]
    ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """New ``(h, c)`` (float32) of rows ``x`` (n, In) with state ``h, c`` (n, H)."""
        H, k = self.hidden, self.n_in
        n = len(x)
        xh = np.empty((n, k + H + 1), dtype=np.float32)
        xh[:, :k] = x
        xh[:, k : k + H] = h
        xh[:, k + H] = 1.0
        t = np.tanh(self._product(xh, self.w, np.empty((n, 4 * H), np.float32)))
        c = np.asarray(c)
        dtype = np.result_type(np.float32, c.dtype)  # float32 unless the state is wider
        h_new, c_new, tmp = (np.empty((n, H), dtype) for _ in range(3))
        _gates(t, c, c_new, h_new, tmp)
        return h_new, c_new

    def step_gathered(
        self,
        x: NDArray[np.float32],
        state_t: tuple[NDArray[np.float32], NDArray[np.float32]] | None,
        parents: NDArray[np.intp],
    ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """One step of rows ``x`` (n, In) from the states ``parents`` of ``state_t`` (``(hᵀ, cᵀ)``, (H, U)
        each, a state per column; the zero state if None): the new ``(hᵀ, cᵀ)`` (H, n), bit for bit
        [`sequence`][predictors.lstm_cell.FusedLSTMCell.sequence] of ``x[:, None]`` from
        ``(h[parents], c[parents])``, transposed.

        With ``"ordered"`` products the pre-activation ``aᵀ`` is one compiled pass that reads the
        parents' ``h`` in place ([`gathered_product`][predictors.ordered_product.gathered_product]), then the
        same ``tanh`` and gate arithmetic as [`sequence`][predictors.lstm_cell.FusedLSTMCell.sequence]
        ([`_cell_state_gathered`][predictors.lstm_cell._cell_state_gathered] reads the parents' ``c`` in
        place); on [`threads`][predictors.lstm_cell.FusedLSTMCell.threads] threads, contiguous ranges of the
        columns in parallel. Other products go through
        [`sequence`][predictors.lstm_cell.FusedLSTMCell.sequence].
        """
        H = self.hidden
        x = np.ascontiguousarray(x, dtype=np.float32)
        n = len(x)
        parents = np.asarray(parents, dtype=np.intp)
        if self.matmul != "ordered":
            gathered = None if state_t is None else (state_t[0][:, parents].T, state_t[1][:, parents].T)
            h, c = self.sequence(x[:, None, :], gathered)
            return np.ascontiguousarray(h.T), np.ascontiguousarray(c.T)
        h_t = np.zeros((H, 0), np.float32) if state_t is None else state_t[0]
        c_prev = np.zeros((H, 0), np.float32) if state_t is None else state_t[1]
        h_new, c = np.empty((H, n), np.float32), np.empty((H, n), np.float32)

        def columns(s: int, e: int) -> None:  # the whole step of columns s … e − 1
            t = np.empty((4 * H, e - s), np.float32)
            gathered_product(x[s:e], h_t, parents[s:e], self.w_t, t)
            np.tanh(t, out=t)  # contiguous, as every tanh of the cell
            _cell_state_gathered(t, c_prev, parents[s:e], c[:, s:e])
            tanh_c = np.tanh(np.ascontiguousarray(c[:, s:e]))  # contiguous, as every tanh here
            np.multiply(t[2 * H : 3 * H], tanh_c, out=h_new[:, s:e])

        # on several threads: ranges of columns in parallel (the compiled pass and numpy's tanh
        # release the GIL), the first on the calling thread; the same bits as one range
        parts = max(1, min(self.threads, n * (H + 4) * 4 * H // MIN_MACS_PER_THREAD))
        ranges = list(itertools.pairwise(np.linspace(0, n, parts + 1).astype(int).tolist()))
        futures = [thread_pool(parts).submit(columns, s, e) for s, e in ranges[1:]]
        columns(*ranges[0])
        for future in futures:
            future.result()
        return h_new, c

    def sequence(
        self,
        x: NDArray[np.floating],
        state: tuple[NDArray[np.floating], NDArray[np.floating]] | None = None,
        block: int = 512,
    ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """The state ``(h, c)`` (n, H) (float32) after the ``L`` steps of sequences ``x`` (n, L, In).

        From ``state`` ``(h, c)`` (n, H each; zero if None). The equations of
        [`step`][predictors.lstm_cell.FusedLSTMCell.step] (the same [`_gates`][predictors.lstm_cell._gates]),
        run ``block`` rows at a time through all ``L`` steps in the transposed layout, ``aᵀ = Wᵀ [x, h, 1]ᵀ``
        (4H, block), so that a block stays in the CPU cache and every gate is a contiguous array. From the
        zero state the first product is ``Wᵀ [x, 1]ᵀ`` over the input and bias rows only (``h = 0``). The
        results equal [`step`][predictors.lstm_cell.FusedLSTMCell.step]'s to float32 rounding (the GEMM of
        another layout sums in another order).

        Raises:
            ValueError: ``x`` not (n, L, In), a ``state`` not (n, H), or ``block`` < 1.
        """
        H, k = self.hidden, self.n_in
        x = np.asarray(x)
        if x.ndim != 3 or x.shape[2] != k:
            raise ValueError(f"x must be (n, L, {k}) sequences, got shape {x.shape}")
        n, L = x.shape[:2]
        if state is not None and not all(np.shape(a) == (n, H) for a in state):
            raise ValueError(f"state must be (h, c) of shape {(n, H)}, got {[np.shape(a) for a in state]}")
        if block < 1:
            raise ValueError(f"block must be >= 1, got {block!r}")
        w_t = self.w_t
        w0_t = np.ascontiguousarray(w_t[:, [*range(k), k + H]])  # the input and bias rows
        h_out, c_out = np.empty((n, H), np.float32), np.empty((n, H), np.float32)
        starts = range(0, n, block)
        # "ordered" on several threads: whole blocks in parallel (their numpy gates release the
        # GIL too), each block's products on its own thread; the same bits as one thread
        parallel = self.matmul == "ordered" and self.threads > 1 and len(starts) > 1
        inner = 1 if parallel else self.threads

        def run(s: int) -> None:
            e = min(s + block, n)
            width = e - s  # buffers, transposed: one column per sequence
            xh, a, c, tmp = (np.empty((r, width), np.float32) for r in (k + H + 1, 4 * H, H, H))
            x0 = np.ones((k + 1, width), np.float32)
            xh[k + H] = 1.0
            h = xh[k : k + H]  # written where the next product reads it
            if state is None:
                c[:] = 0.0
                h[:] = 0.0
            else:
                h[:] = state[0][s:e].T
                c[:] = state[1][s:e].T
            for t in range(L):
                if t == 0 and state is None:
                    x0[:k] = x[s:e, 0].T
                    self._product(w0_t, x0, a, inner)
                else:
                    xh[:k] = x[s:e, t].T
                    self._product(w_t, xh, a, inner)
                np.tanh(a, out=a)
                _gates(a, c, c, h, tmp, axis=0)
            h_out[s:e] = h.T
            c_out[s:e] = c.T

        if parallel:
            for future in [thread_pool(self.threads).submit(run, s) for s in starts]:
                future.result()
        else:
            for s in starts:
                run(s)
        return h_out, c_out


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
    """``tanh(a) = 2 σ(2a) − 1`` with [`sigmoid_exp`][predictors.lstm_cell.sigmoid_exp] (compiled)."""
    return 2.0 * sigmoid_exp(2.0 * a) - 1.0


@njit(cache=True, inline="always")
def cell_update(a: np.ndarray, h: np.ndarray, c: np.ndarray, exp_form: bool) -> None:
    """Gates and state of one row from its pre-activation ``a`` (4H,) (bias included): updates ``h, c``
    (H,) in place. ``exp_form``: [`sigmoid_exp`][predictors.lstm_cell.sigmoid_exp] /
    [`tanh_exp`][predictors.lstm_cell.tanh_exp] instead of [`sigmoid_tanh`][predictors.lstm_cell.sigmoid_tanh]
    / ``tanh``."""
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
    ([`LSTMCellWeights.stacked`][predictors.LSTMCellWeights.stacked]), ``b`` (4H,); updates ``h, c`` (H,) in
    place, ``a`` (4H,) is scratch. ``a = b + Σ_k xh_k w_k`` in order of ``k``, then
    [`cell_update`][predictors.lstm_cell.cell_update] with
    [`sigmoid_tanh`][predictors.lstm_cell.sigmoid_tanh]."""
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
    (the products by BLAS), then [`cell_update`][predictors.lstm_cell.cell_update] with
    [`sigmoid_exp`][predictors.lstm_cell.sigmoid_exp]."""
    a = np.dot(h, w_hh) + np.dot(x, w_ih)  # (n, 4H)
    for k in range(x.shape[0]):
        for g in range(a.shape[1]):
            a[k, g] += b[g]
        cell_update(a[k], h[k], c[k], True)


__all__ = [
    "MATMULS",
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
