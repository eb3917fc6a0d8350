"""The displacement LSTM of Jung et al. (2019): network, inference, the particle displacement model
and the training recipe."""
