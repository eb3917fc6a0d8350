"""The probabilistic neural pose predictor of Okada et al. (2020), Fig. 4, as a torch module.

Okada, Takenaka and Taniguchi, "Multi-person Pose Tracking using Sequential Monte Carlo with
Probabilistic Neural Pose Predictor" (ICRA 2020), Sec. III. Pointwise: every keypoint of a pose is
one sequence. Each of the ``L`` steps of a sequence is ``(Δx, Δy, v)``
([`predictors.pose_lstm.predictor.window_features`][predictors.pose_lstm.predictor.window_features]); an LSTM
of 64 units reads the sequence from the zero state (stateless, the window is the whole context); its last
output goes through a fully-connected block with one hidden layer of 40 leaky-ReLU units and dropout 0.3, and
a linear layer gives the mean ``μ`` and ``log σ`` of a Gaussian over the residual from the last visible
coordinate of the sequence (the "attention" step of Fig. 4, done outside the network).

* **Epistemic uncertainty**: the dropout of the FC block is applied at training *and* test time
  (dropout as variational inference, Gal and Ghahramani 2016); the masks are passed in, so a
  seeded generator draws them.
* **Heteroscedastic aleatoric uncertainty**: ``σ`` depends on the input.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray
from torch import nn

from predictors.pose_lstm.architecture import LEAKY_SLOPE, LOG_SIGMA_RANGE

#: LSTM units (Okada et al. 2020, Fig. 4).
HIDDEN = 64
#: Hidden units of the fully-connected block.
FC = 40
#: Dropout rate of the fully-connected block (training and test).
DROPOUT = 0.3


class PosePredictorNet(nn.Module):
    """``(Δx, Δy, v)`` sequences (B, L, 3) → ``μ`` (B, 2) and ``log σ`` (B, 2) of the residual.

    Args:
        hidden: LSTM units (64).
        fc: Hidden units of the fully-connected block (40).
        dropout: Dropout rate of the FC block (0.3).
    """

    def __init__(self, hidden: int = HIDDEN, fc: int = FC, dropout: float = DROPOUT):
        super().__init__()
        for name, value in (("hidden", hidden), ("fc", fc)):
            if not (isinstance(value, int) and value >= 1):
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        if not 0.0 <= dropout < 1.0:
            raise ValueError(f"dropout must be in [0, 1), got {dropout!r}")
        self.hidden, self.fc_units, self.dropout = int(hidden), int(fc), float(dropout)
        self.lstm = nn.LSTM(3, self.hidden, batch_first=True)
        self.fc = nn.Linear(self.hidden, self.fc_units)
        self.out = nn.Linear(self.fc_units, 4)

    def draw_masks(self, n: int, generator: torch.Generator) -> torch.Tensor | None:
        """Inverted-dropout masks (keep / (1 − p)) of the FC hidden layer, (n, fc), one per sequence."""
        if self.dropout == 0.0:
            return None
        keep = 1.0 - self.dropout
        return (torch.rand((n, self.fc_units), generator=generator) < keep).to(torch.float32) / keep

    def forward(
        self, x: torch.Tensor, masks: torch.Tensor | None = None
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Sequences ``x`` (B, L, 3) → ``(μ, log σ)`` (B, 2) each; ``masks`` (B, fc) scale the FC layer."""
        _, (h, _) = self.lstm(x)
        return self.head(h[0], masks)

    def head(self, h: torch.Tensor, masks: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        """The FC block on LSTM outputs ``h`` (B, hidden) → ``(μ, log σ)``."""
        a = nn.functional.leaky_relu(self.fc(h), LEAKY_SLOPE)
        if masks is not None:
            a = a * masks
        y = self.out(a)
        return y[:, :2], y[:, 2:].clamp(*LOG_SIGMA_RANGE)

    def numpy_weights(self) -> dict[str, NDArray[np.float32]]:
        """The parameters as float32 arrays, keyed by their state-dict names."""
        return {k: v.detach().cpu().numpy().astype(np.float32) for k, v in self.state_dict().items()}

    def architecture(self) -> dict[str, Any]:
        """The hyper-parameters that fix the tensor shapes (for a model sidecar)."""
        return {
            "hidden": self.hidden,
            "fc": self.fc_units,
            "dropout": self.dropout,
            "inputs": ["dx", "dy", "visible"],
            "outputs": ["mu_x", "mu_y", "log_sigma_x", "log_sigma_y"],
        }
