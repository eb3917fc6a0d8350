"""Inference of the probabilistic pose predictor (Okada et al. 2020, Sec. III) from a model file.

Inputs are *pointwise windows*: the last ``L`` observations ``(x, y, v)`` of one keypoint, ``v``
the visible flag (an invisible step holds ``(0, 0, 0)``, as a new filter's queue in Algorithm 1
does). :func:`window_features` turns a window into the network's steps ``(Δx, Δy, v)`` — the
difference to the previous step where both are visible (0 otherwise), in units of ``scale`` px —
and the *attention* step of Fig. 4: the last visible coordinate ``a`` of the window. The network
(:class:`~predictors.pose_lstm.network.PosePredictorNet`) gives ``μ, log σ`` of the residual, so the
predicted coordinate is ``a + scale · (μ + σ ε)``, ``ε ~ N(0, I)``.

Uncertainty switches (the ablation of Okada et al. 2020, Table II):

* ``epistemic=False``: no dropout in the FC block (the deterministic network);
* ``aleatoric=False``: ``σ`` fixed to ``fixed_sigma`` (default: the model file's homoscedastic
  σ, the RMS residual of the mean prediction on the validation split) instead of the predicted one.

``scale`` is a fraction of the sensor region's height (``height / 72``, 10 px in a 720 px image),
recorded in the model file, so a model transfers between image sizes.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from predictors.lstm_cell import LSTMCellWeights
from predictors.training.model_file import ModelFile, load_model, require_shapes

KIND = "pose-lstm"
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
    w = np.asarray(windows, dtype=np.float64)
    pos, vis = w[..., :2], w[..., 2] > 0
    both = vis[..., 1:] & vis[..., :-1]
    d = np.zeros_like(pos)
    d[..., 1:, :] = np.where(both[..., None], (pos[..., 1:, :] - pos[..., :-1, :]) / scale, 0.0)
    inputs = np.concatenate([d, vis[..., None]], axis=-1).astype(np.float32)
    L = w.shape[-2]
    last = L - 1 - np.argmax(vis[..., ::-1], axis=-1)  # index of the last visible step
    anchor = np.take_along_axis(pos, last[..., None, None], axis=-2)[..., 0, :]
    has: NDArray[np.bool_] = np.asarray(vis.any(axis=-1), dtype=bool)
    return inputs, np.where(has[..., None], anchor, 0.0), has


@dataclass(frozen=True)
class PoseStats:
    """The normalisation and the homoscedastic σ of a pose model."""

    scale_per_height: float
    fixed_sigma: tuple[float, float]


class PosePredictor:
    """The probabilistic pose predictor: pointwise windows → sampled next coordinates.

    The LSTM runs through the inference cell of every learned family,
    :class:`predictors.lstm_cell.FusedLSTMCell` (float32, built from the model file's ``lstm.*``
    tensors; :meth:`~predictors.lstm_cell.FusedLSTMCell.sequence` over the windows, blocks of rows),
    its products by ``torch.matmul`` (``matmul="torch"``): torch's GEMM follows
    ``torch.set_num_threads`` and gives the same bits at any thread count, which numpy's BLAS does
    not. At one thread this encodes a pose-smc frame's windows ≈1.2x faster than torch's
    ``nn.LSTM``. The fully-connected head is the network's
    (:meth:`PosePredictorNet.head <predictors.pose_lstm.network.PosePredictorNet.head>`).

    Tolerance: the LSTM outputs equal ``PosePredictorNet.lstm`` (torch's oneDNN kernel) to 1e-6
    (tested on the shipped weights), not bit for bit: the two float32 GEMMs sum in different
    orders. This moves the pose-smc tracker's mean OKS by < 1e-9 on the quick suite and by
    < 5e-9 on the okada2020 scene (8 variants, seeds 0 and 1, 100 frames), and leaves every other
    metric there equal (MOTA, ID switches, misses, false positives, OKS recall and precision).

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
        #: The LSTM layer as the shared float32 cell.
        self.cell = LSTMCellWeights.from_tensors(m.tensors, "lstm.", "_l0").fused(matmul="torch")

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

    def _head(
        self, h: Any, rng: np.random.Generator | None, epistemic: bool
    ) -> tuple[FloatArray, FloatArray]:
        import torch

        masks = None
        if epistemic and self.dropout > 0:
            if rng is None:
                raise ValueError("epistemic sampling needs a random generator")
            keep = 1.0 - self.dropout
            masks = torch.from_numpy(
                (rng.random((h.shape[0], self.net.fc_units), dtype=np.float32) < keep) / np.float32(keep)
            )
        with torch.inference_mode():
            mu, log_sigma = self.net.head(h, masks)
        return mu.numpy().astype(np.float64), np.exp(log_sigma.numpy().astype(np.float64))

    def head_of(
        self, h: NDArray[np.float32], rng: np.random.Generator | None, epistemic: bool = True
    ) -> tuple[FloatArray, FloatArray]:
        """``μ, σ`` (M, 2) of LSTM outputs ``h`` (M, H) (a carried state), as :meth:`distribution`."""
        import torch

        return self._head(torch.from_numpy(np.ascontiguousarray(h, dtype=np.float32)), rng, epistemic)

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
