"""The belt LSTMs of Pollithy et al. (2020): network, numpy/compiled inference, the batched predictor
(MSE, NLL and MC-dropout heads), the roll-out to the nozzle bar and the training recipe."""

from predictors.belt_lstm.predictor import LSTMPredictor

__all__ = ["LSTMPredictor"]
