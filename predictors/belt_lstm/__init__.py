"""The belt LSTMs of Pollithy et al. (2020): network, numpy/compiled inference, the batched predictor
(MSE, NLL and MC-dropout heads), the roll-out to the nozzle bar and the training recipe."""

from __future__ import annotations

from typing import TYPE_CHECKING

from predictors.belt_lstm.predictor import LSTMPredictor
from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from predictors.belt_lstm.network import BeltLSTMNet
    from predictors.belt_lstm.predictor import shipped_weights

#: The module of each name loaded on first access (``__getattr__``), so that importing
#: the package stays light.
_LAZY: dict[str, str] = {
    "BeltLSTMNet": "predictors.belt_lstm.network",
    "shipped_weights": "predictors.belt_lstm.predictor",
}

__all__ = [
    "BeltLSTMNet",
    "LSTMPredictor",
    "shipped_weights",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
