"""The belt LSTM network (torch): two LSTM layers (64, 32 units) and a linear head.

The topology of Pollithy, Reith-Braun, Pfaff and Hanebeck, "Estimating Uncertainties of Recurrent
Neural Networks in Application to Multitarget Tracking" (2020), Sec. IV-A. One network class serves
the three belt models; they differ in the head and the loss:

* ``lstm``: 2 outputs (the next position), MSE loss;
* ``nll-lstm``: 4 outputs, the next position and ``s = log σ²`` per axis, Gaussian NLL loss (their
  eq. (7));
* ``mc-lstm``: 2 outputs, MSE loss, with *variational* dropout (Gal and Ghahramani, "A
  Theoretically Grounded Application of Dropout in Recurrent Neural Networks", 2016): one Bernoulli
  mask per track for the input of each layer, each layer's recurrent state and the head's input,
  held fixed over all time steps of the track.

Features (:class:`Features`): a measurement ``z`` is first expressed relative to the sensor region,
``u = (z − low) / (high − low)``, so a model trained on one camera window works on a window placed
elsewhere; the input at step ``t`` is ``(u_t, u_t − u_{t−1})`` (the difference is 0 at a track's
first step) and the target is the next displacement ``u_{t+1} − u_t``, both standardised by the
training set's mean and std. The network itself never sees metres.

The network runs step by step (:meth:`BeltLSTMNet.step`) with explicit ``(h, c)`` per layer, so a
tracker carries the hidden state per track and never re-runs a window.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray
from torch import nn

#: Model kinds and the number of head outputs per measurement axis.
HEAD_OUTPUTS = {"lstm": 1, "nll-lstm": 2, "mc-lstm": 1}
#: Hidden units of the two LSTM layers (Pollithy et al. 2020, Sec. IV-A).
HIDDEN = (64, 32)


@dataclass(frozen=True)
class Features:
    """Region-relative, standardised features of a measurement sequence.

    Attributes:
        low, size: The sensor region's lower corner and size (D,), in sensor units.
        in_mean, in_std: Mean and std of the input features ``(u, Δu)`` (2D,).
        out_mean, out_std: Mean and std of the target displacement ``Δu`` (D,).
    """

    low: NDArray[np.float64]
    size: NDArray[np.float64]
    in_mean: NDArray[np.float64]
    in_std: NDArray[np.float64]
    out_mean: NDArray[np.float64]
    out_std: NDArray[np.float64]

    @classmethod
    def fit(cls, tracks: list[NDArray[np.float64]], low: Any, high: Any, floor: float = 1e-9) -> Features:
        """Normalisation statistics of ``tracks`` (each ``(T, D)``) in the region ``[low, high]``."""
        low_a = np.asarray(low, dtype=np.float64)
        size = np.asarray(high, dtype=np.float64) - low_a
        u = [(t - low_a) / size for t in tracks]
        du = np.concatenate([np.diff(x, axis=0) for x in u if len(x) > 1])
        inputs = np.concatenate([np.concatenate([x, _diff0(x)], axis=1) for x in u])
        return cls(
            low_a,
            size,
            inputs.mean(axis=0),
            np.maximum(inputs.std(axis=0), floor),
            du.mean(axis=0),
            np.maximum(du.std(axis=0), floor),
        )

    def to_dict(self) -> dict[str, list[float]]:
        """JSON form for a model sidecar."""
        return {k: np.asarray(getattr(self, k)).tolist() for k in self.__dataclass_fields__}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Features:
        """Inverse of :meth:`to_dict`."""
        return cls(**{k: np.asarray(d[k], dtype=np.float64) for k in cls.__dataclass_fields__})

    def inputs(self, z: NDArray[np.float64], z_prev: NDArray[np.float64] | None) -> NDArray[np.float64]:
        """Standardised input ``(u, Δu)`` (n, 2D) of measurements ``z`` (n, D) after ``z_prev``."""
        u = (z - self.low) / self.size
        du = np.zeros_like(u) if z_prev is None else u - (z_prev - self.low) / self.size
        return (np.concatenate([u, du], axis=-1) - self.in_mean) / self.in_std

    def sequence_inputs(self, z: NDArray[np.float64]) -> NDArray[np.float64]:
        """:meth:`inputs` of a padded batch of sequences ``(B, T, D)`` → ``(B, T, 2D)``."""
        u = (z - self.low) / self.size
        du = np.concatenate([np.zeros_like(u[:, :1]), np.diff(u, axis=1)], axis=1)
        return (np.concatenate([u, du], axis=-1) - self.in_mean) / self.in_std

    def targets(self, z: NDArray[np.float64]) -> NDArray[np.float64]:
        """Standardised next displacement ``(B, T − 1, D)`` of sequences ``(B, T, D)``."""
        du = np.diff((z - self.low) / self.size, axis=1)
        return (du - self.out_mean) / self.out_std

    def position(self, z: NDArray[np.float64], out: NDArray[np.float64]) -> NDArray[np.float64]:
        """The predicted next measurement from the last one ``z`` and the standardised output."""
        return z + self.size * (self.out_mean + self.out_std * out)

    def variance_scale(self) -> NDArray[np.float64]:
        """Factor from a standardised output variance to sensor units², per axis (D,)."""
        return (self.size * self.out_std) ** 2


def _diff0(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.concatenate([np.zeros_like(x[:1]), np.diff(x, axis=0)], axis=0)


class BeltLSTMNet(nn.Module):
    """Two stacked LSTM cells and a linear head, run one time step at a time.

    Args:
        kind: ``"lstm"``, ``"nll-lstm"`` or ``"mc-lstm"``.
        dim: Measurement dimension ``D``; the input has ``2D`` features.
        hidden: Units of the two layers.
        dropout: Variational dropout rate (``mc-lstm`` only; 0 elsewhere).
    """

    def __init__(self, kind: str, dim: int, hidden: tuple[int, int] = HIDDEN, dropout: float = 0.0):
        super().__init__()
        if kind not in HEAD_OUTPUTS:
            raise ValueError(f"kind must be one of {sorted(HEAD_OUTPUTS)}, got {kind!r}")
        if not 0.0 <= dropout < 1.0:
            raise ValueError(f"dropout must be in [0, 1), got {dropout!r}")
        if dropout and kind != "mc-lstm":
            raise ValueError(f"only mc-lstm uses dropout, got dropout={dropout} for {kind!r}")
        self.kind, self.dim, self.hidden, self.dropout = kind, dim, tuple(hidden), float(dropout)
        self.cell1 = nn.LSTMCell(2 * dim, hidden[0])
        self.cell2 = nn.LSTMCell(hidden[0], hidden[1])
        self.head = nn.Linear(hidden[1], HEAD_OUTPUTS[kind] * dim)

    # -- masks ----------------------------------------------------------------------------------
    def mask_sizes(self) -> tuple[int, ...]:
        """Widths of the five dropout masks: layer-1 input and state, layer-2 input and state, head."""
        h1, h2 = self.hidden
        return (2 * self.dim, h1, h1, h2, h2)

    def draw_masks(self, n: int, generator: torch.Generator | None = None) -> list[torch.Tensor] | None:
        """Per-track variational dropout masks (keep / (1 − p)), or ``None`` without dropout."""
        if self.dropout == 0.0:
            return None
        keep = 1.0 - self.dropout
        return [
            (torch.rand(n, w, generator=generator) < keep).to(torch.float32) / keep for w in self.mask_sizes()
        ]

    # -- one step -------------------------------------------------------------------------------
    def step(
        self,
        x: torch.Tensor,
        state: tuple[torch.Tensor, ...],
        masks: list[torch.Tensor] | None = None,
    ) -> tuple[torch.Tensor, tuple[torch.Tensor, ...]]:
        """One time step: input ``x`` (n, 2D), state ``(h1, c1, h2, c2)`` → head output, new state."""
        h1, c1, h2, c2 = state
        if masks is not None:
            x, h1_in, h2_in = x * masks[0], h1 * masks[1], h2 * masks[3]
        else:
            h1_in, h2_in = h1, h2
        h1, c1 = self.cell1(x, (h1_in, c1))
        x2 = h1 * masks[2] if masks is not None else h1
        h2, c2 = self.cell2(x2, (h2_in, c2))
        out = self.head(h2 * masks[4] if masks is not None else h2)
        return out, (h1, c1, h2, c2)

    def zero_state(self, n: int) -> tuple[torch.Tensor, ...]:
        """The zero hidden state of ``n`` new tracks."""
        h1, h2 = self.hidden
        return (torch.zeros(n, h1), torch.zeros(n, h1), torch.zeros(n, h2), torch.zeros(n, h2))

    def forward(self, x: torch.Tensor, masks: list[torch.Tensor] | None = None) -> torch.Tensor:
        """Run whole sequences ``x`` (B, T, 2D) from the zero state; outputs (B, T, outputs)."""
        state = self.zero_state(x.shape[0])
        outs = []
        for t in range(x.shape[1]):
            out, state = self.step(x[:, t], state, masks)
            outs.append(out)
        return torch.stack(outs, dim=1)

    # -- weights as plain arrays ----------------------------------------------------------------
    def numpy_weights(self) -> dict[str, NDArray[np.float32]]:
        """The parameters as float32 arrays, keyed by their state-dict names."""
        return {k: v.detach().cpu().numpy().astype(np.float32) for k, v in self.state_dict().items()}

    def architecture(self) -> dict[str, Any]:
        """The hyper-parameters that fix the tensor shapes (for a model sidecar)."""
        return {"hidden": list(self.hidden), "dropout": self.dropout, "head_outputs": HEAD_OUTPUTS[self.kind]}
