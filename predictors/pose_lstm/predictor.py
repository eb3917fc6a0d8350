"""Inference of the probabilistic pose predictor (Okada et al. 2020, Sec. III) from a model file.

Inputs are *pointwise windows*: the last ``L`` observations ``(x, y, v)`` of one keypoint, ``v``
the visible flag (an invisible step holds ``(0, 0, 0)``, as a new filter's queue in Algorithm 1
does). [`window_features`][predictors.pose_lstm.predictor.window_features] turns a window into the network's
steps ``(Δx, Δy, v)`` — the difference to the previous step where both are visible (0 otherwise), in units of
``scale`` px — and the *attention* step of Fig. 4: the last visible coordinate ``a`` of the window. The
network ([`PosePredictorNet`][predictors.pose_lstm.network.PosePredictorNet]) gives ``μ, log σ`` of the
residual, so the predicted coordinate is ``a + scale · (μ + σ ε)``, ``ε ~ N(0, I)``.

Uncertainty switches (the ablation of Okada et al. 2020, Table II):

* ``epistemic=False``: no dropout in the FC block (the deterministic network);
* ``aleatoric=False``: ``σ`` fixed to ``fixed_sigma`` (default: the model file's homoscedastic
  σ, the RMS residual of the mean prediction on the validation split) instead of the predicted one.

``scale`` is a fraction of the sensor region's height (``height / 72``, 10 px in a 720 px image),
recorded in the model file, so a model transfers between image sizes.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from predictors.lstm_cell import FusedLSTMCell, LSTMCellWeights
from predictors.ordered_product import dropout_rows_product, ordered_product
from predictors.pose_lstm.architecture import KIND, LEAKY_SLOPE, LOG_SIGMA_RANGE
from predictors.pose_lstm.prefix_tree import PrefixTree
from predictors.training.model_file import ModelFile, load_model, require_shapes
from track_envs.infra.compiled import njit

#: The displacement scale as a fraction of the region height.
SCALE_PER_HEIGHT = 1.0 / 72.0

FloatArray = NDArray[np.float64]


def window_features(
    windows: NDArray[np.floating], scale: float
) -> tuple[NDArray[np.float32], FloatArray, NDArray[np.bool_]]:
    """Network inputs and attention anchors of pointwise windows.

    Args:
        windows: (..., L, 3) observations ``(x, y, v)`` oldest first; ``v > 0`` is visible.
        scale: px per network unit.

    Returns:
        ``inputs`` (..., L, 3) float32 ``(Δx / scale, Δy / scale, v)`` with ``Δ`` zero unless the step
            and its predecessor are visible; ``anchor`` (..., 2) the last visible coordinate (px), and
            ``has_anchor`` (...,) whether the window has a visible step.
    """
    w = np.asarray(windows)
    if w.dtype not in (np.float32, np.float64):
        w = w.astype(np.float64)
    lead, L = w.shape[:-2], w.shape[-2]
    flat = np.ascontiguousarray(w.reshape(-1, L, 3))
    n = len(flat)
    inputs = np.empty((n, L, 3), np.float32)
    anchor = np.empty((n, 2), np.float64)
    has = np.empty(n, np.bool_)
    _window_features(flat, float(scale), inputs, anchor, has)
    return inputs.reshape(*lead, L, 3), anchor.reshape(*lead, 2), has.reshape(lead)


@njit(cache=True, nogil=True)
def _window_features(
    w: np.ndarray, scale: float, inputs: np.ndarray, anchor: np.ndarray, has: np.ndarray
) -> None:
    """[`window_features`][predictors.pose_lstm.predictor.window_features] of windows ``w`` (n, L, 3), into
    ``inputs`` (n, L, 3), ``anchor`` (n, 2), ``has`` (n,): ``Δ = (p_t − p_{t−1}) / scale`` in float64, then
    float32."""
    n, L = w.shape[0], w.shape[1]
    for r in range(n):
        last = -1
        prev_vis = False
        for t in range(L):
            vis = w[r, t, 2] > 0
            if vis and prev_vis:
                inputs[r, t, 0] = np.float32((np.float64(w[r, t, 0]) - np.float64(w[r, t - 1, 0])) / scale)
                inputs[r, t, 1] = np.float32((np.float64(w[r, t, 1]) - np.float64(w[r, t - 1, 1])) / scale)
            else:
                inputs[r, t, 0] = 0.0
                inputs[r, t, 1] = 0.0
            inputs[r, t, 2] = 1.0 if vis else 0.0
            if vis:
                last = t
            prev_vis = vis
        has[r] = last >= 0
        if last >= 0:
            anchor[r, 0] = np.float64(w[r, last, 0])
            anchor[r, 1] = np.float64(w[r, last, 1])
        else:
            anchor[r, 0] = 0.0
            anchor[r, 1] = 0.0


#: Bits of the random field that decides one dropout unit
#: ([`dropout_fields`][predictors.pose_lstm.predictor.dropout_fields]).
FIELD_BITS = 16


def keep_threshold(dropout: float) -> int:
    """The field value below which a unit is kept: ``round((1 − p) · 2¹⁶)``, so a unit is kept with
    probability ``threshold / 2¹⁶`` (45,875 / 65,536 = 0.6999969 for ``p = 0.3``; exact where
    ``(1 − p) · 2¹⁶`` is an integer)."""
    return round((1.0 - float(dropout)) * (1 << FIELD_BITS))


def dropout_fields(rng: np.random.Generator, rows: int, units: int) -> NDArray[np.uint16]:
    """The random fields of ``rows`` dropout masks of ``units`` units, (rows, units) uint16.

    One draw ``rng.integers(0, 2⁶⁴, ⌈rows · units / 4⌉, dtype=uint64)`` read as consecutive 16-bit
    fields (the machine's byte order, little-endian on x86 and ARM), row by row: unit ``k`` of mask
    ``i`` is kept iff field ``(i, k)`` is below
    [`keep_threshold`][predictors.pose_lstm.predictor.keep_threshold]. Four decisions per 64 random bits,
    instead of one float uniform each.
    """
    n = rows * units
    words = rng.integers(0, 1 << 64, size=-(-n // 4), dtype=np.uint64)
    return words.view(np.uint16)[:n].reshape(rows, units)


def dropout_masks(rng: np.random.Generator, rows: int, units: int, dropout: float) -> NDArray[np.float32]:
    """Inverted-dropout masks (rows, units) float32 of
    [`dropout_fields`][predictors.pose_lstm.predictor.dropout_fields]: ``1 / (1 − p)`` for a kept unit
    (``1 − p`` in float32), 0 for a dropped one (what the CPU head applies, as a matrix)."""
    keep = np.float32(1.0 - dropout)
    kept = dropout_fields(rng, rows, units) < keep_threshold(dropout)
    return (kept / keep).astype(np.float32, copy=False)


@dataclass(frozen=True)
class PoseStats:
    """The normalisation and the homoscedastic σ of a pose model."""

    scale_per_height: float
    fixed_sigma: tuple[float, float]


class PosePredictor:
    """The probabilistic pose predictor: pointwise windows → sampled next coordinates.

    The LSTM runs through the inference cell of every learned family,
    [`predictors.lstm_cell.FusedLSTMCell`][predictors.lstm_cell.FusedLSTMCell] (float32, built from the model
    file's ``lstm.*`` tensors; [`sequence`][predictors.lstm_cell.FusedLSTMCell.sequence] over the windows,
    blocks of rows), and the fully-connected head runs in numpy; every product of both sums each element in a
    fixed order ([`predictors.ordered_product`][predictors.ordered_product], on ``torch.get_num_threads()``
    threads), so a window's result has the same bits whichever other windows are computed with it. That makes
    [`encode_shared`][predictors.pose_lstm.predictor.PosePredictor.encode_shared] (one LSTM step per distinct
    window prefix) and ``head_of(..., rows=...)`` (the head's first layer once per distinct window) exact
    shortcuts of [`encode`][predictors.pose_lstm.predictor.PosePredictor.encode] and the head over every row.

    Tolerance: the outputs equal the network's (``PosePredictorNet``, torch's oneDNN LSTM and its
    GEMMs) to 1e-6 (tested on the shipped weights), not bit for bit: torch sums in other orders.
    Against the earlier inference (torch's GEMM in the cell, the network's head) the pose-smc
    reports keep every id and move positions by at most 6.1e-5 px (one float32 ulp at 500 px) on
    the pinned scene of ``tests/agents/test_pose_smc.py``.

    Args:
        model: A ``pose-lstm`` model file (path or loaded).
    """

    def __init__(self, model: ModelFile | str | os.PathLike[str]) -> None:
        import torch

        from predictors.pose_lstm.network import PosePredictorNet

        m = model if isinstance(model, ModelFile) else load_model(model, kind=KIND, dim=2)
        if m.kind != KIND:
            raise ValueError(f"expected a {KIND!r} model, got {m.kind!r}")
        arch = m.architecture
        net = PosePredictorNet(int(arch["hidden"]), int(arch["fc"]), float(arch["dropout"]))
        shapes = {k: tuple(v.shape) for k, v in net.state_dict().items()}
        require_shapes(m, shapes)
        net.load_state_dict({k: torch.as_tensor(np.asarray(v)) for k, v in m.tensors.items()})
        net.eval()
        self.net = net
        self.model = m
        norm = m.meta.get("normalisation", {})
        sig = m.meta.get("metrics", {}).get("fixed_sigma", [1.0, 1.0])
        self.stats = PoseStats(
            float(norm.get("scale_per_height", SCALE_PER_HEIGHT)), (float(sig[0]), float(sig[1]))
        )
        self.hidden = net.hidden
        self.dropout = net.dropout
        #: The LSTM layer as the shared float32 cell, its products in a fixed order.
        self._cell = LSTMCellWeights.from_tensors(m.tensors, "lstm.", "_l0").fused(matmul="ordered")
        self.fc_units = net.fc_units
        t = {k: np.asarray(v, dtype=np.float32) for k, v in m.tensors.items()}
        self._w1, self._b1 = np.ascontiguousarray(t["fc.weight"].T), t["fc.bias"]
        self._w2, self._b2 = np.ascontiguousarray(t["out.weight"].T), t["out.bias"]

    @property
    def cell(self) -> FusedLSTMCell:
        """The LSTM layer as the shared float32 cell, its products summed in a fixed order
        ([`predictors.ordered_product`][predictors.ordered_product]) on ``torch.get_num_threads()``
        threads."""
        import torch

        threads = torch.get_num_threads()
        if self._cell.threads != threads:
            self._cell = dataclasses.replace(self._cell, threads=threads)
        return self._cell

    def scale_for(self, region_height: float) -> float:
        """px per network unit in a sensor region ``region_height`` px high."""
        return float(region_height) * self.stats.scale_per_height

    def distribution(
        self, inputs: NDArray[np.float32], rng: np.random.Generator | None, *, epistemic: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """``μ, σ`` (M, 2) in network units of the windows ``inputs`` (M, L, 3).

        With ``epistemic`` one dropout mask per window is drawn from ``rng``.
        """
        return self.head_of(self.encode(inputs), rng, epistemic)

    def encode(self, inputs: NDArray[np.float32]) -> NDArray[np.float32]:
        """The LSTM's last output ``h`` (M, H) of the windows ``inputs`` (M, L, 3) (deterministic)."""
        return self.cell.sequence(np.asarray(inputs, dtype=np.float32))[0]

    def encode_shared(self, inputs: NDArray[np.float32]) -> NDArray[np.float32]:
        """[`encode`][predictors.pose_lstm.predictor.PosePredictor.encode] with one LSTM step per distinct
        input prefix ([`PrefixTree`][predictors.pose_lstm.prefix_tree.PrefixTree]): the same bits, fewer
        steps."""
        x = np.ascontiguousarray(inputs, dtype=np.float32)
        return PrefixTree.of(x).encode(self.cell, x)

    def encode_leaves(self, inputs: NDArray[np.float32]) -> tuple[NDArray[np.float32], NDArray[np.intp]]:
        """[`encode_shared`][predictors.pose_lstm.predictor.PosePredictor.encode_shared] as the outputs ``h``
        (k, H) of the distinct windows and each window's row ``leaf`` (M,) among them (``h[leaf]`` is
        [`encode`][predictors.pose_lstm.predictor.PosePredictor.encode]'s result, bit for bit), for
        ``head_of(h, ..., rows=leaf[...])``."""
        x = np.ascontiguousarray(inputs, dtype=np.float32)
        tree = PrefixTree.of(x)
        return tree.encode_nodes(self.cell, x), tree.leaf

    def head_of(
        self,
        h: NDArray[np.float32],
        rng: np.random.Generator | None,
        epistemic: bool = True,
        rows: NDArray[np.intp] | None = None,
    ) -> tuple[FloatArray, FloatArray]:
        """``μ, σ`` (M, 2) of LSTM outputs: row ``r`` of the result reads ``h[rows[r]]`` (``h`` (U, H),
        ``rows`` (M,); every row of ``h`` once if None), as
        [`distribution`][predictors.pose_lstm.predictor.PosePredictor.distribution].

        The FC block ``y = W₂ (m ⊙ leaky(W₁ h + b₁)) + b₂`` with one dropout mask ``m`` per result
        row (``epistemic``; inverted, ``keep / (1 − p)``; its decisions drawn from ``rng`` as one
        block of 16-bit fields, [`dropout_fields`][predictors.pose_lstm.predictor.dropout_fields]):
        ``leaky(W₁ h + b₁) / (1 − p)`` is computed once per row of ``h`` and shared by the result rows that
        read it. Products by [`ordered_product`][predictors.ordered_product.ordered_product] and
        [`dropout_rows_product`][predictors.ordered_product.dropout_rows_product], so a result row's bits do
        not depend on which other rows are computed with it.

        Raises:
            ValueError: ``epistemic`` sampling without ``rng``.
        """
        h = np.ascontiguousarray(h, dtype=np.float32)
        m = len(h) if rows is None else len(rows)
        a = np.empty((len(h), self.fc_units), np.float32)
        threads = self.cell.threads
        ordered_product(h, self._w1, a, threads)
        a += self._b1
        np.maximum(a, a * np.float32(LEAKY_SLOPE), out=a)  # leaky ReLU
        if rows is None:
            rows = np.arange(len(h))
        fields = np.zeros((0, self.fc_units), np.uint16)  # none: every unit kept
        threshold = 1 << FIELD_BITS
        if epistemic and self.dropout > 0:
            if rng is None:
                raise ValueError("epistemic sampling needs a random generator")
            keep = np.float32(1.0 - self.dropout)
            a *= np.float32(1.0) / keep  # the inverted dropout's scale, a kept unit's mask value
            fields = dropout_fields(rng, m, self.fc_units)
            threshold = keep_threshold(self.dropout)
        y = np.empty((m, 4), np.float32)
        dropout_rows_product(a, np.asarray(rows, dtype=np.intp), fields, threshold, self._w2, y, threads)
        y += self._b2
        log_sigma = np.clip(y[:, 2:], *LOG_SIGMA_RANGE)
        return y[:, :2].astype(np.float64), np.exp(log_sigma.astype(np.float64))

    def step(
        self, x: NDArray[np.float32], state: tuple[NDArray[np.float32], NDArray[np.float32]] | None
    ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """One LSTM step of rows ``x`` (M, 3) from ``state`` ``(h, c)`` ((M, H) each; zero if None)."""
        return self.cell.sequence(np.asarray(x, dtype=np.float32)[:, None, :], state)

    def sample(
        self,
        windows: NDArray[np.floating],
        scale: float,
        rng: np.random.Generator,
        *,
        epistemic: bool = True,
        aleatoric: bool = True,
        fixed_sigma: float | tuple[float, float] | None = None,
    ) -> tuple[FloatArray, NDArray[np.bool_]]:
        """One sampled next coordinate (..., 2) px per window (..., L, 3), and whether it has an anchor.

        ``z = a + scale · (μ + σ ε)``; windows without a visible step predict ``(0, 0)``.
        """
        inputs, anchor, has = window_features(windows, scale)
        lead = inputs.shape[:-2]
        mu, sigma = self.distribution(inputs.reshape(-1, *inputs.shape[-2:]), rng, epistemic=epistemic)
        return self.draw(
            mu, sigma, anchor.reshape(-1, 2), scale, rng, aleatoric=aleatoric, fixed_sigma=fixed_sigma
        ).reshape(*lead, 2), has

    def draw(
        self,
        mu: FloatArray,
        sigma: FloatArray,
        anchor: FloatArray,
        scale: float,
        rng: np.random.Generator,
        *,
        aleatoric: bool = True,
        fixed_sigma: float | tuple[float, float] | None = None,
    ) -> FloatArray:
        """``a + scale · (μ + σ ε)`` (M, 2), with σ predicted (``aleatoric``) or fixed."""
        if not aleatoric:
            fixed = self.stats.fixed_sigma if fixed_sigma is None else fixed_sigma
            sigma = np.broadcast_to(np.asarray(fixed, dtype=np.float64), mu.shape)
        eps = rng.standard_normal(mu.shape)
        return anchor + scale * (mu + sigma * eps)
