"""The belt LSTMs of Pollithy et al. (2020): network, numpy/compiled inference, the batched predictor
(MSE, NLL and MC-dropout heads), the roll-out to the nozzle bar and the training recipe."""

from __future__ import annotations

from typing import TYPE_CHECKING

from predictors.belt_lstm.predictor import LSTMPredictor
from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from predictors.belt_lstm.network import BeltLSTMNet
    from predictors.belt_lstm.predictor import shipped_weights

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
