"""The fixed parts of the pose predictor's network that both of its implementations build: the
torch module ([`predictors.pose_lstm.network`][predictors.pose_lstm.network], training) and the numpy
inference ([`predictors.pose_lstm.predictor`][predictors.pose_lstm.predictor]), so neither reads them from the
other."""

from __future__ import annotations

#: The model kind of the pose predictor in a model file.
KIND = "pose-lstm"
#: The negative slope of the FC block's leaky ReLU (torch's default).
LEAKY_SLOPE = 0.01
#: Bounds of the predicted ``log σ`` (scaled units), for a finite loss.
LOG_SIGMA_RANGE = (-6.0, 4.0)
