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

Features ([`Features`][predictors.belt_lstm.features.Features]): a measurement ``z`` is first expressed
relative to the sensor region, ``u = (z − low) / (high − low)``, so a model trained on one camera window works
on a window placed elsewhere; the input at step ``t`` is ``(u_t, u_t − u_{t−1})`` (the difference is 0 at a
track's first step) and the target is the next displacement ``u_{t+1} − u_t``, both standardised by the
training set's mean and std. The network itself never sees metres.

The network runs step by step ([`BeltLSTMNet.step`][predictors.belt_lstm.network.BeltLSTMNet.step]) with
explicit ``(h, c)`` per layer, so a tracker carries the hidden state per track and never re-runs a window.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray
from torch import nn

from predictors.belt_lstm.features import Features as Features  # re-exported: the training code reads it here

#: Model kinds and the number of head outputs per measurement axis.
HEAD_OUTPUTS = {"lstm": 1, "nll-lstm": 2, "mc-lstm": 1}
#: Hidden units of the two LSTM layers (Pollithy et al. 2020, Sec. IV-A).
HIDDEN = (64, 32)


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
