"""The displacement LSTM of the LSTM particle filter (torch): one LSTM layer and a linear head.

Jung, Schlangen and Charlish, "Sequential Monte Carlo Filtering with Long Short-Term Memory
Prediction" (FUSION 2019), Fig. 1 and Sec. IV-A: an LSTM of ``H = 25`` hidden units reads the
previous rotation and speed ``(r_{t−1}, s_{t−1})`` of a trajectory
([`predictors.displacement.geometry`][predictors.displacement.geometry]) and a linear head predicts the
current ``(r̂_t, ŝ_t)``; during training the *input* activations are dropped independently with probability
0.25. Both inputs and outputs are scaled, ``(r / r̄, s / s̄)``
([`DisplacementFeatures`][predictors.displacement_lstm.inference.DisplacementFeatures]): ``s̄`` is the mean
speed of the training data, so a model learnt in one unit system runs in another by passing that system's
speed scale.

The network runs whole sequences for training
([`DisplacementLSTMNet.forward`][predictors.displacement_lstm.network.DisplacementLSTMNet.forward], from the
zero state) and one step at a time with an explicit ``(h, c)``
([`DisplacementLSTMNet.step`][predictors.displacement_lstm.network.DisplacementLSTMNet.step]); tracking runs
the same weights in numpy
([`predictors.displacement_lstm.inference`][predictors.displacement_lstm.inference]).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray
from torch import nn

#: The model kind of the displacement LSTM in a model file.
KIND = "displacement-lstm"
#: Hidden units (Jung et al. 2019, Sec. IV-A).
HIDDEN = 25
#: Input dropout rate during training (Jung et al. 2019, Sec. IV-A).
DROPOUT = 0.25


class DisplacementLSTMNet(nn.Module):
    """``(r_{t−1}, s_{t−1})`` (scaled) → LSTM(H) → linear → ``(r̂_t, ŝ_t)`` (scaled).

    Args:
        hidden: Hidden units ``H`` (default 25).
        dropout: Input dropout rate used in training (default 0.25); the network applies the masks
            it is given ([`draw_masks`][predictors.displacement_lstm.network.DisplacementLSTMNet.draw_masks]),
            so the training loop's seeded generator draws them.
    """

    def __init__(self, hidden: int = HIDDEN, dropout: float = DROPOUT):
        super().__init__()
        if not (isinstance(hidden, int) and hidden >= 1):
            raise ValueError(f"hidden must be an integer >= 1, got {hidden!r}")
        if not 0.0 <= dropout < 1.0:
            raise ValueError(f"dropout must be in [0, 1), got {dropout!r}")
        self.hidden, self.dropout = int(hidden), float(dropout)
        self.lstm = nn.LSTM(2, self.hidden, batch_first=True)
        self.head = nn.Linear(self.hidden, 2)

    def draw_masks(self, shape: tuple[int, ...], generator: torch.Generator) -> torch.Tensor | None:
        """Inverted-dropout masks (keep / (1 − p)) of input shape ``(B, T, 2)``, one per element."""
        if self.dropout == 0.0:
            return None
        keep = 1.0 - self.dropout
        return (torch.rand(shape, generator=generator) < keep).to(torch.float32) / keep

    def forward(self, x: torch.Tensor, masks: torch.Tensor | None = None) -> torch.Tensor:
        """Sequences ``x`` (B, T, 2) from the zero state → outputs (B, T, 2); ``masks`` multiply ``x``."""
        if masks is not None:
            x = x * masks
        out, _ = self.lstm(x)
        return self.head(out)

    def step(
        self, x: torch.Tensor, state: tuple[torch.Tensor, torch.Tensor] | None = None
    ) -> tuple[torch.Tensor, tuple[torch.Tensor, torch.Tensor]]:
        """One step of rows ``x`` (n, 2) with state ``(h, c)`` (n, H) each (zero when ``None``)."""
        if state is None:
            state = (torch.zeros(len(x), self.hidden), torch.zeros(len(x), self.hidden))
        h, c = state
        out, (h_new, c_new) = self.lstm(x[:, None, :], (h[None], c[None]))
        return self.head(out[:, 0]), (h_new[0], c_new[0])

    def numpy_weights(self) -> dict[str, NDArray[np.float32]]:
        """The parameters as float32 arrays, keyed by their state-dict names."""
        return {k: v.detach().cpu().numpy().astype(np.float32) for k, v in self.state_dict().items()}

    def architecture(self) -> dict[str, Any]:
        """The hyper-parameters that fix the tensor shapes (for a model sidecar)."""
        return {"hidden": self.hidden, "dropout": self.dropout, "inputs": ["rotation", "speed"]}
